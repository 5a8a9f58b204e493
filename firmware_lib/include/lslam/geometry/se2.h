#pragma once
// SE(2): rigid motions of the plane. Poses are stored as (x, y, theta) rather than as a rotation
// matrix: three doubles per variable is what the fixed-size variable store can afford, and the
// angle form is what the datasets and the g2o-style errors use anyway.
//
// Tangent vectors are tau = (vx, vy, w). Every Jacobian is taken w.r.t. right (local)
// perturbations, X (+) tau = X * Exp(tau), and every output Jacobian is an optional pointer
// named J_<result>_<input> that may be nullptr, so callers on the hot path only pay for what
// they use.
#include <cmath>

#include "lslam/eigen.h"
#include "lslam/geometry/angle.h"
#include "lslam/geometry/coordinate_range.h"
#include "lslam/status.h"

namespace lslam {

using Mat23 = Eigen::Matrix<double, 2, 3>;

class SE2 {
 public:
  static constexpr int kDof = 3;

  SE2() = default;                                 // identity
  SE2(double x, double y, double theta) noexcept;  // theta is wrapped to (-pi, pi]

  double x() const noexcept { return x_; }
  double y() const noexcept { return y_; }
  double theta() const noexcept { return theta_; }
  Vec2 translation() const noexcept { return Vec2(x_, y_); }
  Mat2 rotation() const noexcept;
  Vec3 vector() const noexcept { return Vec3(x_, y_, theta_); }  // (x, y, theta)

  // this * b
  SE2 compose(const SE2& b, Mat3* J_c_a = nullptr, Mat3* J_c_b = nullptr) const noexcept;
  // this^-1
  SE2 inverse(Mat3* J_inv_a = nullptr) const noexcept;
  // this^-1 * b
  SE2 between(const SE2& b, Mat3* J_d_a = nullptr, Mat3* J_d_b = nullptr) const noexcept;
  // this * p: a point given in this pose's frame, expressed in the outer frame.
  Vec2 transformFrom(const Vec2& p_local, Mat23* J_p_a = nullptr,
                     Mat2* J_p_p = nullptr) const noexcept;

  // Exp: tangent vector -> pose. J_r is the right Jacobian of Exp at tau.
  static SE2 exp(const Vec3& tau, Mat3* J_r = nullptr) noexcept;
  // Log: pose -> tangent vector with w in (-pi, pi]. J_r_inv is the inverse right Jacobian.
  Vec3 log(Mat3* J_r_inv = nullptr) const noexcept;

  // this * Exp(tau)
  SE2 retract(const Vec3& tau, Mat3* J_x_a = nullptr, Mat3* J_x_tau = nullptr) const noexcept;
  // Log(this^-1 * b); the inverse of retract: retract(localCoordinates(b)) == b.
  Vec3 localCoordinates(const SE2& b, Mat3* J_t_a = nullptr, Mat3* J_t_b = nullptr) const noexcept;

 private:
  double x_ = 0.0;
  double y_ = 0.0;
  double theta_ = 0.0;
};

// Input check for a pose from outside (an initial value or a measurement): NonFiniteInput for a
// NaN or Inf coordinate, InvalidArgument for x or y beyond kMaxCoordinate (coordinate_range.h; the
// angle only has to be finite: it is wrapped), Ok otherwise.
[[nodiscard]] inline Status validateValue(const SE2& x) noexcept {
  if (!std::isfinite(x.theta())) return Status::NonFiniteInput;
  return checkCoordinates(x.translation());
}

}  // namespace lslam
