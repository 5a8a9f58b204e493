#pragma once
// Two Gaussian measurements of one relative pose as one: the information-weighted mean on the
// manifold (one Gauss-Newton step from the first), z = z1 (+) (O1 + O2)^-1 O2 (z2 (-) z1), with
// information O1 + O2. Exact for a linear error; on the manifold it differs from keeping both
// factors at second order in the measurements' spread (a few noise sigmas here).
#include "lslam/eigen.h"

namespace lslam {

// The between factors' error per tangent coordinate at zero error, e = S tau: SE2's error is
// (x, y, theta) of the residual pose (S = I); SE3's is (t, v) with v the residual quaternion's
// vector part, about half the rotation vector (S = diag(1, 1, 1, 1/2, 1/2, 1/2)).
template <class G>
Eigen::Matrix<double, G::kDof, G::kDof> betweenErrorPerTangent() noexcept {
  Eigen::Matrix<double, G::kDof, G::kDof> s = Eigen::Matrix<double, G::kDof, G::kDof>::Identity();
  if constexpr (G::kDof == 6) s.template bottomRightCorner<3, 3>() *= 0.5;
  return s;
}

// The inverse of a positive-definite matrix the size of G's tangent from its factorization, a
// column at a time: a matrix right-hand side takes Eigen's blocked solver, whose workspace may
// come from the heap.
template <class G>
Eigen::Matrix<double, G::kDof, G::kDof> positiveDefiniteInverse(
    const Eigen::LLT<Eigen::Matrix<double, G::kDof, G::kDof>>& llt) noexcept {
  using Matrix = Eigen::Matrix<double, G::kDof, G::kDof>;
  Matrix inverse;
  for (int c = 0; c < G::kDof; ++c) inverse.col(c) = llt.solve(Matrix::Identity().col(c));
  return inverse;
}

template <class G>
Eigen::Matrix<double, G::kDof, G::kDof> positiveDefiniteInverse(
    const Eigen::Matrix<double, G::kDof, G::kDof>& spd) noexcept {
  return positiveDefiniteInverse<G>(Eigen::LLT<Eigen::Matrix<double, G::kDof, G::kDof>>(spd));
}

// A between measurement's information (error coordinates) as a covariance in the tangent.
template <class G>
Eigen::Matrix<double, G::kDof, G::kDof> betweenTangentCovariance(
    const Eigen::Matrix<double, G::kDof, G::kDof>& information) noexcept {
  Eigen::Matrix<double, G::kDof, G::kDof> inverse_s = betweenErrorPerTangent<G>();
  inverse_s.diagonal() = inverse_s.diagonal().cwiseInverse();
  return inverse_s * positiveDefiniteInverse<G>(information) * inverse_s;
}

// G: SE2 or SE3, with information in the between factors' error coordinates (retract and
// localCoordinates work in the tangent: betweenErrorPerTangent converts).
template <class G>
G mergedMeasurement(const G& z1, const Eigen::Matrix<double, G::kDof, G::kDof>& information1,
                    const G& z2, const Eigen::Matrix<double, G::kDof, G::kDof>& information2,
                    Eigen::Matrix<double, G::kDof, G::kDof>* information) noexcept {
  using Matrix = Eigen::Matrix<double, G::kDof, G::kDof>;
  const Matrix sum = information1 + information2;
  const Matrix s = betweenErrorPerTangent<G>();
  const auto d = (s * z1.localCoordinates(z2)).eval();  // in error coordinates
  const auto step = sum.llt().solve(information2 * d).eval();
  *information = sum;
  return z1.retract(s.diagonal().cwiseInverse().asDiagonal() * step);
}

// The information of z^-1, for a between measurement z of information `information` (both in the
// between factors' error coordinates): the same measurement read from the other pose.
template <class G>
Eigen::Matrix<double, G::kDof, G::kDof> reversedBetweenInformation(
    const G& z, const Eigen::Matrix<double, G::kDof, G::kDof>& information) noexcept {
  using Matrix = Eigen::Matrix<double, G::kDof, G::kDof>;
  Matrix j;  // d z^-1 / d z in the tangent
  static_cast<void>(z.inverse(&j));
  // In error coordinates e = S tau the Jacobian is S j S^-1, and information goes by its inverse.
  const Matrix s = betweenErrorPerTangent<G>();
  Matrix s_inverse = s;
  s_inverse.diagonal() = s_inverse.diagonal().cwiseInverse();
  const Matrix back = s * j.inverse() * s_inverse;  // d z / d z^-1: the inverse of j
  return back.transpose() * information * back;
}

// Two measurements of one vector (a point observation's position): the information-weighted mean,
// exact for an error linear in the measurement.
template <int N>
Eigen::Matrix<double, N, 1> mergedMeasurement(const Eigen::Matrix<double, N, 1>& z1,
                                              const Eigen::Matrix<double, N, N>& information1,
                                              const Eigen::Matrix<double, N, 1>& z2,
                                              const Eigen::Matrix<double, N, N>& information2,
                                              Eigen::Matrix<double, N, N>* information) noexcept {
  const Eigen::Matrix<double, N, N> sum = information1 + information2;
  *information = sum;
  return sum.llt().solve(information1 * z1 + information2 * z2);
}

}  // namespace lslam
