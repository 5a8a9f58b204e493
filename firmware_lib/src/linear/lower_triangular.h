#pragma once
// Small dense kernels on the D x D diagonal blocks of the factor.
#include <cmath>

#include "lslam/eigen.h"

namespace lslam {
namespace detail {

// Inverse of a lower-triangular block with a nonzero diagonal, by forward substitution on the
// identity, column by column (the result is lower-triangular too).
template <int D>
Eigen::Matrix<double, D, D> invertLowerTriangular(const Eigen::Matrix<double, D, D>& l) {
  Eigen::Matrix<double, D, D> l_inv = Eigen::Matrix<double, D, D>::Zero();
  for (int c = 0; c < D; ++c) {
    for (int i = c; i < D; ++i) {
      double v = (i == c) ? 1.0 : 0.0;
      for (int p = c; p < i; ++p) v -= l(i, p) * l_inv(p, c);
      l_inv(i, c) = v / l(i, i);
    }
  }
  return l_inv;
}

// Lower Cholesky factor of a small SPD block, inverted: returns false on a pivot that is not
// positive and finite (never clamped: a bad pivot means the problem is not positive definite).
template <int D>
inline bool invertedCholesky(const Eigen::Matrix<double, D, D>& a, Eigen::Matrix<double, D, D>& l,
                             Eigen::Matrix<double, D, D>& l_inv) {
  l.setZero();
  for (int j = 0; j < D; ++j) {
    double pivot = a(j, j);
    for (int p = 0; p < j; ++p) pivot -= l(j, p) * l(j, p);
    if (!(pivot > 0.0) || !std::isfinite(pivot)) return false;
    const double ljj = std::sqrt(pivot);
    l(j, j) = ljj;
    for (int i = j + 1; i < D; ++i) {
      double v = a(i, j);
      for (int p = 0; p < j; ++p) v -= l(i, p) * l(j, p);
      l(i, j) = v / ljj;
    }
  }
  l_inv = detail::invertLowerTriangular<D>(l);
  return true;
}

}  // namespace detail
}  // namespace lslam
