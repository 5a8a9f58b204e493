#pragma once
// SO(3): rotations of space, stored as a unit quaternion (4 doubles, against 9 for a matrix; the
// product of two is 16 multiplications and renormalizing it is cheap).
//
// q and -q are the same rotation. The sign of the stored quaternion is not canonicalized (w may
// be negative); Log picks the representative with w >= 0, so it returns angles in [0, pi].
//
// Tangent vectors are phi in R^3 (axis times angle). Every Jacobian is taken w.r.t. right
// (local) perturbations, R (+) phi = R * Exp(phi), and every output Jacobian is an optional
// pointer named J_<result>_<input> that may be nullptr, as in se2.h.
#include "lslam/eigen.h"
#include "lslam/status.h"

#include <Eigen/Geometry>

namespace lslam {

// | |q| - 1 | above this makes a quaternion invalid. Loose enough for quaternions stored in
// single precision or printed with 7 digits; tight enough that the rotation built from one is
// orthogonal to ~2e-6.
constexpr double kUnitQuaternionTolerance = 1e-6;

// Input check for quaternions from outside (measurements, initial values): NonFiniteInput for a
// NaN or Inf coefficient, InvalidArgument when | |q| - 1 | > tolerance (zero, or finite
// coefficients whose squared norm overflows, included), Ok otherwise.
// Requires 0 <= tolerance < 1 (a programmer's constant, asserted).
Status validateQuaternion(const Eigen::Quaterniond& q,
                          double tolerance = kUnitQuaternionTolerance) noexcept;

// [v]x: the matrix with [v]x p = v x p.
Mat3 skew(const Vec3& v) noexcept;

class SO3 {
 public:
  static constexpr int kDof = 3;

  SO3() = default;  // identity
  // Stored as given, without normalization. Every operation assumes a unit quaternion: values
  // from outside are checked with validateQuaternion (validateValue for an SE3) before any use, so
  // a bad one is a Status, never an assertion.
  explicit SO3(const Eigen::Quaterniond& q) noexcept;

  const Eigen::Quaterniond& quaternion() const noexcept { return q_; }
  Mat3 matrix() const noexcept;

  // this * b. The result is renormalized (one Newton step, no square root), so that norm errors
  // do not accumulate over long chains of compositions and retractions.
  SO3 compose(const SO3& b, Mat3* J_c_a = nullptr, Mat3* J_c_b = nullptr) const noexcept;
  // this^-1
  SO3 inverse(Mat3* J_inv_a = nullptr) const noexcept;
  // this^-1 * b
  SO3 between(const SO3& b, Mat3* J_d_a = nullptr, Mat3* J_d_b = nullptr) const noexcept;
  // this * p: the point p rotated.
  Vec3 act(const Vec3& p, Mat3* J_p_a = nullptr, Mat3* J_p_p = nullptr) const noexcept;

  // Exp: tangent vector -> rotation. J_r is the right Jacobian of Exp at phi.
  static SO3 exp(const Vec3& phi, Mat3* J_r = nullptr) noexcept;
  // Log: rotation -> tangent vector with angle |phi| in [0, pi]. At exactly pi, phi and -phi are
  // the same rotation and either may be returned. J_r_inv is the inverse right Jacobian.
  Vec3 log(Mat3* J_r_inv = nullptr) const noexcept;

  // The right Jacobian of Exp, Jr(phi) = I - (1 - cos t)/t^2 [phi]x + (t - sin t)/t^3 [phi]x^2
  // with t = |phi|. The left Jacobian is Jl(phi) = Jr(-phi) = Jr(phi)^T.
  static Mat3 rightJacobian(const Vec3& phi) noexcept;
  // Jr(phi)^-1 = I + [phi]x / 2 + (1 - (t/2) cot(t/2))/t^2 [phi]x^2. Singular at |phi| = 2 pi;
  // meant for |phi| <= pi (what Log returns).
  static Mat3 rightJacobianInverse(const Vec3& phi) noexcept;

  // this * Exp(tau)
  SO3 retract(const Vec3& tau, Mat3* J_x_a = nullptr, Mat3* J_x_tau = nullptr) const noexcept;
  // Log(this^-1 * b); the inverse of retract: retract(localCoordinates(b)) == b.
  Vec3 localCoordinates(const SO3& b, Mat3* J_t_a = nullptr, Mat3* J_t_b = nullptr) const noexcept;

 private:
  Eigen::Quaterniond q_ = Eigen::Quaterniond::Identity();
};

}  // namespace lslam
