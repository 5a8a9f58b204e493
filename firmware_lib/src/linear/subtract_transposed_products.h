#pragma once
// One column's step of the back-substitution, shared by the depth-first solve and the solve in
// column order (incremental_cholesky_layout.cpp). Internal to firmware_lib.
#include "lslam/eigen.h"
#include "lslam/linear/block_kernels.h"
#include "lslam/linear/index.h"

namespace lslam {
namespace detail {

// x -= sum_{i >= 1} blocks[i]^T y(rows[i]), y(r) the solution of row r (solution + S r, S =
// kSolutionStride<D>): the back-substitution's inner loop. The solution is kept by column position,
// so a row reads its y with one index (through the variables' order it would take two dependent
// loads). On a SIMD host the products are summed elementwise and reduced to a vector once per
// column, where a transposed block times a vector would reduce across lanes for every block.
// For D = 3 and 6 on x86-64 that is the std::fma form, whose bits the AVX2/FMA kernel of the whole
// column step gives (solveColumnAvx: a block column per register, where Eigen's SSE2 form leaves a
// lane of every column over). On a scalar FPU (the Cortex-M) the direct form takes fewer
// instructions.
template <int D>
inline void subtractTransposedProducts(Eigen::Matrix<double, D, 1>& x,
                                       const Eigen::Matrix<double, D, D>* blocks, const Index* rows,
                                       Index size, const double* solution) {
  using ConstSolution = Eigen::Map<const Eigen::Matrix<double, D, 1>>;
  constexpr Index kStride = kSolutionStride<D>;
#if defined(__x86_64__)
  if constexpr (D == 3 || D == 6) {
    subtractTransposedProductsFused(x, blocks, rows, size, solution);
    return;
  }
#endif
#if defined(__SSE2__) || defined(__ARM_NEON)
  // The parent's product (row 1) last, as in the x86-64 form (see subtractTransposedProductsFused).
  Eigen::Matrix<double, D, D> acc = Eigen::Matrix<double, D, D>::Zero();
  const auto add = [&](Index i) {
    acc += blocks[i].cwiseProduct(
        ConstSolution(solution + kStride * rows[i]).template replicate<1, D>());
  };
  for (Index i = 2; i < size; ++i) add(i);
  if (size > 1) add(1);
  x -= acc.colwise().sum().transpose();
#else
  for (Index i = 1; i < size; ++i) {
    x.noalias() -= blocks[i].transpose() * ConstSolution(solution + kStride * rows[i]);
  }
#endif
}

// Column k's part of L^T x = d: x(k) = L(k,k)^-T (d(k) - sum_{i >= 1} L(rows[i], k)^T x(rows[i])),
// from the column's stored blocks (blocks[0] is L(k,k)^-1) and the solutions of its rows.
template <int D>
inline Eigen::Matrix<double, D, 1> solveColumn(const Eigen::Matrix<double, D, 1>& d,
                                               const Eigen::Matrix<double, D, D>* blocks,
                                               const Index* rows, Index size,
                                               const double* solution) {
  Eigen::Matrix<double, D, 1> x = d;
  subtractTransposedProducts<D>(x, blocks, rows, size, solution);
#if defined(__x86_64__)
  // In the order of solveColumnAvx's reduction (Eigen's product of a 6 x 6 has its own).
  if constexpr (D == 6) return multiplyTransposed(blocks[0], x);
#endif
  return blocks[0].transpose() * x;
}

// Column k's whole step of the solve: x(k) (solveColumn) into its entry of the solution by
// position and into `delta`; returns whether it moved from the entry's old value by more than
// `tolerance` (max-norm). On an x86-64 host with AVX2/FMA one kernel does it all, with x kept in
// registers from the products to the stores (solveColumnAvx, the same bits).
template <int D>
inline bool solveColumnInPlace(const Eigen::Matrix<double, D, 1>& d,
                               const Eigen::Matrix<double, D, D>* blocks, const Index* rows,
                               Index size, double* solution, Index k, double tolerance,
                               Eigen::Matrix<double, D, 1>& delta) {
  if constexpr (kAvxForms<D>) {
    if (cpuHasAvxFma()) return solveColumnAvx(d, blocks, rows, size, solution, k, tolerance, delta);
  }
  Eigen::Map<Eigen::Matrix<double, D, 1>> entry(solution + kSolutionStride<D> * k);
  const Eigen::Matrix<double, D, 1> x = solveColumn<D>(d, blocks, rows, size, solution);
  const bool moved = (x - entry).cwiseAbs().maxCoeff() > tolerance;
  entry = x;
  delta = x;
  return moved;
}

}  // namespace detail
}  // namespace lslam
