#pragma once
// Two Gaussian measurements of one relative pose as one: the information-weighted mean on the
// manifold (one Gauss-Newton step from the first), z = z1 (+) (O1 + O2)^-1 O2 (z2 (-) z1), with
// information O1 + O2. Exact for a linear error; on the manifold it differs from keeping both
// factors at second order in the measurements' spread (a few noise sigmas here).
#include "lslam/eigen.h"

namespace lslam {

// G: SE2 or SE3 (retract / localCoordinates in right-perturbation coordinates, the between
// factors' error coordinates to first order).
template <class G>
G mergedMeasurement(const G& z1, const Eigen::Matrix<double, G::kDof, G::kDof>& information1,
                    const G& z2, const Eigen::Matrix<double, G::kDof, G::kDof>& information2,
                    Eigen::Matrix<double, G::kDof, G::kDof>* information) noexcept {
  using Matrix = Eigen::Matrix<double, G::kDof, G::kDof>;
  const Matrix sum = information1 + information2;
  const auto d = z1.localCoordinates(z2);
  const auto step = sum.llt().solve(information2 * d).eval();
  *information = sum;
  return z1.retract(step);
}

}  // namespace lslam
