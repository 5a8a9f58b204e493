#include <doctest/doctest.h>

#include <cmath>
#include <random>

#include "lslam/geometry/angle.h"
#include "numerical_diff.h"

using lslam::wrapAngle;
using lslam::test::kPi;

namespace {

constexpr unsigned kSeed = 20240601u;

}  // namespace

TEST_CASE("wrapAngle maps every angle into (-pi, pi] and keeps its direction") {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> wide(-1000.0, 1000.0);
  for (int i = 0; i < 10000; ++i) {
    const double a = wide(rng);
    const double r = wrapAngle(a);
    CHECK(r > -kPi);
    CHECK(r <= kPi);
    CHECK(std::abs(std::cos(r) - std::cos(a)) < 1e-12);
    CHECK(std::abs(std::sin(r) - std::sin(a)) < 1e-12);
  }
  std::uniform_real_distribution<double> inside(-kPi, kPi);
  for (int i = 0; i < 1000; ++i) {
    const double a = inside(rng);
    if (a > -kPi) CHECK(wrapAngle(a) == a);  // angles already in range are returned untouched
  }
  // Within 3 pi (sums of two wrapped angles) the result is exactly the IEEE remainder.
  std::uniform_real_distribution<double> near(-3.0 * kPi, 3.0 * kPi);
  for (int i = 0; i < 100000; ++i) {
    const double a = near(rng);
    double expected = std::remainder(a, 2.0 * kPi);
    if (expected <= -kPi) expected += 2.0 * kPi;
    CAPTURE(a);
    CHECK(wrapAngle(a) == expected);
  }
  for (double edge : {kPi, -kPi, 3.0 * kPi, -3.0 * kPi}) {
    for (double a : {std::nextafter(edge, 0.0), edge, std::nextafter(edge, 2.0 * edge)}) {
      double expected = std::remainder(a, 2.0 * kPi);
      if (expected <= -kPi) expected += 2.0 * kPi;
      CAPTURE(a);
      CHECK(wrapAngle(a) == expected);
    }
  }
  CHECK(wrapAngle(kPi) == kPi);
  CHECK(wrapAngle(-kPi) == kPi);
  CHECK(wrapAngle(0.0) == 0.0);
  CHECK(wrapAngle(2.0 * kPi) == 0.0);
  CHECK(wrapAngle(-2.0 * kPi) == 0.0);
  CHECK(wrapAngle(kPi + 1e-9) == doctest::Approx(-kPi + 1e-9).epsilon(1e-15));
  CHECK(wrapAngle(-kPi - 1e-9) == doctest::Approx(kPi - 1e-9).epsilon(1e-15));
  CHECK(wrapAngle(2.5 * kPi) == doctest::Approx(0.5 * kPi).epsilon(1e-15));
  CHECK(wrapAngle(-7.5 * kPi) == doctest::Approx(0.5 * kPi).epsilon(1e-14));
  const double three_pi = wrapAngle(3.0 * kPi);
  CHECK(three_pi > -kPi);
  CHECK(three_pi <= kPi);
  CHECK(std::abs(std::abs(three_pi) - kPi) < 1e-15);
}
