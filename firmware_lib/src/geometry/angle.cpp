#include "lslam/geometry/angle.h"

#include <cmath>

namespace lslam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTwoPi = 2.0 * kPi;

}  // namespace

double wrapAngle(double angle) noexcept {
  if (angle > -kPi && angle <= kPi) return angle;  // the common case costs one comparison pair
  // Sums and differences of two wrapped angles lie within 3 pi. There one shift by 2 pi is exact
  // (Sterbenz: the operands are within a factor of two) and equals the IEEE remainder below, at
  // a fixed cost: a heading that crosses the cut must not make a step dearer on the target.
  if (angle > kPi && angle <= 3.0 * kPi) return angle - kTwoPi;
  if (angle <= -kPi && angle > -3.0 * kPi) return angle + kTwoPi;
  // The IEEE remainder is exact and lies in [-pi, pi]; only -pi needs moving to the open end.
  double r = std::remainder(angle, kTwoPi);
  if (r <= -kPi) r += kTwoPi;
  return r;
}

}  // namespace lslam
