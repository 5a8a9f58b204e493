#pragma once
// The inner loops of the factor's updates on D x D blocks: the block product of the numeric
// factorization (t += b s) and the Householder reflections of the row update.
//
// Portable forms, written as elementwise column operations with every sum taken from the left,
// rather than left to Eigen's products, whose summation order differs between the rows they
// vectorize and the rest (the one exception is noted at addBlockProduct).
// On an x86-64 host the two loops that dominate a large factor's updates also have AVX forms for
// D = 3: a 3 x 3 block's columns of 3 leave SSE2's 2-lane registers a lane short, and a 4-lane
// register takes a column in one instruction. They are chosen at run time (cpuHasAvx), so the
// host binary still runs on any x86-64, and they use no FMA and sum in the portable order, so
// every host computes the same bits as the portable forms (the committed stream header and the
// Cortex-M results are compared with those bits). On other targets cpuHasAvx() is false.
#include "lslam/eigen.h"
#include "lslam/linear/index.h"

namespace lslam {
namespace detail {

// t += b * s. On x86-64 column by column with only elementwise operations, so that every row is
// summed in the same order whether or not Eigen vectorizes it (the AVX form matches it bit for
// bit). Elsewhere Eigen's product, which takes the fewest instructions on the scalar Cortex-M
// (the elementwise form cost its relinearizations 19 % more).
template <int D>
inline void addBlockProduct(Eigen::Matrix<double, D, D>& t, const Eigen::Matrix<double, D, D>& b,
                            const Eigen::Matrix<double, D, D>& s) {
#if defined(__x86_64__)
  for (int c = 0; c < D; ++c) {
    Eigen::Matrix<double, D, 1> sum = b.col(0) * s(0, c);
    for (int k = 1; k < D; ++k) sum += b.col(k) * s(k, c);
    t.col(c) += sum;
  }
#else
  t.noalias() += b * s;
#endif
}

// [x_l x_w] H_0 ... H_{D-1} in place, for the rows of x_l and x_w (any count, D columns each),
// with H_j = I - beta(j) v_j v_j^T and v_j = e_j + [0; u.col(j)] (2D long). Elementwise, as above.
template <int D, typename XL, typename XW>
inline void applyRowReflections(const Eigen::Matrix<double, D, D>& u,
                                const Eigen::Matrix<double, D, 1>& beta, XL& x_l, XW& x_w) {
#pragma GCC unroll 6
  for (int j = 0; j < D; ++j) {
    auto t = (x_w.col(0) * u(0, j)).eval();
#pragma GCC unroll 6
    for (int c = 1; c < D; ++c) t += x_w.col(c) * u(c, j);
    const auto s = (beta(j) * (x_l.col(j) + t)).eval();
    x_l.col(j) -= s;
#pragma GCC unroll 6
    for (int c = 0; c < D; ++c) x_w.col(c) -= s * u(c, j);
  }
}

// Whether this CPU runs the AVX forms below (never off x86-64: known at compile time there, so the
// checks cost the target nothing).
#if defined(__x86_64__)
bool cpuHasAvx();
#else
constexpr bool cpuHasAvx() {
  return false;
}
#endif

// applyRowReflections on the row blocks x_l = blocks[b], x_w = w[rows[b]] for b in [1, size).
void applyRowReflectionsAvx(const Mat3& u, const Vec3& beta, Mat3* blocks, const Index* rows,
                            Index size, Mat3* w);

// addBlockProduct(target[p], blocks[b], s) for b in [first, size), with p the place of rows[b]
// among target_rows (ascending, holding every rows[b]; target_rows[0] is below them all).
void addBlockProductsAvx(const Mat3* blocks, const Index* rows, Index first, Index size,
                         const Mat3& s, const Index* target_rows, Mat3* target);

// addBlockProductsAvx for several source columns at once: for b in [first, size), target[p] +=
// columns[0][b] * s[0], then += columns[1][b] * s[1], ... (each product summed as in
// addBlockProduct), p the place of rows[b] among target_rows. The target block is loaded and
// stored once for all of them.
void addBlockProductsOfColumnsAvx(const Mat3* const* columns, const Mat3* s, Index num_columns,
                                  const Index* rows, Index first, Index size,
                                  const Index* target_rows, Mat3* target);

}  // namespace detail
}  // namespace lslam
