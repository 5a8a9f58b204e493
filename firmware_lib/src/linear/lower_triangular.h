#pragma once
// Small dense kernels on the D x D diagonal blocks of the factor.
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

}  // namespace detail
}  // namespace lslam
