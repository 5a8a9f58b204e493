#include "lslam/geometry/so3.h"

#include <cmath>

#include "angle_coefficients.h"
#include "lslam/assert.h"
#include "lslam/geometry/sin_cos.h"
#include "right_plus_minus.h"

namespace lslam {
namespace {

using detail::kTinyAngle;
using detail::sinc;
using detail::versineOverSquare;

// (t - sin t)/t^3 and 1 - (t/2)cot(t/2) cancel catastrophically near t = 0. Below this angle
// they use six-term Taylor series instead; at the switch both forms are within 4e-14 relative.
constexpr double kSeriesAngle = 0.3;

// (t - sin t)/t^3, given sin_t = sin(t).
double sineDefectOverCube(double t, double sin_t) noexcept {
  if (std::abs(t) < kSeriesAngle) {
    const double t2 = t * t;
    return 1.0 / 6.0 +
           t2 * (-1.0 / 120.0 +
                 t2 * (1.0 / 5040.0 +
                       t2 * (-1.0 / 362880.0 + t2 * (1.0 / 39916800.0 - t2 / 6227020800.0))));
  }
  return (t - sin_t) / (t * t * t);
}

// (1 - (t/2) cot(t/2))/t^2: the [phi]x^2 coefficient of Jr^-1. The series coefficients are
// |B_2n| / (2n)! (Bernoulli numbers), shifted by t^2.
double halfCotDefectOverSquare(double t) noexcept {
  const double t2 = t * t;
  if (std::abs(t) < kSeriesAngle) {
    return 1.0 / 12.0 +
           t2 * (1.0 / 720.0 + t2 * (1.0 / 30240.0 +
                                     t2 * (1.0 / 1209600.0 + t2 * (1.0 / 47900160.0 +
                                                                   t2 * 691.0 / 1307674368000.0))));
  }
  const double h = 0.5 * t;
  const SinCos sc = sinCos(h);
  return (1.0 - h * sc.cos / sc.sin) / t2;
}

// Scales the quaternion by one Newton step towards unit norm: (3 - |q|^2)/2 takes a norm error
// e to about -3e^2/2, with no square root.
Eigen::Quaterniond renormalized(const Eigen::Quaterniond& q) noexcept {
  Eigen::Quaterniond r = q;
  r.coeffs() *= 0.5 * (3.0 - q.squaredNorm());
  return r;
}

}  // namespace

Status validateQuaternion(const Eigen::Quaterniond& q, double tolerance) noexcept {
  LSLAM_ASSERT(tolerance >= 0.0 && tolerance < 1.0);
  if (!q.coeffs().allFinite()) return Status::NonFiniteInput;
  if (!(std::abs(q.norm() - 1.0) <= tolerance)) return Status::InvalidArgument;
  return Status::Ok;
}

Mat3 skew(const Vec3& v) noexcept {
  Mat3 m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

SO3::SO3(const Eigen::Quaterniond& q) noexcept : q_(q) {}

Mat3 SO3::matrix() const noexcept {
  return q_.toRotationMatrix();
}

SO3 SO3::compose(const SO3& b, Mat3* J_c_a, Mat3* J_c_b) const noexcept {
  // a Exp(tau) b = a b Exp(Rb^T tau): Ad(b^-1) = Rb^T.
  if (J_c_a != nullptr) *J_c_a = b.matrix().transpose();
  if (J_c_b != nullptr) J_c_b->setIdentity();
  SO3 c;
  c.q_ = renormalized(q_ * b.q_);
  return c;
}

SO3 SO3::inverse(Mat3* J_inv_a) const noexcept {
  // (a Exp(tau))^-1 = Exp(-tau) a^-1 = a^-1 Exp(-Ra tau).
  if (J_inv_a != nullptr) *J_inv_a = -matrix();
  SO3 inv;
  inv.q_ = q_.conjugate();
  return inv;
}

SO3 SO3::between(const SO3& b, Mat3* J_d_a, Mat3* J_d_b) const noexcept {
  SO3 d;
  d.q_ = renormalized(q_.conjugate() * b.q_);
  // Exp(-tau) a^-1 b = d Exp(-Rd^T tau).
  if (J_d_a != nullptr) *J_d_a = -d.matrix().transpose();
  if (J_d_b != nullptr) J_d_b->setIdentity();
  return d;
}

Vec3 SO3::act(const Vec3& p, Mat3* J_p_a, Mat3* J_p_p) const noexcept {
  if (J_p_a != nullptr || J_p_p != nullptr) {
    const Mat3 r = matrix();
    // R Exp(tau) p = R (p + tau x p) = R p - R [p]x tau to first order.
    if (J_p_a != nullptr) *J_p_a = -r * skew(p);
    if (J_p_p != nullptr) *J_p_p = r;
  }
  return q_ * p;
}

// Exp(phi) = (cos(t/2), sin(t/2) phi / t) with t = |phi|; sin(t/2)/t = sinc(t/2)/2 has no 0/0.
SO3 SO3::exp(const Vec3& phi, Mat3* J_r) noexcept {
  const double h = 0.5 * phi.norm();
  const SinCos sc = sinCos(h);
  const double k = 0.5 * sinc(h, sc.sin);
  if (J_r != nullptr) *J_r = rightJacobian(phi);
  SO3 x;
  x.q_ = Eigen::Quaterniond(sc.cos, k * phi.x(), k * phi.y(), k * phi.z());
  return x;
}

// phi = t v / |v| with t = 2 atan2(|v|, w), for q = (w, v). atan2 makes the angle independent of
// the norm of q and accurate over the whole range: near 0 it has no 1 - cos to cancel, and near
// pi (w -> 0, |v| -> 1) no division by a vanishing sine.
Vec3 SO3::log(Mat3* J_r_inv) const noexcept {
  // Near pi: q and -q are the same rotation, and quaternions on either side of w = 0 differ by a
  // half turn about nearly the same axis. Taking the representative with w >= 0 keeps t in
  // [0, pi]: a rotation by pi + e about v comes out as pi - e about -v. At w = 0 exactly, t = pi
  // and phi = pi v (the other answer, -pi v, is the same rotation).
  const double sign = q_.w() < 0.0 ? -1.0 : 1.0;
  const double w = sign * q_.w();
  const Vec3 v = sign * q_.vec();
  const double n = v.norm();
  double scale = 0.0;  // t / n
  if (n < kTinyAngle) {
    // Near 0: 2 atan(x)/n with x = n/w, as 2 (1 - x^2/3)/w; w is ~1 here (q unit).
    const double x = n / w;
    scale = 2.0 * (1.0 - x * x / 3.0) / w;
  } else {
    scale = 2.0 * std::atan2(n, w) / n;
  }
  const Vec3 phi = scale * v;
  if (J_r_inv != nullptr) *J_r_inv = rightJacobianInverse(phi);
  return phi;
}

Mat3 SO3::rightJacobian(const Vec3& phi) noexcept {
  const double t = phi.norm();
  const Mat3 phi_x = skew(phi);
  return Mat3::Identity() - versineOverSquare(t) * phi_x +
         sineDefectOverCube(t, sinCos(t).sin) * (phi_x * phi_x);
}

Mat3 SO3::rightJacobianInverse(const Vec3& phi) noexcept {
  const double t = phi.norm();
  const Mat3 phi_x = skew(phi);
  return Mat3::Identity() + 0.5 * phi_x + halfCotDefectOverSquare(t) * (phi_x * phi_x);
}

SO3 SO3::retract(const Vec3& tau, Mat3* J_x_a, Mat3* J_x_tau) const noexcept {
  return detail::retract(*this, tau, J_x_a, J_x_tau);
}

Vec3 SO3::localCoordinates(const SO3& b, Mat3* J_t_a, Mat3* J_t_b) const noexcept {
  return detail::localCoordinates(*this, b, J_t_a, J_t_b);
}

}  // namespace lslam
