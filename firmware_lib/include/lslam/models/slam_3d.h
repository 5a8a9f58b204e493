#pragma once
// The 3D model: SE3 poses and Point3 landmarks; pose priors and odometry/loop closures, landmark
// priors, and point observations as a position in the robot frame. A pose graph is the same
// model with no landmarks.
#include "lslam/factors/point_observation_3d.h"
#include "lslam/factors/point_priors.h"
#include "lslam/factors/se3_factors.h"
#include "lslam/geometry/point.h"
#include "lslam/geometry/se3.h"
#include "lslam/type_list.h"

namespace lslam {

struct Slam3D {
  using Variables = TypeList<SE3, Point3>;
  using Factors =
      TypeList<PriorSE3Factor, BetweenSE3Factor, PriorPoint3Factor, PointObservationSE3Factor>;
  // The factor the solver anchors the first pose with (see smoother.h, the gauge).
  using PosePrior = PriorSE3Factor;
  // The odometry and loop-closure kind (CompactPoseGraph derives its measurements in it).
  // The landmark observation CompactPoseGraph derives and folds.
  using PointObservation = PointObservationSE3Factor;
  using PoseBetween = BetweenSE3Factor;
};

}  // namespace lslam
