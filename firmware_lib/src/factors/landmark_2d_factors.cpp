#include "lslam/factors/landmark_2d_factors.h"

#include <cmath>

#include "lslam/factors/information.h"
#include "lslam/geometry/angle.h"
#include "lslam/geometry/coordinate_range.h"
#include "lslam/geometry/sin_cos.h"

// Derivation. Let w = l - t (world frame) and d = R^T w, and J = [0 -1; 1 0], so that
// R(theta + a) = R (I + a J) to first order.
//
// x -> x Exp(v, a): t -> t + R v and R^T -> (I - a J) R^T to first order, hence
//   d -> (I - a J)(d - v) = d - v - a J d,   J_d_x = [-1 0 dy; 0 -1 -dx].
// l -> l + dl: J_d_l = R^T.
//
// Position factor: e = d - z, so J_e_x = J_d_x and J_e_l = R^T.
//
// Range-bearing factor, with r = |d|, u = d / r:
//   d r = u^T d d,   d atan2(dy, dx) = g^T d d   with g = (-dy, dx) / r^2 = (-uy, ux) / r.
//   Range row:   u^T J_d_x = [-ux, -uy, ux dy - uy dx] = [-ux, -uy, 0];  u^T R^T = (w / r)^T.
//   Bearing row: g^T J_d_x = [uy / r, -ux / r, -(ux dx + uy dy) / r] = [uy / r, -ux / r, -1];
//                g^T R^T = (R g)^T = (J w)^T / r^2 = (-wy, wx) / r^2.
// The bearing's 1/r^2 is formed as (w / r) / r, which stays finite for every r > 0.

namespace lslam {

Vec2 pointObservationErrorSE2(const SE2& x, const Point2& l, const Vec2& z, Mat23* J_e_x,
                              Mat2* J_e_l) noexcept {
  const auto [s, c] = sinCos(x.theta());
  const double wx = l.x() - x.x();
  const double wy = l.y() - x.y();
  const double dx = c * wx + s * wy;
  const double dy = -s * wx + c * wy;
  if (J_e_x != nullptr) {
    *J_e_x << -1.0, 0.0, dy,  //
        0.0, -1.0, -dx;
  }
  if (J_e_l != nullptr) *J_e_l << c, s, -s, c;
  return Vec2(dx - z.x(), dy - z.y());
}

Point2 landmarkFromPointObservationSE2(const SE2& x, const Vec2& z) noexcept {
  return Point2(x.transformFrom(z));
}

Status validatePointObservationSE2(const Vec2& z, const Mat2& information) noexcept {
  const Status s = checkCoordinates(z);
  return s != Status::Ok ? s : checkInformation(information);
}

Vec2 rangeBearingErrorSE2(const SE2& x, const Point2& l, const Vec2& z, Mat23* J_e_x,
                          Mat2* J_e_l) noexcept {
  const auto [s, c] = sinCos(x.theta());
  const double wx = l.x() - x.x();
  const double wy = l.y() - x.y();
  const double dx = c * wx + s * wy;
  const double dy = -s * wx + c * wy;
  const double r = std::sqrt(dx * dx + dy * dy);
  if (J_e_x != nullptr || J_e_l != nullptr) {
    // At r == 0 (also when dx^2 + dy^2 underflows) the error is not differentiable: zero rows.
    // Otherwise 1 / r is finite: r >= sqrt(smallest subnormal) ~ 2e-162.
    const double inv_r = r > 0.0 ? 1.0 / r : 0.0;
    const double ux = dx * inv_r;  // d / r
    const double uy = dy * inv_r;
    const double vx = wx * inv_r;  // w / r = R u
    const double vy = wy * inv_r;
    if (J_e_x != nullptr) {
      *J_e_x << -ux, -uy, 0.0,  //
          uy * inv_r, -ux * inv_r, r > 0.0 ? -1.0 : 0.0;
    }
    if (J_e_l != nullptr) {
      *J_e_l << vx, vy,  //
          -vy * inv_r, vx * inv_r;
    }
  }
  return Vec2(r - z(0), wrapAngle(std::atan2(dy, dx) - z(1)));
}

Point2 landmarkFromRangeBearingSE2(const SE2& x, const Vec2& z) noexcept {
  const auto [sb, cb] = sinCos(z(1));
  return Point2(x.transformFrom(Vec2(z(0) * cb, z(0) * sb)));
}

Status validateRangeBearingSE2(const Vec2& z, const Mat2& information) noexcept {
  if (!z.allFinite()) return Status::NonFiniteInput;
  // See the header: zero is rejected too.
  if (!(z(0) > 0.0) || !withinCoordinateRange(z(0))) return Status::InvalidArgument;
  return checkInformation(information);
}

}  // namespace lslam
