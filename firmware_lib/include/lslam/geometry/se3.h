#pragma once
// SE(3): rigid motions of space, stored as (SO3 rotation, Vec3 translation): the point p in the
// pose's frame is R p + t in the outer frame.
//
// Tangent vectors are ordered tau = (rho, phi): TRANSLATION PART FIRST (rho = tau.head<3>()),
// ROTATION PART SECOND (phi = tau.tail<3>()). Factors' errors and their information matrices
// use this same order. Exp(rho, phi) = (Exp(phi), V(phi) rho) with V = Jl(phi) of SO3.
//
// Every Jacobian is taken w.r.t. right (local) perturbations, X (+) tau = X * Exp(tau), and every
// output Jacobian is an optional pointer named J_<result>_<input> that may be nullptr, as in
// se2.h and so3.h.
#include "lslam/eigen.h"
#include "lslam/geometry/so3.h"

namespace lslam {

class SE3;
// Input check for a pose from outside (an initial value or a measurement): NonFiniteInput for a
// NaN or Inf coefficient, InvalidArgument for a translation coordinate beyond kMaxCoordinate
// (coordinate_range.h) or a quaternion that is not unit (validateQuaternion), Ok otherwise.
[[nodiscard]] Status validateValue(const SE3& x) noexcept;

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using Mat36 = Eigen::Matrix<double, 3, 6>;
using Mat4 = Eigen::Matrix<double, 4, 4>;

class SE3 {
 public:
  static constexpr int kDof = 6;

  SE3() = default;  // identity
  SE3(const SO3& rotation, const Vec3& translation) noexcept : r_(rotation), t_(translation) {}

  const SO3& rotation() const noexcept { return r_; }
  const Vec3& translation() const noexcept { return t_; }
  Mat4 matrix() const noexcept;  // homogeneous [R t; 0 1]

  // this * b
  SE3 compose(const SE3& b, Mat6* J_c_a = nullptr, Mat6* J_c_b = nullptr) const noexcept;
  // this^-1
  SE3 inverse(Mat6* J_inv_a = nullptr) const noexcept;
  // this^-1 * b
  SE3 between(const SE3& b, Mat6* J_d_a = nullptr, Mat6* J_d_b = nullptr) const noexcept;
  // this * p: a point given in this pose's frame, expressed in the outer frame.
  Vec3 transformFrom(const Vec3& p_local, Mat36* J_p_a = nullptr,
                     Mat3* J_p_p = nullptr) const noexcept;

  // Ad(this) = [R [t]x R; 0 R] for the (rho, phi) order: X Exp(tau) = Exp(Ad(X) tau) X.
  Mat6 adjoint() const noexcept;

  // Exp: tangent vector (rho, phi) -> pose. J_r is the right Jacobian of Exp at tau.
  static SE3 exp(const Vec6& tau, Mat6* J_r = nullptr) noexcept;
  // Log: pose -> tangent vector (rho, phi) with |phi| in [0, pi]. J_r_inv is the inverse right
  // Jacobian.
  Vec6 log(Mat6* J_r_inv = nullptr) const noexcept;

  // this * Exp(tau)
  SE3 retract(const Vec6& tau, Mat6* J_x_a = nullptr, Mat6* J_x_tau = nullptr) const noexcept;
  // Log(this^-1 * b); the inverse of retract: retract(localCoordinates(b)) == b.
  Vec6 localCoordinates(const SE3& b, Mat6* J_t_a = nullptr, Mat6* J_t_b = nullptr) const noexcept;

 private:
  SO3 r_;
  Vec3 t_ = Vec3::Zero();
};

}  // namespace lslam
