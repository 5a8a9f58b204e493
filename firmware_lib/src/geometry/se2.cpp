#include "lslam/geometry/se2.h"

#include <cmath>

#include "angle_coefficients.h"
#include "lslam/geometry/sin_cos.h"
#include "right_plus_minus.h"

namespace lslam {
namespace {

using detail::kTinyAngle;
using detail::sinc;
using detail::versineOverSquare;

// (w - sin w)/w^2 and (w/2)cot(w/2) - 1 cancel catastrophically near w = 0: the direct forms
// lose about 2*log10(1/w) digits. Below this angle they use five-term Taylor series instead.
// 0.3 balances the two errors: at the switch both are below 4e-14 relative.
constexpr double kSeriesAngle = 0.3;

// (w - sin w)/w^2, given sin_w = sin(w).
double sineDefectOverSquare(double w, double sin_w) noexcept {
  if (std::abs(w) < kSeriesAngle) {
    const double w2 = w * w;
    return w * (1.0 / 6.0 + w2 * (-1.0 / 120.0 +
                                  w2 * (1.0 / 5040.0 + w2 * (-1.0 / 362880.0 + w2 / 39916800.0))));
  }
  return (w - sin_w) / (w * w);
}

// (w/2) cot(w/2): the scale of the inverse of the V matrix of Exp. Written as h cos(h) / sin(h),
// which is accurate up to w = pi, where cos(h) goes to zero and sin(h) to one.
double halfCotScale(double w) noexcept {
  const double h = 0.5 * w;
  if (std::abs(w) < kTinyAngle) return 1.0 - h * h / 3.0;
  const SinCos sc = sinCos(h);
  return h * sc.cos / sc.sin;
}

// ((w/2) cot(w/2) - 1)/w, the translation coupling of the inverse right Jacobian, given
// k = halfCotScale(w).
double halfCotDefect(double w, double k) noexcept {
  if (std::abs(w) < kSeriesAngle) {
    const double w2 = w * w;
    return -w * (1.0 / 12.0 + w2 * (1.0 / 720.0 + w2 * (1.0 / 30240.0 +
                                                        w2 * (1.0 / 1209600.0 + w2 / 47900160.0))));
  }
  return (k - 1.0) / w;
}

// Ad(X^-1) for X = (x, y, theta) with c = cos(theta), s = sin(theta). It carries a right
// perturbation through a right product: a * Exp(tau) * b = a * b * Exp(Ad(b^-1) tau).
Mat3 adjointOfInverse(double x, double y, double c, double s) noexcept {
  Mat3 m;
  m << c, s, s * x - c * y,  //
      -s, c, c * x + s * y,  //
      0.0, 0.0, 1.0;
  return m;
}

}  // namespace

SE2::SE2(double x, double y, double theta) noexcept : x_(x), y_(y), theta_(wrapAngle(theta)) {}

Mat2 SE2::rotation() const noexcept {
  const auto [s, c] = sinCos(theta_);
  Mat2 r;
  r << c, -s, s, c;
  return r;
}

SE2 SE2::compose(const SE2& b, Mat3* J_c_a, Mat3* J_c_b) const noexcept {
  const auto [s, c] = sinCos(theta_);
  if (J_c_a != nullptr) {
    const SinCos b_sc = sinCos(b.theta_);
    *J_c_a = adjointOfInverse(b.x_, b.y_, b_sc.cos, b_sc.sin);
  }
  if (J_c_b != nullptr) J_c_b->setIdentity();
  return SE2(x_ + c * b.x_ - s * b.y_, y_ + s * b.x_ + c * b.y_, theta_ + b.theta_);
}

SE2 SE2::inverse(Mat3* J_inv_a) const noexcept {
  const auto [s, c] = sinCos(theta_);
  if (J_inv_a != nullptr) {
    // -Ad(a): a right perturbation of a becomes a left one of a^-1, with the sign flipped.
    *J_inv_a << -c, s, -y_,  //
        -s, -c, x_,          //
        0.0, 0.0, -1.0;
  }
  return SE2(-(c * x_ + s * y_), s * x_ - c * y_, -theta_);
}

SE2 SE2::between(const SE2& b, Mat3* J_d_a, Mat3* J_d_b) const noexcept {
  const auto [s, c] = sinCos(theta_);
  const double dx = b.x_ - x_;
  const double dy = b.y_ - y_;
  const SE2 d(c * dx + s * dy, -s * dx + c * dy, b.theta_ - theta_);
  if (J_d_a != nullptr) {
    // Exp(-tau) a^-1 b = d Exp(-Ad(d^-1) tau).
    const SinCos d_sc = sinCos(d.theta_);
    *J_d_a = -adjointOfInverse(d.x_, d.y_, d_sc.cos, d_sc.sin);
  }
  if (J_d_b != nullptr) J_d_b->setIdentity();
  return d;
}

Vec2 SE2::transformFrom(const Vec2& p_local, Mat23* J_p_a, Mat2* J_p_p) const noexcept {
  const auto [s, c] = sinCos(theta_);
  const double rx = c * p_local.x() - s * p_local.y();
  const double ry = s * p_local.x() + c * p_local.y();
  if (J_p_a != nullptr) {
    // a Exp(v, w) p = t + R (v + p + w J p) to first order, and R J p = J R p.
    *J_p_a << c, -s, -ry,  //
        s, c, rx;
  }
  if (J_p_p != nullptr) *J_p_p << c, -s, s, c;
  return Vec2(x_ + rx, y_ + ry);
}

// Exp(v, w) = (V(w) v, w) with V = [a -b; b a], a = sin(w)/w, b = (1 - cos w)/w.
// Its right Jacobian is [[a, b, g vx - e vy], [-b, a, g vy + e vx], [0, 0, 1]] with
// e = (1 - cos w)/w^2 and g = (w - sin w)/w^2.
SE2 SE2::exp(const Vec3& tau, Mat3* J_r) noexcept {
  const double vx = tau(0);
  const double vy = tau(1);
  const double w = tau(2);
  const double sin_w = sinCos(w).sin;
  const double a = sinc(w, sin_w);
  const double e = versineOverSquare(w);
  const double b = w * e;
  if (J_r != nullptr) {
    const double g = sineDefectOverSquare(w, sin_w);
    *J_r << a, b, g * vx - e * vy,  //
        -b, a, g * vy + e * vx,     //
        0.0, 0.0, 1.0;
  }
  return SE2(a * vx - b * vy, b * vx + a * vy, w);
}

// V^-1 = [k h; -h k] with h = w/2, k = h cot h. The inverse right Jacobian, the inverse of the
// block-triangular J_r above, simplifies to [[k, -h, -p vx + vy/2], [h, k, -p vy - vx/2],
// [0, 0, 1]] with p = (k - 1)/w.
Vec3 SE2::log(Mat3* J_r_inv) const noexcept {
  const double h = 0.5 * theta_;
  const double k = halfCotScale(theta_);
  const double vx = k * x_ + h * y_;
  const double vy = -h * x_ + k * y_;
  if (J_r_inv != nullptr) {
    const double p = halfCotDefect(theta_, k);
    *J_r_inv << k, -h, -p * vx + 0.5 * vy,  //
        h, k, -p * vy - 0.5 * vx,           //
        0.0, 0.0, 1.0;
  }
  return Vec3(vx, vy, theta_);
}

SE2 SE2::retract(const Vec3& tau, Mat3* J_x_a, Mat3* J_x_tau) const noexcept {
  return detail::retract(*this, tau, J_x_a, J_x_tau);
}

Vec3 SE2::localCoordinates(const SE2& b, Mat3* J_t_a, Mat3* J_t_b) const noexcept {
  return detail::localCoordinates(*this, b, J_t_a, J_t_b);
}

}  // namespace lslam
