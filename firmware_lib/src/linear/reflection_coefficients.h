#pragma once
// What the row update's SIMD kernels share: the reflection coefficients where their row-block
// loops read them, and where each row block's L comes from.
#include "lslam/eigen.h"
#include "lslam/linear/index.h"

namespace lslam {
namespace detail {

// Per reflection j: the u entries of factor 0 (c = 0 .. D - 1), of factor 1, .., then beta(j). A
// local copy, because the kernels' W and L stores may alias u for all the compiler knows: read
// through u, GCC reloads each entry per row block.
template <int D, int M>
struct ReflectionCoefficients {
  double of[D][D * M + 1];

  ReflectionCoefficients(const Eigen::Matrix<double, D, D>* u,
                         const Eigen::Matrix<double, D, 1>& beta) {
    for (int j = 0; j < D; ++j) {
      for (int m = 0; m < M; ++m) {
        for (int c = 0; c < D; ++c) of[j][D * m + c] = u[m](c, j);
      }
      of[j][D * M] = beta(j);
    }
  }
};

// Where row block b's L is read (see applyRowReflectionsFromAvx): source_blocks[b] for b < kept,
// source_blocks[source[b]] beyond, or a zero block (fill).
template <int D>
struct ReflectionSources {
  const Eigen::Matrix<double, D, D>* source_blocks;
  const Index* source;
  Index kept;

  static constexpr double kZero[D * D] = {};

  const double* operator()(Index b) const {
    if (b < kept) return source_blocks[b].data();
    return source[b] != kNoIndex ? source_blocks[source[b]].data() : kZero;
  }
};

}  // namespace detail
}  // namespace lslam
