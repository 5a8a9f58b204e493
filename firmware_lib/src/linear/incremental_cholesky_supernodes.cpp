// The full factorization by supernodes (block sizes 3 and 6, on hosts with the AVX kernels; see
// factorize()).
//
// Right-looking, column by column, a column's update of each later column loads and stores every
// target block once per source column. Across the dense top of a large factor the targets no
// longer fit in cache, so that traffic, not the arithmetic, sets the pace. Consecutive columns
// whose structures nest, struct(k) = {k + 1} u struct(k + 1) (a chain of the elimination tree with
// no fill branching in: a supernode), share every row outside the chain. Their updates of those
// rows are applied together: each target block is loaded once, receives the chain's products in
// ascending column order, and is stored once. That order is the one the column-by-column loop
// applies them in, so the factor is bit for bit the same (a width-1 supernode is the plain loop).
// The targets are still loaded from beyond the cache once per chain; keeping a panel of them in
// cache across chains (a 2-D blocked, supernodal factorization) would remove the rest.
#include "lslam/linear/block_kernels.h"
#include "lslam/linear/incremental_cholesky.h"

namespace lslam {
namespace {

// Longer chains are split: fewer loads of each target vs. more source columns streamed at once.
constexpr Index kMaxSupernodeWidth = 8;

}  // namespace

// The supernode that starts at affected[*next]; *next moves past it.
template <int... S>
Status IncrementalCholesky<S...>::factorizeSupernode(Index* next) {
  const Index first = a_.affected[*next];
  const Index last = supernodeEnd(*next);
  for (Index m = first; m <= last; ++m) {
    const Status s = finishColumn(m);
    if (s != Status::Ok) return s;
    scatterWithinSupernode(m, last);
  }
  scatterFromSupernode(first, last);
  *next += last - first + 1;
  return Status::Ok;
}

// The last column of the supernode that starts at affected[i]: the chain continues while a
// column's parent is the next column and its structure is one row longer than the parent's
// (struct(k) \ {parent} is always within struct(parent), so the two are then equal).
template <int... S>
Index IncrementalCholesky<S...>::supernodeEnd(Index i) const {
  const Index first = a_.affected[i];
  Index last = first;
  for (; i + 1 < affected_count_ && last - first + 1 < kMaxSupernodeWidth; ++i) {
    const Index next = a_.affected[i + 1];
    const Index size = a_.staged_count[last];
    if (next != last + 1 || size < 2 || a_.rows[a_.staged_start[last] + 1] != next ||
        size != a_.staged_count[next] + 1) {
      break;
    }
    last = next;
  }
  return last;
}

// Column m's update of the chain's later columns m + 1 .. last (its rows 1 .. last - m), as
// scatter() does it for every row (a function of its own, so that scatter(), also the Cortex-M's
// path, stays lean). A later column t = m + a holds exactly m's rows from a on.
template <int... S>
void IncrementalCholesky<S...>::scatterWithinSupernode(Index m, Index last) {
  if constexpr (detail::kAvxForms<D>) {
    const Index* rows = a_.rows + a_.staged_start[m];
    const Block* blocks = a_.blocks + a_.staged_start[m];
    const Index size = a_.staged_count[m];
    for (Index a = 1; a <= last - m; ++a) {
      const Index t = rows[a];
      Block* target = a_.blocks + a_.staged_start[t];
      const Block s = -1.0 * blocks[a].transpose();
      a_.staged_d[t].noalias() += s.transpose() * a_.staged_d[m];
      detail::addBlockProductsAvx(blocks, rows, a, size, s, a_.rows + a_.staged_start[t], target);
      stats_.block_products += size - a;
    }
  } else {
    LSLAM_ASSERT(false);  // only the factors of D = 3 and 6 have the AVX kernels
    static_cast<void>(m);
    static_cast<void>(last);
  }
}

// The chain first .. last updates the columns of struct(last) together (see the top).
template <int... S>
void IncrementalCholesky<S...>::scatterFromSupernode(Index first, Index last) {
  if constexpr (detail::kAvxForms<D>) {
    const Index width = last - first + 1;
    const Index* out_rows = a_.rows + a_.staged_start[last] + 1;
    const Index num_out = a_.staged_count[last] - 1;
    // Column m's rows outside the chain start at its (last - m + 1)-th block: out_rows in order.
    const Block* out[kMaxSupernodeWidth];
    for (Index m = first; m <= last; ++m) {
      out[m - first] = a_.blocks + a_.staged_start[m] + (last - m + 1);
      // What scatter() counts for targets out_rows[j]: num_out - j products each.
      stats_.block_products += static_cast<std::int64_t>(num_out) * (num_out + 1) / 2;
    }
    for (Index j = 0; j < num_out; ++j) {
      const Index target_column = out_rows[j];
      const Index* target_rows = a_.rows + a_.staged_start[target_column];
      Block* target = a_.blocks + a_.staged_start[target_column];
      // Written as scatter() writes it, for its bits (Eigen sums L d in another order).
      for (Index m = 0; m < width; ++m) {
        const Block s = -1.0 * out[m][j].transpose();
        a_.staged_d[target_column].noalias() += s.transpose() * a_.staged_d[first + m];
      }
      // From row j, the target's own (its diagonal block), as scatter() does it.
      detail::subtractOuterProductsOfColumnsAvx(out, width, out_rows, j, num_out, target_rows,
                                                target);
    }
  } else {
    LSLAM_ASSERT(false);  // only the factors of D = 3 and 6 have the AVX kernels
    static_cast<void>(first);
    static_cast<void>(last);
  }
}

#define LSLAM_INSTANTIATE_SUPERNODES(...)                                               \
  template Status IncrementalCholesky<__VA_ARGS__>::factorizeSupernode(Index*);         \
  template Index IncrementalCholesky<__VA_ARGS__>::supernodeEnd(Index) const;           \
  template void IncrementalCholesky<__VA_ARGS__>::scatterWithinSupernode(Index, Index); \
  template void IncrementalCholesky<__VA_ARGS__>::scatterFromSupernode(Index, Index);
LSLAM_INSTANTIATE_SUPERNODES(2)
LSLAM_INSTANTIATE_SUPERNODES(3)
LSLAM_INSTANTIATE_SUPERNODES(6)
#undef LSLAM_INSTANTIATE_SUPERNODES

}  // namespace lslam
