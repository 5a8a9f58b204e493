// The reordered update of IncrementalCholesky: the affected top of the elimination tree is given a
// fresh COLAMD order (the variables of the added factors last) and refactorized from its Schur
// complement, as iSAM2 re-eliminates the top of its Bayes tree. See factorizeReordered() in the
// header for why nothing outside the affected set changes numerically.
//
// Why this matters: with a fixed ordering, a loop closure to an old pose walks the whole etree path
// from that pose's (deep) column to the root, through the largest cliques, and every later loop
// closure nearby walks it again. After a reordered update the loop's variables sit next to the
// root, so the next closures in the same place touch a short path.
#include <algorithm>
#include <cstring>

#include "lslam/linear/incremental_cholesky.h"
#include "rows_after_collector.h"

namespace lslam {

// A = the queued columns (changed and added) and all their ancestors in the current etree, sorted.
template <int D>
Index IncrementalCholesky<D>::collectAffectedTop() {
  const std::uint32_t id = nextMark();
  Index count = 0;
  for (Index h = 0; h < heap_size_; ++h) {
    Index k = a_.heap[h];
    while (k != kNoIndex && a_.mark[k] != id) {
      a_.mark[k] = id;
      a_.affected[count++] = k;
      k = k < n_ ? parent(k) : kNoIndex;
    }
  }
  std::sort(a_.affected, a_.affected + count);
  return count;
}

template <int D>
Index IncrementalCholesky<D>::affectedTopSize() {
  LSLAM_ASSERT(in_update_ && !full_);
  top_size_ = collectAffectedTop();
  top_collected_ = true;
  return top_size_;
}

// For every variable of A (by rank), the old columns of A whose clique ({j} and its structure, all
// in A because A is closed upwards) holds it: the pattern of the Schur complement on A.
template <int D>
void IncrementalCholesky<D>::buildCliqueIndex() {
  Index* start = a_.clique_start;
  for (Index r = 0; r <= top_size_; ++r) start[r] = 0;
  for (Index r = 0; r < top_size_; ++r) {
    const Index j = a_.affected[r];
    if (j >= n_) continue;  // an added column has no old clique
    const Index* rows = a_.rows + a_.start[j];
    for (Index i = 0; i < a_.count[j]; ++i) ++start[a_.rank_of[rows[i]] + 1];
  }
  for (Index r = 0; r < top_size_; ++r) start[r + 1] += start[r];
  Index* cursor = a_.scratch;
  for (Index r = 0; r < top_size_; ++r) cursor[r] = start[r];
  for (Index r = 0; r < top_size_; ++r) {
    const Index j = a_.affected[r];
    if (j >= n_) continue;
    const Index* rows = a_.rows + a_.start[j];
    for (Index i = 0; i < a_.count[j]; ++i) a_.clique_entry[cursor[a_.rank_of[rows[i]]]++] = r;
  }
}

// The fresh order of A in top_order (current positions): COLAMD on the cliques for the free
// variables, then `last` as given.
template <int D>
Status IncrementalCholesky<D>::orderAffectedTop(ColamdOrdering& ordering, const Index* last,
                                                Index num_last) {
  // affectedTopSize() has usually just collected A (the caller's policy asks for |A| first).
  if (!top_collected_) top_size_ = collectAffectedTop();
  for (Index r = 0; r < top_size_; ++r) a_.rank_of[a_.affected[r]] = r;
  buildCliqueIndex();
  const std::uint32_t last_id = nextMark();
  for (Index i = 0; i < num_last; ++i) {
    const Index c = last[i];
    LSLAM_ASSERT(c >= 0 && c < staged_columns_ && a_.rank_of[c] < top_size_ &&
                 a_.affected[a_.rank_of[c]] == c);
    a_.mark[c] = last_id;
  }
  Index* rank_of_local = a_.row_list;
  Index free = 0;
  ordering.begin();
  for (Index r = 0; r < top_size_; ++r) {
    if (a_.mark[a_.affected[r]] == last_id) continue;
    ordering.startColumn();
    rank_of_local[free++] = r;
    for (Index e = a_.clique_start[r]; e < a_.clique_start[r + 1]; ++e) {
      if (!ordering.addEntry(a_.clique_entry[e])) return Status::WorkspaceExhausted;
    }
  }
  if (free > 0) {
    const Status s = ordering.order(top_size_, a_.scratch);
    if (s != Status::Ok) return s;
  }
  for (Index i = 0; i < free; ++i) a_.top_order[i] = a_.affected[rank_of_local[a_.scratch[i]]];
  Index placed = free;
  for (Index i = 0; i < num_last; ++i) {
    if (a_.mark[last[i]] != last_id) continue;  // listed twice
    a_.mark[last[i]] = 0;
    a_.top_order[placed++] = last[i];
  }
  LSLAM_ASSERT(placed == top_size_);
  return Status::Ok;
}

// Structure of the reordered column k (reordered position): the members after k of every old clique
// holding its variable, its factor neighbours after k, and the fill of its children.
template <int D>
Status IncrementalCholesky<D>::buildReorderedStructure(Index k, const InformationSource<D>& source,
                                                       const Index* new_variable_at,
                                                       const Index* new_position_of) {
  const std::uint32_t id = nextMark();
  Index* rows = a_.scratch;
  Index count = 0;
  const Index r = a_.rank_of[a_.top_order[k - top_base_]];
  for (Index e = a_.clique_start[r]; e < a_.clique_start[r + 1]; ++e) {
    const Index j = a_.affected[a_.clique_entry[e]];
    const Index* members = a_.rows + a_.start[j];
    for (Index i = 0; i < a_.count[j]; ++i) {
      const Index p = a_.new_position[members[i]];
      if (p > k && a_.mark[p] != id) {
        a_.mark[p] = id;
        rows[count++] = p;
      }
    }
  }
  detail::RowsAfterCollector collector(new_position_of, k, a_.mark, id, rows + count);
  source.visitNeighbours(new_variable_at[k], collector);
  count += collector.count();
  count = addChildrenFill(k, id, rows, count);
  const Status s = stageStructure(k, rows, count);
  if (s == Status::Ok && count > 0) linkStagedChild(k, rows[0]);
  return s;
}

// Adds old column j's share of the Schur complement on A, L(:,j) L(:,j)^T and L(:,j) d(j), to the
// staged columns in the fresh order (its members sorted by reordered position, so each target is
// merged).
template <int D>
void IncrementalCholesky<D>::addOldClique(Index j) {
  const Index size = a_.count[j];
  const Index* rows = a_.rows + a_.start[j];
  const Block* blocks = a_.blocks + a_.start[j];
  Index* order = a_.heap;  // free: the queue was read by collectAffectedTop()
  for (Index i = 0; i < size; ++i) order[i] = i;
  const Index* new_position = a_.new_position;
  std::sort(order, order + size, [rows, new_position](Index x, Index y) {
    return new_position[rows[x]] < new_position[rows[y]];
  });
  // The pool holds L(j,j)^-1; the Schur complement needs L(j,j) itself.
  auto member = [&](Index i) -> const Block& { return i == 0 ? a_.diagonal[j] : blocks[i]; };
  const Vector& dj = a_.d[j];
  for (Index a = 0; a < size; ++a) {
    const Index ia = order[a];
    const Index target_column = new_position[rows[ia]];
    const Index* target_rows = a_.rows + a_.staged_start[target_column];
    Block* target = a_.blocks + a_.staged_start[target_column];
    const Block& m_a = member(ia);
    const Block m_a_t = m_a.transpose();
    a_.staged_d[target_column].noalias() += m_a * dj;
    target[0].noalias() += m_a * m_a_t;
    Index p = 1;
    for (Index b = a + 1; b < size; ++b) {
      const Index ib = order[b];
      const Index row = new_position[rows[ib]];
      while (target_rows[p] < row) ++p;
      LSLAM_DEBUG_ASSERT(p < a_.staged_count[target_column] && target_rows[p] == row);
      target[p].noalias() += member(ib) * m_a_t;
    }
  }
  stats_.block_products += static_cast<std::int64_t>(size) * (size + 1) / 2;
}

template <int D>
Status IncrementalCholesky<D>::factorizeReordered(const InformationSource<D>& source,
                                                  ColamdOrdering& ordering, const Index* last,
                                                  Index num_last, const Index* variable_at,
                                                  Index* new_variable_at, Index* new_position_of) {
  LSLAM_ASSERT(in_update_ && !full_);
  const Status ordered = orderAffectedTop(ordering, last, num_last);
  if (ordered != Status::Ok) return ordered;
  // Reordered positions: the columns outside A keep their relative order, A follows in its fresh
  // order.
  const Index total = staged_columns_;
  top_base_ = total - top_size_;
  Index next = 0;
  for (Index c = 0, r = 0; c < total; ++c) {
    if (r < top_size_ && a_.affected[r] == c) {
      ++r;
      continue;
    }
    a_.new_position[c] = next++;
  }
  LSLAM_ASSERT(next == top_base_);
  for (Index i = 0; i < top_size_; ++i) a_.new_position[a_.top_order[i]] = top_base_ + i;
  for (Index c = 0; c < total; ++c) {
    new_variable_at[a_.new_position[c]] = variable_at[c];
    new_position_of[variable_at[c]] = a_.new_position[c];
  }
  reordered_ = true;
  // Symbolic, in the fresh order.
  for (Index k = top_base_; k < total; ++k) a_.child_head[k] = kNoIndex;
  for (Index k = top_base_; k < total; ++k) {
    const Status s = buildReorderedStructure(k, source, new_variable_at, new_position_of);
    if (s != Status::Ok) return s;
  }
  // Numeric: the change of Lambda, then the old Schur complement, then right-looking over A.
  for (Index k = top_base_; k < total; ++k)
    startColumn(k, source, new_variable_at, new_position_of);
  for (Index r = 0; r < top_size_; ++r) {
    if (a_.affected[r] < n_) addOldClique(a_.affected[r]);
  }
  for (Index k = top_base_; k < total; ++k) {
    const Status s = finishColumn(k);
    if (s != Status::Ok) return s;
    scatter(a_.rows + a_.staged_start[k], a_.blocks + a_.staged_start[k], a_.staged_count[k],
            a_.staged_d[k], -1.0);
  }
  stats_.columns_recomputed = top_size_;
  stats_.blocks_written = pool_end_ - pool_mark_;
  return Status::Ok;
}

// Installs a reordered update: the columns outside A move down to their reordered positions with
// their rows relabelled (the rows in A, always a suffix, re-sorted), and A's recomputed columns go
// on top.
template <int D>
void IncrementalCholesky<D>::commitReordered() {
  const Index old_n = n_;
  const Index total = staged_columns_;
  for (Index r = 0; r < top_size_; ++r) {
    if (a_.affected[r] < old_n) live_blocks_ -= a_.count[a_.affected[r]];
  }
  // Ascending: a column only moves down, onto a slot already moved or left by a column of A.
  for (Index c = 0, r = 0; c < old_n; ++c) {
    if (r < top_size_ && a_.affected[r] == c) {
      ++r;
      continue;
    }
    const Index to = a_.new_position[c];
    if (to == c) continue;
    a_.start[to] = a_.start[c];
    a_.count[to] = a_.count[c];
    a_.d[to] = a_.d[c];
    a_.diagonal[to] = a_.diagonal[c];
    a_.needs_solve[to] = a_.needs_solve[c];
  }
  const Index lowest_moved = a_.affected[0];
  for (Index k = 0; k < top_base_; ++k) {
    Index* rows = a_.rows + a_.start[k];
    Block* blocks = a_.blocks + a_.start[k];
    const Index size = a_.count[k];
    if (rows[size - 1] < lowest_moved) continue;  // no row of this column moved
    Index first_top = size;
    for (Index i = 0; i < size; ++i) {
      rows[i] = a_.new_position[rows[i]];
      if (rows[i] >= top_base_ && first_top == size) first_top = i;
    }
    // Insertion sort of the suffix in A (short), moving the blocks with their rows.
    for (Index i = first_top + 1; i < size; ++i) {
      const Index row = rows[i];
      const Block block = blocks[i];
      Index p = i;
      for (; p > first_top && rows[p - 1] > row; --p) {
        rows[p] = rows[p - 1];
        blocks[p] = blocks[p - 1];
      }
      rows[p] = row;
      blocks[p] = block;
    }
  }
  for (Index k = top_base_; k < total; ++k) installStaged(k);
  n_ = total;
  rebuildChildLists();
  in_update_ = false;
}

// Every member defined here is instantiated here (only this file sees their definitions).
#define LSLAM_INSTANTIATE_REORDER(D)                                                               \
  template Index IncrementalCholesky<D>::collectAffectedTop();                                     \
  template Index IncrementalCholesky<D>::affectedTopSize();                                        \
  template void IncrementalCholesky<D>::buildCliqueIndex();                                        \
  template Status IncrementalCholesky<D>::orderAffectedTop(ColamdOrdering&, const Index*, Index);  \
  template Status IncrementalCholesky<D>::buildReorderedStructure(                                 \
      Index, const InformationSource<D>&, const Index*, const Index*);                             \
  template void IncrementalCholesky<D>::addOldClique(Index);                                       \
  template Status IncrementalCholesky<D>::factorizeReordered(const InformationSource<D>&,          \
                                                             ColamdOrdering&, const Index*, Index, \
                                                             const Index*, Index*, Index*);        \
  template void IncrementalCholesky<D>::commitReordered();
LSLAM_INSTANTIATE_REORDER(2)
LSLAM_INSTANTIATE_REORDER(3)
LSLAM_INSTANTIATE_REORDER(6)
#undef LSLAM_INSTANTIATE_REORDER

}  // namespace lslam
