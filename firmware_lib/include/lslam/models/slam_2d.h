#pragma once
// The 2D model: SE2 poses and Point2 landmarks; pose priors and odometry/loop closures, landmark
// priors, and landmark observations as a position in the robot frame or as range and bearing. A
// pose graph is the same model with no landmarks.
#include "lslam/factors/landmark_2d_factors.h"
#include "lslam/factors/point_priors.h"
#include "lslam/factors/se2_factors.h"
#include "lslam/geometry/point.h"
#include "lslam/geometry/se2.h"
#include "lslam/type_list.h"

namespace lslam {

struct Slam2D {
  using Variables = TypeList<SE2, Point2>;
  using Factors = TypeList<PriorSE2Factor, BetweenSE2Factor, PriorPoint2Factor,
                           PointObservationSE2Factor, RangeBearingSE2Factor>;
  // The factor the solver anchors the first pose with (see smoother.h, the gauge).
  using PosePrior = PriorSE2Factor;
  // The odometry and loop-closure kind (CompactPoseGraph derives its measurements in it).
  // The landmark observation CompactPoseGraph derives and folds.
  using PointObservation = PointObservationSE2Factor;
  using PoseBetween = BetweenSE2Factor;
};

}  // namespace lslam
