#include "lslam/linear/incremental_cholesky.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "lower_triangular.h"
#include "lslam/linear/block_kernels.h"
#include "rows_after_collector.h"
#include "subtract_transposed_products.h"

namespace lslam {

template <int... S>
IncrementalCholesky<S...>::IncrementalCholesky(const CholeskyArrays<S...>& arrays) : a_(arrays) {
  LSLAM_ASSERT(a_.max_columns > 0 && a_.max_blocks > 0);
  std::memset(a_.queued, 0, sizeof(std::uint32_t) * static_cast<std::size_t>(a_.max_columns));
  std::memset(a_.mark, 0, sizeof(std::uint32_t) * static_cast<std::size_t>(a_.max_columns));
  std::memset(a_.needs_solve, 0, static_cast<std::size_t>(a_.max_columns));
  std::memset(
      a_.solution, 0,
      sizeof(double) * detail::kSolutionStride<D> * static_cast<std::size_t>(a_.max_columns));
  const Index root = a_.max_columns;
  a_.first_child[root] = kNoIndex;
  a_.next_sibling[root] = kNoIndex;
  a_.prev_sibling[root] = kNoIndex;
}

template <int... S>
void IncrementalCholesky<S...>::beginUpdate(Index new_columns, bool full_refactor,
                                            const Index* variable_at) {
  LSLAM_ASSERT(!in_update_);
  LSLAM_ASSERT(new_columns >= 0 && n_ + new_columns <= a_.max_columns);
  if (layout_pending_) layoutForSolve();
  in_update_ = true;
  if (++stamp_ == 0) {  // wrapped: forget every old stamp so none is mistaken for a current one
    std::memset(a_.queued, 0, sizeof(std::uint32_t) * static_cast<std::size_t>(a_.max_columns));
    stamp_ = 1;
  }
  staged_columns_ = n_ + new_columns;
  pool_mark_ = pool_end_;
  value_mark_ = value_end_;
  heap_size_ = 0;
  affected_count_ = 0;
  full_ = full_refactor;
  keep_structures_ = false;
  reordered_ = false;
  top_collected_ = false;
  row_update_mark_ = 0;
  staging_variable_at_ = variable_at;
  stats_ = FactorizationStats{};
  if (full_) {
    // Every column is affected and is taken in ascending order: no queue (see factorize).
    for (Index k = 0; k < staged_columns_; ++k) a_.child_head[k] = kNoIndex;
  } else {
    for (Index k = n_; k < staged_columns_; ++k) queue(k);
  }
}

template <int... S>
void IncrementalCholesky<S...>::markChanged(Index column) {
  LSLAM_ASSERT(in_update_ && column >= 0 && column < staged_columns_);
  if (full_) return;  // every column is recomputed anyway
  queue(column);
  top_collected_ = false;  // a collected affected set no longer covers every changed column
}

template <int... S>
void IncrementalCholesky<S...>::keepUnchangedStructures() {
  LSLAM_ASSERT(in_update_ && full_);
  keep_structures_ = true;
}

// In a full refactorization the queue is idle, so its stamps mark the changed structures.
template <int... S>
void IncrementalCholesky<S...>::markStructureChanged(Index column) {
  LSLAM_ASSERT(in_update_ && column >= 0 && column < staged_columns_);
  if (keep_structures_) a_.queued[column] = stamp_;
}

template <int... S>
void IncrementalCholesky<S...>::queue(Index column) {
  if (a_.queued[column] == stamp_) return;
  a_.queued[column] = stamp_;
  a_.child_head[column] = kNoIndex;
  // Binary min-heap: the columns must be processed in ascending order, and a column's parent is
  // only known once the column's structure is.
  Index i = heap_size_++;
  while (i > 0) {
    const Index up = (i - 1) / 2;
    if (a_.heap[up] <= column) break;
    a_.heap[i] = a_.heap[up];
    i = up;
  }
  a_.heap[i] = column;
}

template <int... S>
Index IncrementalCholesky<S...>::popSmallest() {
  const Index top = a_.heap[0];
  const Index last = a_.heap[--heap_size_];
  Index i = 0;
  for (;;) {
    Index child = 2 * i + 1;
    if (child >= heap_size_) break;
    if (child + 1 < heap_size_ && a_.heap[child + 1] < a_.heap[child]) ++child;
    if (a_.heap[child] >= last) break;
    a_.heap[i] = a_.heap[child];
    i = child;
  }
  if (heap_size_ > 0) a_.heap[i] = last;
  return top;
}

template <int... S>
std::uint32_t IncrementalCholesky<S...>::nextMark() {
  if (++mark_id_ == 0) {
    std::memset(a_.mark, 0, sizeof(std::uint32_t) * static_cast<std::size_t>(a_.max_columns));
    mark_id_ = 1;
  }
  return mark_id_;
}

template <int... S>
Status IncrementalCholesky<S...>::factorize(const InformationSource<S...>& source,
                                            const Index* variable_at, const Index* position_of) {
  const Status s = startFactorization(source, variable_at, position_of);
  if (s != Status::Ok) return s;
  bool finished = false;
  return continueFactorization(std::numeric_limits<std::int64_t>::max(), &finished);
}

template <int... S>
Status IncrementalCholesky<S...>::startFactorization(const InformationSource<S...>& source,
                                                     const Index* variable_at,
                                                     const Index* position_of) {
  LSLAM_ASSERT(in_update_);
  staging_variable_at_ = variable_at;
  // Symbolic: the structure of every affected column, in ascending order. A column's parent is
  // queued as soon as the column's structure is known, which grows the set to the root. A full
  // refactorization takes every column in turn instead, without a heap's sift-down per column.
  if (full_) {
    for (Index k = 0; k < staged_columns_; ++k) {
      a_.affected[affected_count_++] = k;
      const Status s = keepsStructure(k) ? stageOldStructure(k)
                                         : buildStructure(k, source, variable_at, position_of);
      if (s != Status::Ok) return s;
    }
  }
  while (heap_size_ > 0) {
    const Index k = popSmallest();
    a_.affected[affected_count_++] = k;
    const Status s = buildStructure(k, source, variable_at, position_of);
    if (s != Status::Ok) return s;
  }
  // Numeric, right-looking over the affected columns only: each starts from its old value plus
  // the change of Lambda, and receives the updated-minus-old contributions of the affected columns
  // below it before it is factorized.
  if (full_) {
    assembleAllColumns(source, variable_at, position_of);
  } else {
    for (Index i = 0; i < affected_count_; ++i) {
      startColumn(a_.affected[i], source, variable_at, position_of);
    }
  }
  by_supernodes_ = false;
  if constexpr (kUniform && detail::kAvxForms<D>) by_supernodes_ = full_ && detail::cpuHasAvxFma();
  next_affected_ = 0;
  stats_.columns_recomputed = affected_count_;
  return Status::Ok;
}

// The numeric phase from the first column not yet factorized, a column (or a supernode) at a
// time, until it has spent max_products block products or every column is done.
template <int... S>
Status IncrementalCholesky<S...>::continueFactorization(std::int64_t max_products, bool* finished) {
  LSLAM_ASSERT(in_update_ && next_affected_ >= 0);
  const std::int64_t until =
      max_products >= std::numeric_limits<std::int64_t>::max() - stats_.block_products
          ? std::numeric_limits<std::int64_t>::max()
          : stats_.block_products + max_products;
  while (next_affected_ < affected_count_ && stats_.block_products < until) {
    if constexpr (kUniform && detail::kAvxForms<D>) {
      if (by_supernodes_) {
        const Status s = factorizeSupernode(&next_affected_);
        if (s != Status::Ok) return s;
        continue;
      }
    }
    const Index k = a_.affected[next_affected_++];
    const Status s = finishColumn(k);
    if (s != Status::Ok) return s;
    scatterSlots(a_.staged_start[k], a_.staged_count[k], a_.staged_d[k], -1.0);
    if (!full_ && k < n_) scatterSlots(a_.start[k], a_.count[k], a_.d[k], 1.0);
  }
  *finished = next_affected_ == affected_count_;
  stats_.blocks_written = pool_end_ - pool_mark_;
  return Status::Ok;
}

template <int... S>
Status IncrementalCholesky<S...>::buildStructure(Index k, const InformationSource<S...>& source,
                                                 const Index* variable_at,
                                                 const Index* position_of) {
  const std::uint32_t id = nextMark();
  Index* rows = a_.scratch;
  // Structures only grow (factors are never removed), so the old structure stays a subset.
  Index count = 0;
  if (!full_ && k < n_) {
    const Index* old_rows = a_.rows + a_.start[k];
    for (Index i = 1; i < a_.count[k]; ++i) {
      a_.mark[old_rows[i]] = id;
      rows[count++] = old_rows[i];
    }
  }
  detail::RowsAfterCollector collector(position_of, k, a_.mark, id, rows + count);
  source.visitNeighbours(variable_at[k], collector);
  count += collector.count();
  // Fill from the affected children: struct(k) contains struct(child) \ {k}. Unaffected
  // children's contributions are already in the old structure.
  count = addChildrenFill(k, id, rows, count);
  const Status s = stageStructure(k, rows, count);
  if (s != Status::Ok) return s;
  if (count > 0) {
    // The parent is affected too (queueing first: it resets its child list). In a full
    // refactorization it is taken in turn, its child list reset by beginUpdate.
    if (!full_) queue(rows[0]);
    linkStagedChild(k, rows[0]);
  }
  return Status::Ok;
}

// Adds the rows of k's staged children below k (their structure minus k) to a row list.
template <int... S>
Index IncrementalCholesky<S...>::addChildrenFill(Index k, std::uint32_t id, Index* rows,
                                                 Index count) {
  for (Index c = a_.child_head[k]; c != kNoIndex; c = a_.child_next[c]) {
    const Index* child_rows = a_.rows + a_.staged_start[c];
    for (Index i = 2; i < a_.staged_count[c]; ++i) {  // [0] is c, [1] is k itself
      const Index r = child_rows[i];
      if (a_.mark[r] != id) {
        a_.mark[r] = id;
        rows[count++] = r;
      }
    }
  }
  return count;
}

// Writes column k's structure (k, then `rows` sorted) to the pool tail.
template <int... S>
Status IncrementalCholesky<S...>::stageStructure(Index k, Index* rows, Index count) {
  std::sort(rows, rows + count);
  if (pool_end_ + count + 1 > a_.max_blocks) return Status::CapacityExhausted;
  if constexpr (!kUniform) {
    const int width = positionSize(k);
    Index height = width;
    for (Index i = 0; i < count; ++i) height += positionSize(rows[i]);
    if (value_end_ + height * width > a_.max_values) return Status::CapacityExhausted;
    a_.row_size[pool_end_] = static_cast<std::uint8_t>(width);
    a_.offset[pool_end_] = value_end_;
    value_end_ += width * width;
    for (Index i = 0; i < count; ++i) {
      const int size = positionSize(rows[i]);
      a_.row_size[pool_end_ + 1 + i] = static_cast<std::uint8_t>(size);
      a_.offset[pool_end_ + 1 + i] = value_end_;
      value_end_ += size * width;
    }
  }
  a_.staged_start[k] = pool_end_;
  a_.staged_count[k] = count + 1;
  a_.rows[pool_end_] = k;
  std::memcpy(a_.rows + pool_end_ + 1, rows, sizeof(Index) * static_cast<std::size_t>(count));
  pool_end_ += count + 1;
  return Status::Ok;
}

// Whether column k keeps its old structure (see keepUnchangedStructures); a column that does not
// is stamped, so that its parent does not either. Its children are staged already.
template <int... S>
bool IncrementalCholesky<S...>::keepsStructure(Index k) {
  if (!keep_structures_) return false;
  bool changed = k >= n_ || a_.queued[k] == stamp_;
  for (Index c = a_.child_head[k]; !changed && c != kNoIndex; c = a_.child_next[c]) {
    changed = a_.queued[c] == stamp_;
  }
  if (changed) a_.queued[k] = stamp_;
  return !changed;
}

// Stages column k's old structure as it is (k first, then its rows ascending).
template <int... S>
Status IncrementalCholesky<S...>::stageOldStructure(Index k) {
  const Index count = a_.count[k];
  if (pool_end_ + count > a_.max_blocks) return Status::CapacityExhausted;
  if constexpr (!kUniform) {
    const Index from = a_.start[k];
    if (value_end_ + columnValues(from, count) > a_.max_values) return Status::CapacityExhausted;
    const int width = a_.row_size[from];
    for (Index i = 0; i < count; ++i) {
      a_.row_size[pool_end_ + i] = a_.row_size[from + i];
      a_.offset[pool_end_ + i] = value_end_;
      value_end_ += a_.row_size[from + i] * width;
    }
  }
  a_.staged_start[k] = pool_end_;
  a_.staged_count[k] = count;
  std::memcpy(a_.rows + pool_end_, a_.rows + a_.start[k],
              sizeof(Index) * static_cast<std::size_t>(count));
  pool_end_ += count;
  if (count > 1) linkStagedChild(k, a_.rows[a_.start[k] + 1]);
  return Status::Ok;
}

// Links k as a staged child of its parent, so that the parent's structure picks up k's fill.
template <int... S>
void IncrementalCholesky<S...>::linkStagedChild(Index k, Index parent) {
  a_.child_next[k] = a_.child_head[parent];
  a_.child_head[parent] = k;
}

template <int... S>
void IncrementalCholesky<S...>::startColumn(Index k, const InformationSource<S...>& source,
                                            const Index* variable_at, const Index* position_of) {
  const Index start = a_.staged_start[k];
  const Index size = a_.staged_count[k];
  const Index* rows = a_.rows + start;
  if constexpr (!kUniform) {
    startMixedColumn(k, source, variable_at, position_of);
    return;
  }
  Block* blocks = a_.blocks + start;
  for (Index i = 0; i < size; ++i) {
    a_.slot[rows[i]] = i;
    blocks[i].setZero();
  }
  Vector& e = a_.staged_d[k];
  e.setZero();
  if (!reordered_ && k < n_) {  // a reordered update starts from the old Schur complement instead
    // C_old(:,k) = L_old(:,k) L_old(k,k)^T and e_old = L_old(k,k) d_old: the column as it was
    // before its pivot, on the old structure (a subset of the updated one).
    const Block& l = a_.diagonal[k];
    const Block l_t = l.transpose();
    const Index* old_rows = a_.rows + a_.start[k];
    const Block* old_blocks = a_.blocks + a_.start[k];
    blocks[0].noalias() = l * l_t;
    for (Index i = 1; i < a_.count[k]; ++i)
      blocks[a_.slot[old_rows[i]]].noalias() = old_blocks[i] * l_t;
    e.noalias() = l * a_.d[k];
  }
  ColumnAccumulator<S...> acc(blocks, a_.slot, &e);
  source.assembleColumnChange(variable_at[k], position_of, acc);
}

// A full factorization assembles every column of Lambda, ascending, each factor linearized once
// (InformationSource::assembleColumn): the diagonal blocks and eta of the later columns
// accumulate in staged_diagonal and staged_d (compact arrays; staged_diagonal is free until the
// column is factorized), and each column's own blocks are zeroed just before it is assembled:
// zeroing the whole staged factor first and adding to diagonal blocks scattered over it would
// cost a cache miss per factor.
template <int... S>
void IncrementalCholesky<S...>::assembleAllColumns(const InformationSource<S...>& source,
                                                   const Index* variable_at,
                                                   const Index* position_of) {
  for (Index i = 0; i < affected_count_; ++i) {
    a_.staged_diagonal[a_.affected[i]].setZero();
    a_.staged_d[a_.affected[i]].setZero();
  }
  LaterDiagonals<S...> later(a_.staged_diagonal, a_.staged_d);
  for (Index i = 0; i < affected_count_; ++i) {
    const Index k = a_.affected[i];
    const Index* rows = a_.rows + a_.staged_start[k];
    if constexpr (!kUniform) {
      assembleMixedColumn(k, source, variable_at, position_of, later);
      continue;
    }
    Block* blocks = a_.blocks + a_.staged_start[k];
    // Every earlier column has been assembled: what they sent to k's diagonal is complete.
    blocks[0] = a_.staged_diagonal[k];
    for (Index b = 1; b < a_.staged_count[k]; ++b) {
      blocks[b].setZero();
      a_.slot[rows[b]] = b;
    }
    ColumnAccumulator<S...> acc(blocks, a_.slot, &a_.staged_d[k]);
    source.assembleColumn(variable_at[k], position_of, acc, later);
  }
}

template <int... S>
Status IncrementalCholesky<S...>::finishColumn(Index k) {
  if constexpr (!kUniform) return finishMixedColumn(k);
  const Index size = a_.staged_count[k];
  Block* blocks = a_.blocks + a_.staged_start[k];
  Block l;
  Block l_inv;
  if (!detail::invertedCholesky<D>(blocks[0], l, l_inv)) return Status::NotPositiveDefinite;
  a_.staged_diagonal[k] = l;
  blocks[0] = l_inv;
  // L(:,k) = C(:,k) L(k,k)^-T, and L(k,k)^-1 is lower-triangular: 6 multiply-adds per block row.
  detail::multiplyBlocksByTransposedLower<D>(blocks + 1, size - 1, l_inv);
  a_.staged_d[k] = (l_inv * a_.staged_d[k]).eval();
  // Finite pivots do not make a finite right-hand side: a huge information times a large error
  // (eta = J^T Omega e) overflows there alone, and the solution would be NaN with no other sign.
  if (!a_.staged_d[k].allFinite()) return Status::NumericalOverflow;
  return Status::Ok;
}

// Sends column k's contribution -/+ L(r,k) L(s,k)^T (and -/+ L(s,k) d(k)) to every column s of its
// structure: sign -1 for the recomputed column, +1 to take back the old one. Every target is
// staged.
template <int... S>
void IncrementalCholesky<S...>::scatter(const Index* rows, const Block* blocks, Index size,
                                        const Vector& d, double sign) {
  bool host_kernels = false;  // asked once per column: a call on a hot loop otherwise
  if constexpr (detail::kAvxForms<D>) host_kernels = detail::cpuHasAvxFma();
  for (Index a = 1; a < size; ++a) {
    const Index s = rows[a];
    const Index* target_rows = a_.rows + a_.staged_start[s];
    Block* target = a_.blocks + a_.staged_start[s];
    const Index target_size = a_.staged_count[s];
    const Block l_sk_t = sign * blocks[a].transpose();
    a_.staged_d[s].noalias() += l_sk_t.transpose() * d;
    // rows[a..] is a subset of the target's rows, both ascending: merge. rows[a] is s itself, the
    // target's diagonal block (target_rows[0]). The AVX kernel takes it in the same loop; the
    // portable loop takes it first, as addBlockProduct: the same bits, and on the Cortex-M7 fewer
    // instructions than inside the merge.
    if constexpr (detail::kAvxForms<D>) {
      if (host_kernels) {
        detail::addBlockProductsAvx(blocks, rows, a, size, l_sk_t, target_rows, target);
        stats_.block_products += size - a;
        continue;
      }
    }
    detail::addBlockProduct<D>(target[0], blocks[a], l_sk_t);
    Index p = 1;
    for (Index b = a + 1; b < size; ++b) {
      while (target_rows[p] < rows[b]) ++p;
      LSLAM_DEBUG_ASSERT(p < target_size && target_rows[p] == rows[b]);
      detail::addBlockProduct<D>(target[p], blocks[b], l_sk_t);
    }
    static_cast<void>(target_size);
    stats_.block_products += size - a;
  }
}

template <int... S>
void IncrementalCholesky<S...>::scatterSlots(Index start, Index count, const Vector& d,
                                             double sign) {
  if constexpr (kUniform) {
    scatter(a_.rows + start, a_.blocks + start, count, d, sign);
  } else {
    scatterMixed(start, count, d, sign);
  }
}

template <int... S>
void IncrementalCholesky<S...>::commit() {
  LSLAM_ASSERT(in_update_);
  if (reordered_) {
    commitReordered();
    return;
  }
  const Index old_n = n_;
  if (!full_) settleStagedColumns();
  // New columns start with no children; their children (earlier columns) link in below.
  for (Index k = old_n; k < staged_columns_; ++k) a_.first_child[k] = kNoIndex;
  for (Index i = 0; i < affected_count_; ++i) {
    const Index k = a_.affected[i];
    const bool had_column = !full_ && k < old_n;
    const Index old_parent = had_column ? parent(k) : kNoIndex;
    if (had_column) live_blocks_ -= a_.count[k];
    installStaged(k);
    if (!full_) {
      const Index new_parent = parent(k);
      if (!had_column) {
        linkChild(new_parent, k);
      } else if (new_parent != old_parent) {
        unlinkChild(old_parent, k);
        linkChild(new_parent, k);
      }
    }
  }
  if (full_) {
    live_blocks_ = pool_end_ - pool_mark_;
    n_ = staged_columns_;
    rebuildChildLists();
  }
  n_ = staged_columns_;
  in_update_ = false;
  // The layout waits for the next update (or compaction): a refactorization is the dearest
  // update, and copying the whole factor fits better in the next, cheap one.
  if (full_) layout_pending_ = true;
}

// Makes column k's staged values its committed ones.
template <int... S>
void IncrementalCholesky<S...>::installStaged(Index k) {
  a_.start[k] = a_.staged_start[k];
  a_.count[k] = a_.staged_count[k];
  live_blocks_ += a_.count[k];
  a_.d[k] = a_.staged_d[k];
  a_.diagonal[k] = a_.staged_diagonal[k];
  a_.needs_solve[k] = 1;
}

// Copy-on-write leaves every recomputed column at the pool tail. Left there, the tail would march
// through the whole pool, one copy of the top per loop closure, with each column wherever its
// latest copy landed: the factor spread over far more memory than it occupies, so every solve
// streams it from main memory. Instead, a column whose structure did not grow is copied back over
// its committed blocks (the structures are then equal: they only grow), and the columns that grew
// (and the added ones) are packed at the start of the staging area. The tail is reused by the next
// update, the factor stays compact, and only grown columns leave garbage behind.
template <int... S>
void IncrementalCholesky<S...>::settleStagedColumns() {
  Index* grown = a_.scratch;
  Index num_grown = 0;
  for (Index i = 0; i < affected_count_; ++i) {
    const Index k = a_.affected[i];
    if (k < n_ && a_.staged_count[k] == a_.count[k]) {
      copyColumnValues(a_.staged_start[k], a_.count[k], a_.start[k]);
      a_.staged_start[k] = a_.start[k];
    } else {
      grown[num_grown++] = k;
    }
  }
  const PoolEnd end =
      packColumns(grown, num_grown, a_.staged_start, a_.staged_count, {pool_mark_, value_mark_});
  pool_end_ = end.blocks;
  value_end_ = end.values;
}

// Moves `columns` (start/count: their pool places) to consecutive places from `write` on, in pool
// order, so that every move goes towards the front and never over a column not yet moved (mixed
// sizes: a column's values lie in the pool in the order of its slots, so the same holds for them).
// Returns the end of the packed range.
template <int... S>
typename IncrementalCholesky<S...>::PoolEnd IncrementalCholesky<S...>::packColumns(
    Index* columns, Index num, Index* start, const Index* count, PoolEnd write) {
  std::sort(columns, columns + num, [start](Index x, Index y) { return start[x] < start[y]; });
  for (Index i = 0; i < num; ++i) {
    const Index k = columns[i];
    const Index from = start[k];
    const Index size = count[k];
    if constexpr (kUniform) {
      if (from != write.blocks) {
        std::memmove(a_.rows + write.blocks, a_.rows + from,
                     sizeof(Index) * static_cast<std::size_t>(size));
        for (Index b = 0; b < size; ++b) a_.blocks[write.blocks + b] = a_.blocks[from + b];
      }
    } else {
      write.values = moveColumn(from, size, write);
    }
    start[k] = write.blocks;
    write.blocks += size;
  }
  return write;
}

template <int... S>
std::int64_t IncrementalCholesky<S...>::inPlaceProducts() {
  LSLAM_ASSERT(in_update_ && !full_);
  const std::uint32_t id = nextMark();
  std::int64_t products = 0;
  for (Index h = 0; h < heap_size_; ++h) {
    // An added column has no structure yet, and no parent to walk to.
    for (Index k = a_.heap[h]; k != kNoIndex && k < n_ && a_.mark[k] != id; k = parent(k)) {
      a_.mark[k] = id;
      products += static_cast<std::int64_t>(a_.count[k]) * a_.count[k];
    }
  }
  return products;
}

template <int... S>
void IncrementalCholesky<S...>::rollback() {
  LSLAM_ASSERT(in_update_);
  pool_end_ = pool_mark_;
  value_end_ = value_mark_;
  staged_columns_ = n_;
  affected_count_ = 0;
  in_update_ = false;
}

template <int... S>
void IncrementalCholesky<S...>::linkChild(Index parent, Index child) {
  const Index p = parent == kNoIndex ? a_.max_columns : parent;
  const Index head = a_.first_child[p];
  a_.next_sibling[child] = head;
  a_.prev_sibling[child] = kNoIndex;
  if (head != kNoIndex) a_.prev_sibling[head] = child;
  a_.first_child[p] = child;
}

template <int... S>
void IncrementalCholesky<S...>::unlinkChild(Index parent, Index child) {
  const Index p = parent == kNoIndex ? a_.max_columns : parent;
  const Index prev = a_.prev_sibling[child];
  const Index next = a_.next_sibling[child];
  if (prev != kNoIndex) {
    a_.next_sibling[prev] = next;
  } else {
    a_.first_child[p] = next;
  }
  if (next != kNoIndex) a_.prev_sibling[next] = prev;
}

template <int... S>
void IncrementalCholesky<S...>::rebuildChildLists() {
  a_.first_child[a_.max_columns] = kNoIndex;
  for (Index k = 0; k < n_; ++k) a_.first_child[k] = kNoIndex;
  // Descending, so that every child list ends up in ascending order.
  for (Index k = n_ - 1; k >= 0; --k) linkChild(parent(k), k);
}

template <int... S>
void IncrementalCholesky<S...>::clear() {
  LSLAM_ASSERT(!in_update_);
  n_ = 0;
  staged_columns_ = 0;
  pool_end_ = pool_mark_ = 0;
  value_end_ = value_mark_ = 0;
  live_blocks_ = 0;
  affected_count_ = 0;
  layout_pending_ = false;
  a_.first_child[a_.max_columns] = kNoIndex;
}

template <int... S>
void IncrementalCholesky<S...>::swap(IncrementalCholesky& other) {
  LSLAM_ASSERT(!in_update_ && !other.in_update_);
  const IncrementalCholesky kept = *this;
  *this = other;
  other = kept;
}

template <int... S>
void IncrementalCholesky<S...>::compact() {
  LSLAM_ASSERT(!in_update_);
  if (layout_pending_) {
    layoutForSolve();
    if (pool_end_ == live_blocks_) return;
  }
  Index* order = a_.scratch;
  for (Index k = 0; k < n_; ++k) order[k] = k;
  const PoolEnd end = packColumns(order, n_, a_.start, a_.count, {0, 0});
  pool_end_ = end.blocks;
  value_end_ = end.values;
  LSLAM_ASSERT(pool_end_ == live_blocks_);
}

template <int... S>
Index IncrementalCholesky<S...>::backSubstitute(Vector* delta, const Index* variable_at,
                                                double tolerance, bool full, Index* visited) {
  LSLAM_ASSERT(!in_update_);
  if (layout_pending_) return solveInColumnOrder(delta, variable_at, visited);
  const std::uint32_t changed = nextMark();
  std::uint32_t* const mark = a_.mark;
  Index* stack = a_.heap;
  Index top = 0;
  Index solved = 0;
  for (Index c = a_.first_child[a_.max_columns]; c != kNoIndex; c = a_.next_sibling[c]) {
    stack[top++] = c;
  }
  while (top > 0) {
    const Index k = stack[--top];
    const Index* rows = columnRows(k);
    const Index size = a_.count[k];
    bool moved;
    if constexpr (kUniform) {  // inline: once per visited column
      moved = detail::solveColumnInPlace<D>(a_.d[k], columnBlocks(k), rows, size, a_.solution, k,
                                            tolerance, delta[variable_at[k]]);
    } else {
      moved = solveMixedColumn(k, tolerance, delta[variable_at[k]]);
    }
    a_.needs_solve[k] = 0;
    visited[solved++] = k;
    if (moved) mark[k] = changed;
    // A column that did not move still passes on the moves of the rows it refers to: its
    // children refer to them too (their structure lies in k's and k itself).
    bool descend = full || moved;
    for (Index i = 1; !descend && i < size; ++i) descend = mark[rows[i]] == changed;
    for (Index c = a_.first_child[k]; c != kNoIndex; c = a_.next_sibling[c]) {
      if (descend || a_.needs_solve[c] != 0) stack[top++] = c;
    }
  }
  return solved;
}

template <int... S>
bool IncrementalCholesky<S...>::solveColumn(Index k, double tolerance, Vector& delta) {
  if constexpr (kUniform) {
    return detail::solveColumnInPlace<D>(a_.d[k], columnBlocks(k), columnRows(k), a_.count[k],
                                         a_.solution, k, tolerance, delta);
  } else {
    return solveMixedColumn(k, tolerance, delta);
  }
}

// The members defined here, one by one, as in the other parts of the class (_reorder, _row_update,
// _layout, _supernodes). Not `template class`: GCC's link-time optimizer turns this file's calls
// to members defined in another part into weak references when the class is instantiated whole,
// and a linker pulls no archive member for a weak reference (an -flto build then fails to link:
// undefined factorizeSupernode). Member by member, the references stay strong.
#define LSLAM_INSTANTIATE_CORE(...)                                                              \
  template IncrementalCholesky<__VA_ARGS__>::IncrementalCholesky(                                \
      const CholeskyArrays<__VA_ARGS__>&);                                                       \
  template void IncrementalCholesky<__VA_ARGS__>::beginUpdate(Index, bool, const Index*);        \
  template void IncrementalCholesky<__VA_ARGS__>::markChanged(Index);                            \
  template void IncrementalCholesky<__VA_ARGS__>::keepUnchangedStructures();                     \
  template void IncrementalCholesky<__VA_ARGS__>::markStructureChanged(Index);                   \
  template void IncrementalCholesky<__VA_ARGS__>::queue(Index);                                  \
  template Index IncrementalCholesky<__VA_ARGS__>::popSmallest();                                \
  template std::uint32_t IncrementalCholesky<__VA_ARGS__>::nextMark();                           \
  template Status IncrementalCholesky<__VA_ARGS__>::factorize(                                   \
      const InformationSource<__VA_ARGS__>&, const Index*, const Index*);                        \
  template Status IncrementalCholesky<__VA_ARGS__>::buildStructure(                              \
      Index, const InformationSource<__VA_ARGS__>&, const Index*, const Index*);                 \
  template Index IncrementalCholesky<__VA_ARGS__>::addChildrenFill(Index, std::uint32_t, Index*, \
                                                                   Index);                       \
  template Status IncrementalCholesky<__VA_ARGS__>::stageStructure(Index, Index*, Index);        \
  template bool IncrementalCholesky<__VA_ARGS__>::keepsStructure(Index);                         \
  template Status IncrementalCholesky<__VA_ARGS__>::stageOldStructure(Index);                    \
  template void IncrementalCholesky<__VA_ARGS__>::linkStagedChild(Index, Index);                 \
  template void IncrementalCholesky<__VA_ARGS__>::startColumn(                                   \
      Index, const InformationSource<__VA_ARGS__>&, const Index*, const Index*);                 \
  template void IncrementalCholesky<__VA_ARGS__>::assembleAllColumns(                            \
      const InformationSource<__VA_ARGS__>&, const Index*, const Index*);                        \
  template Status IncrementalCholesky<__VA_ARGS__>::finishColumn(Index);                         \
  template void IncrementalCholesky<__VA_ARGS__>::commit();                                      \
  template void IncrementalCholesky<__VA_ARGS__>::installStaged(Index);                          \
  template void IncrementalCholesky<__VA_ARGS__>::settleStagedColumns();                         \
  template typename IncrementalCholesky<__VA_ARGS__>::PoolEnd                                    \
  IncrementalCholesky<__VA_ARGS__>::packColumns(Index*, Index, Index*, const Index*, PoolEnd);   \
  template std::int64_t IncrementalCholesky<__VA_ARGS__>::inPlaceProducts();                     \
  template void IncrementalCholesky<__VA_ARGS__>::rollback();                                    \
  template void IncrementalCholesky<__VA_ARGS__>::linkChild(Index, Index);                       \
  template void IncrementalCholesky<__VA_ARGS__>::unlinkChild(Index, Index);                     \
  template void IncrementalCholesky<__VA_ARGS__>::rebuildChildLists();                           \
  template void IncrementalCholesky<__VA_ARGS__>::compact();                                     \
  template void IncrementalCholesky<__VA_ARGS__>::clear();                                       \
  template void IncrementalCholesky<__VA_ARGS__>::swap(IncrementalCholesky&);                    \
  template Status IncrementalCholesky<__VA_ARGS__>::startFactorization(                          \
      const InformationSource<__VA_ARGS__>&, const Index*, const Index*);                        \
  template Status IncrementalCholesky<__VA_ARGS__>::continueFactorization(std::int64_t, bool*);  \
  template Index IncrementalCholesky<__VA_ARGS__>::backSubstitute(Vector*, const Index*, double, \
                                                                  bool, Index*);                 \
  template void IncrementalCholesky<__VA_ARGS__>::scatterSlots(Index, Index, const Vector&,      \
                                                               double);                          \
  template bool IncrementalCholesky<__VA_ARGS__>::solveColumn(Index, double, Vector&);
LSLAM_INSTANTIATE_CORE(2)
LSLAM_INSTANTIATE_CORE(3)
LSLAM_INSTANTIATE_CORE(6)
LSLAM_INSTANTIATE_CORE(3, 2)
LSLAM_INSTANTIATE_CORE(6, 3)
#undef LSLAM_INSTANTIATE_CORE
template void IncrementalCholesky<2>::scatter(const Index*, const Block*, Index, const Vector&,
                                              double);
template void IncrementalCholesky<3>::scatter(const Index*, const Block*, Index, const Vector&,
                                              double);
template void IncrementalCholesky<6>::scatter(const Index*, const Block*, Index, const Vector&,
                                              double);

}  // namespace lslam
