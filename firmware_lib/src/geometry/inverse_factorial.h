// 1 / n! at compile time: the coefficients of the geometry's Taylor series.
#pragma once

namespace lslam::detail {

constexpr double inverseFactorial(int n) {
  double f = 1.0;
  for (int i = 2; i <= n; ++i) f *= i;
  return 1.0 / f;
}

}  // namespace lslam::detail
