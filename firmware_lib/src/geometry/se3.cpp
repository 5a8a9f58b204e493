#include "lslam/geometry/se3.h"

#include <array>
#include <cmath>
#include <cstddef>

#include "inverse_factorial.h"
#include "lslam/geometry/coordinate_range.h"
#include "lslam/geometry/sin_cos.h"
#include "right_plus_minus.h"

namespace lslam {
namespace {

using detail::inverseFactorial;

// Below this angle the three coefficients of Q (below) use Taylor series: their closed forms
// cancel terms of size t, t^2 to a result of size t^3 .. t^5 and would lose up to 5*log10(1/t)
// digits. At t = 1 the closed forms are within 3e-14 relative, and nine series terms within 1e-17.
constexpr double kSeriesAngle = 1.0;
constexpr int kSeriesTerms = 9;
using Series = std::array<double, kSeriesTerms>;

// sum_m c[m] x^m by Horner's rule.
double polynomial(const Series& c, double x) noexcept {
  double s = c[kSeriesTerms - 1];
  for (std::size_t m = kSeriesTerms - 1; m-- > 0;) s = s * x + c[m];
  return s;
}

// (t - sin t)/t^3 = sum_m (-1)^m t^2m / (2m+3)!
constexpr Series kSineDefectSeries = [] {
  Series c{};
  for (int m = 0; m < kSeriesTerms; ++m) {
    c[m] = (m % 2 == 0 ? 1.0 : -1.0) * inverseFactorial(2 * m + 3);
  }
  return c;
}();

// (t^2 + 2 cos t - 2)/(2 t^4) = sum_m (-1)^m t^2m / (2m+4)!
constexpr Series kCosineDefectSeries = [] {
  Series c{};
  for (int m = 0; m < kSeriesTerms; ++m) {
    c[m] = (m % 2 == 0 ? 1.0 : -1.0) * inverseFactorial(2 * m + 4);
  }
  return c;
}();

// (2t - 3 sin t + t cos t)/(2 t^5) = sum_m (-1)^m (m+1) t^2m / (2m+5)!
constexpr Series kMixedDefectSeries = [] {
  Series c{};
  for (int m = 0; m < kSeriesTerms; ++m) {
    c[m] = (m % 2 == 0 ? 1.0 : -1.0) * (m + 1) * inverseFactorial(2 * m + 5);
  }
  return c;
}();

// The block coupling translation and rotation in the right Jacobian of SE3's Exp:
// Jr(rho, phi) = [Jr(phi) Q; 0 Jr(phi)] with Q = Ql(-rho, -phi), where Ql is the left-Jacobian
// block of Barfoot and Furgale, "Associating uncertainty with three-dimensional poses" (2014).
// Negating both arguments flips the odd-degree terms. With P = [phi]x and R = [rho]x:
//   Q = -R/2 + c1 (P R + R P - P R P) - c2 (P P R + R P P - 3 P R P) + c3 (P R P P + P P R P)
// c1 = (t - sin t)/t^3, c2 = (t^2 + 2 cos t - 2)/(2 t^4), c3 = (2t - 3 sin t + t cos t)/(2 t^5).
Mat3 translationCoupling(const Vec3& rho, const Vec3& phi) noexcept {
  const double t = phi.norm();
  double c1 = 0.0;
  double c2 = 0.0;
  double c3 = 0.0;
  if (t < kSeriesAngle) {
    const double t2 = t * t;
    c1 = polynomial(kSineDefectSeries, t2);
    c2 = polynomial(kCosineDefectSeries, t2);
    c3 = polynomial(kMixedDefectSeries, t2);
  } else {
    const auto [s, c] = sinCos(t);
    const double t2 = t * t;
    c1 = (t - s) / (t2 * t);
    c2 = (t2 + 2.0 * c - 2.0) / (2.0 * t2 * t2);
    c3 = (2.0 * t - 3.0 * s + t * c) / (2.0 * t2 * t2 * t);
  }
  const Mat3 p = skew(phi);
  const Mat3 r = skew(rho);
  const Mat3 pr = p * r;
  const Mat3 rp = r * p;
  const Mat3 prp = pr * p;
  return -0.5 * r + c1 * (pr + rp - prp) - c2 * (p * pr + rp * p - 3.0 * prp) +
         c3 * (prp * p + p * prp);
}

// Ad(X^-1) = [R^T -R^T [t]x; 0 R^T]. It carries a right perturbation through a right product:
// a Exp(tau) b = a b Exp(Ad(b^-1) tau).
Mat6 adjointOfInverse(const Mat3& r, const Vec3& t) noexcept {
  Mat6 m;
  const Mat3 rt = r.transpose();
  m << rt, -rt * skew(t), Mat3::Zero(), rt;
  return m;
}

// [J Q; 0 J]
Mat6 blockUpperTriangular(const Mat3& j, const Mat3& q) noexcept {
  Mat6 m;
  m << j, q, Mat3::Zero(), j;
  return m;
}

}  // namespace

Mat4 SE3::matrix() const noexcept {
  Mat4 m = Mat4::Identity();
  m.topLeftCorner<3, 3>() = r_.matrix();
  m.topRightCorner<3, 1>() = t_;
  return m;
}

Mat6 SE3::adjoint() const noexcept {
  const Mat3 r = r_.matrix();
  Mat6 m;
  m << r, skew(t_) * r, Mat3::Zero(), r;
  return m;
}

SE3 SE3::compose(const SE3& b, Mat6* J_c_a, Mat6* J_c_b) const noexcept {
  if (J_c_a != nullptr) *J_c_a = adjointOfInverse(b.r_.matrix(), b.t_);
  if (J_c_b != nullptr) J_c_b->setIdentity();
  return SE3(r_.compose(b.r_), t_ + r_.act(b.t_));
}

SE3 SE3::inverse(Mat6* J_inv_a) const noexcept {
  // (a Exp(tau))^-1 = Exp(-tau) a^-1 = a^-1 Exp(-Ad(a) tau).
  if (J_inv_a != nullptr) *J_inv_a = -adjoint();
  const SO3 r_inv = r_.inverse();
  return SE3(r_inv, -r_inv.act(t_));
}

SE3 SE3::between(const SE3& b, Mat6* J_d_a, Mat6* J_d_b) const noexcept {
  const SO3 r_inv = r_.inverse();
  const SE3 d(r_inv.compose(b.r_), r_inv.act(b.t_ - t_));
  // Exp(-tau) a^-1 b = d Exp(-Ad(d^-1) tau).
  if (J_d_a != nullptr) *J_d_a = -adjointOfInverse(d.r_.matrix(), d.t_);
  if (J_d_b != nullptr) J_d_b->setIdentity();
  return d;
}

Vec3 SE3::transformFrom(const Vec3& p_local, Mat36* J_p_a, Mat3* J_p_p) const noexcept {
  Mat3 J_rp_r;
  Mat3 J_rp_p;
  const bool want_jacobian = J_p_a != nullptr || J_p_p != nullptr;
  const Vec3 rp =
      r_.act(p_local, want_jacobian ? &J_rp_r : nullptr, want_jacobian ? &J_rp_p : nullptr);
  // a Exp(rho, phi) p = t + R (rho + p + phi x p) to first order.
  if (J_p_a != nullptr) *J_p_a << J_rp_p, J_rp_r;
  if (J_p_p != nullptr) *J_p_p = J_rp_p;
  return t_ + rp;
}

// Exp(rho, phi) = (Exp(phi), V rho) with V = Jl(phi) = Jr(phi)^T.
SE3 SE3::exp(const Vec6& tau, Mat6* J_r) noexcept {
  const Vec3 rho = tau.head<3>();
  const Vec3 phi = tau.tail<3>();
  Mat3 jr;
  const SO3 r = SO3::exp(phi, &jr);
  if (J_r != nullptr) *J_r = blockUpperTriangular(jr, translationCoupling(rho, phi));
  return SE3(r, jr.transpose() * rho);
}

// rho = V^-1 t with V^-1 = Jl(phi)^-1 = Jr(phi)^-T. The inverse right Jacobian is the inverse
// of the block-triangular Jr: [Ji -Ji Q Ji; 0 Ji] with Ji = Jr(phi)^-1.
Vec6 SE3::log(Mat6* J_r_inv) const noexcept {
  Mat3 ji;
  const Vec3 phi = r_.log(&ji);
  const Vec3 rho = ji.transpose() * t_;
  if (J_r_inv != nullptr) {
    *J_r_inv = blockUpperTriangular(ji, -ji * translationCoupling(rho, phi) * ji);
  }
  Vec6 tau;
  tau << rho, phi;
  return tau;
}

SE3 SE3::retract(const Vec6& tau, Mat6* J_x_a, Mat6* J_x_tau) const noexcept {
  return detail::retract(*this, tau, J_x_a, J_x_tau);
}

Vec6 SE3::localCoordinates(const SE3& b, Mat6* J_t_a, Mat6* J_t_b) const noexcept {
  return detail::localCoordinates(*this, b, J_t_a, J_t_b);
}

Status validateValue(const SE3& x) noexcept {
  // Non-finite first, wherever it is: a NaN quaternion with a far translation is NonFiniteInput.
  const Status translation = checkCoordinates(x.translation());
  if (translation == Status::NonFiniteInput) return translation;
  const Status rotation = validateQuaternion(x.rotation().quaternion());
  return rotation != Status::Ok ? rotation : translation;
}

}  // namespace lslam
