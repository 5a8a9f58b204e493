#pragma once
// Coefficients of the rotation groups' exp/log/Jacobians that are 0/0 at angle 0 in closed form,
// written so that they stay accurate there. Shared by se2.cpp and so3.cpp.
#include <cmath>

#include "lslam/geometry/sin_cos.h"

namespace lslam::detail {

// Below this angle the coefficients that are 0/0 at t = 0 (sin(t)/t here; (t/2)cot(t/2) and
// atan(x)/x in their files) switch to two-term Taylor series; the dropped fourth-order terms are
// below 3e-17 there.
inline constexpr double kTinyAngle = 1e-4;

// sin(t)/t, given sin_t = sin(t) (the callers need sin(t) for more than one coefficient).
inline double sinc(double t, double sin_t) noexcept {
  if (std::abs(t) < kTinyAngle) return 1.0 - t * t / 6.0;
  return sin_t / t;
}

// (1 - cos t)/t^2, formed as (1/2) sinc(t/2)^2: the direct 1 - cos t cancels for small t.
inline double versineOverSquare(double t) noexcept {
  const double h = 0.5 * t;
  const double s = sinc(h, sinCos(h).sin);
  return 0.5 * s * s;
}

}  // namespace lslam::detail
