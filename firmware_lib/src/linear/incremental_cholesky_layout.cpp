// The pool layout for the back-substitution (IncrementalCholesky::layoutForSolve).
//
// Rewrites the live columns to the front of the pool in the order backSubstitute visits them (root
// first, depth first, children in descending order), so that a solve reads the pool forwards
// instead of jumping from column to column. Later updates keep the layout for every column whose
// structure does not grow (see settleStagedColumns); grown and added columns go to the tail until
// the next full refactorization lays the factor out again. The layout of a full refactorization is
// done by the next beginUpdate() or compact() (layout_pending_): the refactorization is the dearest
// update, and a whole copy of the factor fits better in the next, cheap one.
//
// The columns are written straight to the front when every one lies beyond the live size (after
// a full refactorization, which leaves the fresh columns above the old ones); otherwise through
// the free tail, then moved down. Without room for either, the layout stays as it is.
//
// In a file of its own: in incremental_cholesky.cpp it would change the compiler's inlining of the
// column functions there, and with it the Cortex-M's cost per odometry step.
#include <algorithm>
#include <cstring>

#include "lslam/linear/incremental_cholesky.h"
#include "subtract_transposed_products.h"

namespace lslam {

template <int... S>
void IncrementalCholesky<S...>::layoutForSolve() {
  LSLAM_ASSERT(!in_update_);
  layout_pending_ = false;  // done now, or impossible until a compaction
  Index lowest = pool_end_;
  for (Index k = 0; k < n_; ++k) lowest = std::min(lowest, a_.start[k]);
  Index base = 0;
  Index value_base = 0;
  Index live_values = 0;
  if constexpr (!kUniform) {
    for (Index k = 0; k < n_; ++k) live_values += columnValues(a_.start[k], a_.count[k]);
  }
  // Written in place from 0 only when no column lies below the live size (mixed sizes: for the
  // values too); otherwise beyond the pool's end, then moved to the front.
  bool beyond_end = lowest < live_blocks_;
  if constexpr (!kUniform) {
    Index lowest_value = value_end_;
    for (Index k = 0; k < n_; ++k) {
      for (Index i = 0; i < a_.count[k]; ++i)
        lowest_value = std::min(lowest_value, a_.offset[a_.start[k] + i]);
    }
    beyond_end = beyond_end || lowest_value < live_values;
  }
  if (beyond_end) {
    if (pool_end_ + live_blocks_ > a_.max_blocks) return;
    if (value_end_ + live_values > a_.max_values) return;
    base = pool_end_;
    value_base = value_end_;
  }
  Index* stack = a_.heap;
  Index top = 0;
  Index write = base;
  Index value_write = value_base;
  for (Index c = a_.first_child[a_.max_columns]; c != kNoIndex; c = a_.next_sibling[c]) {
    stack[top++] = c;
  }
  while (top > 0) {
    const Index k = stack[--top];
    const Index from = a_.start[k];
    const Index size = a_.count[k];
    std::memcpy(a_.rows + write, a_.rows + from, sizeof(Index) * static_cast<std::size_t>(size));
    if constexpr (kUniform) {
      for (Index b = 0; b < size; ++b) a_.blocks[write + b] = a_.blocks[from + b];
    } else {
      const int width = a_.row_size[from];
      for (Index b = 0; b < size; ++b) {
        const Index length = a_.row_size[from + b] * width;
        std::memmove(a_.values + value_write, a_.values + a_.offset[from + b],
                     sizeof(double) * static_cast<std::size_t>(length));
        a_.row_size[write + b] = a_.row_size[from + b];
        a_.offset[write + b] = value_write - value_base;
        value_write += length;
      }
    }
    a_.start[k] = write - base;
    write += size;
    for (Index c = a_.first_child[k]; c != kNoIndex; c = a_.next_sibling[c]) stack[top++] = c;
  }
  LSLAM_ASSERT(write - base == live_blocks_);
  if (base != 0) {
    std::memmove(a_.rows, a_.rows + base, sizeof(Index) * static_cast<std::size_t>(live_blocks_));
    if constexpr (kUniform) {
      for (Index b = 0; b < live_blocks_; ++b) a_.blocks[b] = a_.blocks[base + b];
    } else {
      std::memmove(a_.row_size, a_.row_size + base, static_cast<std::size_t>(live_blocks_));
      std::memmove(a_.offset, a_.offset + base,
                   sizeof(Index) * static_cast<std::size_t>(live_blocks_));
      std::memmove(a_.values, a_.values + value_base,
                   sizeof(double) * static_cast<std::size_t>(live_values));
    }
  }
  value_end_ = live_values;
  pool_end_ = live_blocks_;
}

// The solve after a full refactorization, before its layout: every column is solved (the
// refactorization changed them all; a second solve before the next update repeats it), and
// descending column order (a parent always comes after its children) reads the columns where
// the factorization staged them, ascending, backwards and contiguously, where the depth-first walk
// would jump.
template <int... S>
Index IncrementalCholesky<S...>::solveInColumnOrder(Vector* delta, const Index* variable_at,
                                                    Index* visited) {
  for (Index k = n_ - 1; k >= 0; --k) {
    // Every column is solved here, moved or not.
    static_cast<void>(solveColumn(k, 0.0, delta[variable_at[k]]));
    a_.needs_solve[k] = 0;
    visited[n_ - 1 - k] = k;
  }
  return n_;
}

template <int... S>
void IncrementalCholesky<S...>::loadSolution(const Vector* delta, const Index* variable_at) {
  for (Index k = 0; k < n_; ++k) solutionEntry(k) = delta[variable_at[k]];
}

template void IncrementalCholesky<2>::layoutForSolve();
template void IncrementalCholesky<2>::loadSolution(const IncrementalCholesky<2>::Vector*,
                                                   const Index*);
template Index IncrementalCholesky<2>::solveInColumnOrder(IncrementalCholesky<2>::Vector*,
                                                          const Index*, Index*);
template void IncrementalCholesky<3>::layoutForSolve();
template void IncrementalCholesky<3>::loadSolution(const IncrementalCholesky<3>::Vector*,
                                                   const Index*);
template Index IncrementalCholesky<3>::solveInColumnOrder(IncrementalCholesky<3>::Vector*,
                                                          const Index*, Index*);
template void IncrementalCholesky<6>::layoutForSolve();
template void IncrementalCholesky<3, 2>::layoutForSolve();
template void IncrementalCholesky<3, 2>::loadSolution(const IncrementalCholesky<3, 2>::Vector*,
                                                      const Index*);
template Index IncrementalCholesky<3, 2>::solveInColumnOrder(IncrementalCholesky<3, 2>::Vector*,
                                                             const Index*, Index*);
template void IncrementalCholesky<6, 3>::layoutForSolve();
template void IncrementalCholesky<6, 3>::loadSolution(const IncrementalCholesky<6, 3>::Vector*,
                                                      const Index*);
template Index IncrementalCholesky<6, 3>::solveInColumnOrder(IncrementalCholesky<6, 3>::Vector*,
                                                             const Index*, Index*);
template void IncrementalCholesky<6>::loadSolution(const IncrementalCholesky<6>::Vector*,
                                                   const Index*);
template Index IncrementalCholesky<6>::solveInColumnOrder(IncrementalCholesky<6>::Vector*,
                                                          const Index*, Index*);

}  // namespace lslam
