#include "lslam/geometry/sin_cos.h"

#include <cmath>
#include <limits>

#include "inverse_factorial.h"
#include "lslam/geometry/angle.h"

namespace lslam {
namespace {

using detail::inverseFactorial;

// pi/2 split in three parts for a Cody-Waite reduction r = angle - k pi/2. The first two parts
// carry 33 significant bits each, so k * part is exact for |k| < 2^20 and the first subtraction
// is exact; the third part is the rounded rest. Together they hold pi/2 to ~1e-37.
constexpr double kHalfPiHigh = 0x1.921fb544p+0;
constexpr double kHalfPiMid = 0x1.0b4611a6p-34;
constexpr double kHalfPiLow = 0x1.3198a2e037073p-69;
constexpr double kTwoOverPi = 0x1.45f306dc9c883p-1;

// Adding and subtracting 1.5 * 2^52 rounds a double of magnitude < 2^51 to the nearest integer
// with the FPU's rounding mode, in two additions and without a library call.
constexpr double kRoundingShift = 0x1.8p52;

// Taylor series on |r| <= pi/4: the first omitted terms, r^19/19! and r^18/18!, are below 1e-18
// there, far under the 1.1e-16 rounding of the result, so no minimax fit is needed.
double sinPolynomial(double r) noexcept {
  const double r2 = r * r;
  const double tail =
      -inverseFactorial(3) +
      r2 * (inverseFactorial(5) +
            r2 * (-inverseFactorial(7) +
                  r2 * (inverseFactorial(9) +
                        r2 * (-inverseFactorial(11) +
                              r2 * (inverseFactorial(13) +
                                    r2 * (-inverseFactorial(15) + r2 * inverseFactorial(17)))))));
  return r + r * r2 * tail;
}

double cosPolynomial(double r) noexcept {
  const double r2 = r * r;
  const double tail =
      inverseFactorial(4) +
      r2 * (-inverseFactorial(6) +
            r2 * (inverseFactorial(8) +
                  r2 * (-inverseFactorial(10) +
                        r2 * (inverseFactorial(12) +
                              r2 * (-inverseFactorial(14) + r2 * inverseFactorial(16))))));
  return 1.0 - 0.5 * r2 + r2 * r2 * tail;
}

}  // namespace

SinCos sinCos(double angle) noexcept {
  if (!(std::abs(angle) <= kSinCosFixedCostLimit)) {
    if (!std::isfinite(angle)) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      return SinCos{nan, nan};
    }
    angle = wrapAngle(angle);
  }
  const double k = (angle * kTwoOverPi + kRoundingShift) - kRoundingShift;
  const double r = ((angle - k * kHalfPiHigh) - k * kHalfPiMid) - k * kHalfPiLow;
  const double s = sinPolynomial(r);
  const double c = cosPolynomial(r);
  // angle = r + k pi/2: rotate (cos r, sin r) by k quarter turns. Two's complement makes
  // k & 3 the quadrant for negative k as well.
  switch (static_cast<unsigned>(static_cast<int>(k)) & 3U) {
    case 0:
      return SinCos{s, c};
    case 1:
      return SinCos{c, -s};
    case 2:
      return SinCos{-s, -c};
    default:
      return SinCos{-c, s};
  }
}

}  // namespace lslam
