#pragma once
// The 3D pose graph: SE3 poses only, with pose priors and odometry/loop closures. Slam3D without
// its landmark kind, so that every block is 6 x 6: the factorization is the one-size kind, whose
// pool is an array of 6 x 6 blocks that the AVX2/FMA kernels of an x86-64 host work on (mixed
// sizes take Eigen's fixed-size products).
#include "lslam/factors/se3_factors.h"
#include "lslam/geometry/se3.h"
#include "lslam/type_list.h"

namespace lslam {

struct PoseSlam3D {
  using Variables = TypeList<SE3>;
  using Factors = TypeList<PriorSE3Factor, BetweenSE3Factor>;
  // The factor the solver anchors the first pose with (see smoother.h, the gauge).
  using PosePrior = PriorSE3Factor;
  // The odometry and loop-closure kind (CompactPoseGraph derives its measurements in it).
  using PoseBetween = BetweenSE3Factor;
};

}  // namespace lslam
