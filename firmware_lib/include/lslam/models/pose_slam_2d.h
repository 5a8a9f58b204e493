#pragma once
// The 2D pose graph as a model: SE2 poses only, with pose priors and odometry/loop closures.
// Slam2D without its landmark kind, so that every block is 3 x 3: the factorization is the
// one-size kind, with the supernodal refactorization and the AVX2/FMA 3x3 kernels of an x86-64
// host.
#include "lslam/factors/se2_factors.h"
#include "lslam/geometry/se2.h"
#include "lslam/type_list.h"

namespace lslam {

struct PoseSlam2D {
  using Variables = TypeList<SE2>;
  using Factors = TypeList<PriorSE2Factor, BetweenSE2Factor>;
  // The factor the solver anchors the first pose with (see smoother.h, the gauge).
  using PosePrior = PriorSE2Factor;
  // The odometry and loop-closure kind (CompactPoseGraph derives its measurements in it).
  using PoseBetween = BetweenSE2Factor;
};

}  // namespace lslam
