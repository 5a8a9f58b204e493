#pragma once
// The single way firmware_lib includes Eigen: fixed-size types only, and Eigen's own assertions
// routed to lslam's handler (Eigen's default is the C assert, whose newlib failure path pulls in
// fprintf and malloc on a bare-metal target).
#include "lslam/assert.h"

#if !defined(eigen_assert) && !defined(NDEBUG)
#define eigen_assert(x) LSLAM_ASSERT(x)
#endif

#include <Eigen/Core>

namespace lslam {

using Vec2 = Eigen::Matrix<double, 2, 1>;
using Vec3 = Eigen::Matrix<double, 3, 1>;
using Mat2 = Eigen::Matrix<double, 2, 2>;
using Mat3 = Eigen::Matrix<double, 3, 3>;

}  // namespace lslam
