#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>

#include "lslam/geometry/sin_cos.h"

using lslam::SinCos;
using lslam::sinCos;

namespace {

constexpr unsigned kSeed = 20261123u;
constexpr int kCases = 200000;
constexpr double kPi = 3.14159265358979323846;

// The reference is the host's libm (glibc's sin and cos are correctly rounded in practice). Both
// values lie in [-1, 1], so an absolute bound of two ulps of 1 covers a result within one ulp of
// the true value plus the reference's own half ulp.
constexpr double kTolerance = 2.0 * std::numeric_limits<double>::epsilon();

void checkAgainstLibm(double angle) {
  const SinCos sc = sinCos(angle);
  CAPTURE(angle);
  CHECK(std::abs(sc.sin - std::sin(angle)) <= kTolerance);
  CHECK(std::abs(sc.cos - std::cos(angle)) <= kTolerance);
}

}  // namespace

TEST_CASE("sinCos matches libm on random angles of every regime") {
  std::mt19937_64 rng(kSeed);
  std::uniform_real_distribution<double> wrapped(-kPi, kPi);
  std::uniform_real_distribution<double> wide(-200.0, 200.0);
  std::uniform_real_distribution<double> exponent(-30.0, 0.0);
  for (int i = 0; i < kCases; ++i) {
    checkAgainstLibm(wrapped(rng));
    checkAgainstLibm(wide(rng));
    const double tiny = std::pow(10.0, exponent(rng));
    checkAgainstLibm(tiny);
    checkAgainstLibm(-tiny);
  }
}

TEST_CASE("sinCos is accurate at quadrant boundaries, where the reduction cancels") {
  for (int k = -64; k <= 64; ++k) {
    const double boundary = k * (kPi / 2.0);
    for (double offset : {0.0, 1e-12, -1e-12, kPi / 4.0, -kPi / 4.0}) {
      checkAgainstLibm(boundary + offset);
      checkAgainstLibm(std::nextafter(boundary + offset, 1e9));
      checkAgainstLibm(std::nextafter(boundary + offset, -1e9));
    }
  }
  // Near multiples of pi/2 the result is small and needs relative, not absolute, accuracy.
  const double near_pi = std::nextafter(kPi, 0.0);
  CHECK(std::abs(sinCos(near_pi).sin - std::sin(near_pi)) <= 4e-16 * std::abs(std::sin(near_pi)));
  CHECK(std::abs(sinCos(kPi / 2).cos - std::cos(kPi / 2)) <= 4e-16 * std::abs(std::cos(kPi / 2)));
}

TEST_CASE("sinCos is exact at zero and handles large and non-finite angles") {
  for (double zero : {0.0, -0.0}) {
    CHECK(sinCos(zero).sin == 0.0);
    CHECK(sinCos(zero).cos == 1.0);
  }
  // Beyond the fixed-cost range the angle is wrapped first; the wrap uses the double nearest
  // 2 pi, which moves the result by at most |angle| * 2.4e-16 / (2 pi).
  for (double big : {7e4, -7e4, 1e6, -3.5e7}) {
    const SinCos sc = sinCos(big);
    const double tol = std::abs(big) * 2.5e-16 + kTolerance;
    CAPTURE(big);
    CHECK(std::abs(sc.sin - std::sin(big)) <= tol);
    CHECK(std::abs(sc.cos - std::cos(big)) <= tol);
  }
  for (double bad :
       {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
        -std::numeric_limits<double>::infinity()}) {
    CHECK(std::isnan(sinCos(bad).sin));
    CHECK(std::isnan(sinCos(bad).cos));
  }
}
