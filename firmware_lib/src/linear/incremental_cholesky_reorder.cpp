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
template <int... S>
Index IncrementalCholesky<S...>::collectAffectedTop() {
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

template <int... S>
Index IncrementalCholesky<S...>::affectedTopSize() {
  LSLAM_ASSERT(in_update_ && !full_);
  top_size_ = collectAffectedTop();
  top_collected_ = true;
  return top_size_;
}

// For every variable of A (by rank), the old columns of A whose clique ({j} and its structure, all
// in A because A is closed upwards) holds it: the pattern of the Schur complement on A.
template <int... S>
void IncrementalCholesky<S...>::buildCliqueIndex() {
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
template <int... S>
Status IncrementalCholesky<S...>::orderAffectedTop(ColamdOrdering& ordering, const Index* last,
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
template <int... S>
Status IncrementalCholesky<S...>::buildReorderedStructure(Index k,
                                                          const InformationSource<S...>& source,
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
template <int... S>
void IncrementalCholesky<S...>::addOldClique(Index j) {
  const Index size = a_.count[j];
  const Index* rows = a_.rows + a_.start[j];
  Index* order = a_.heap;  // free: the queue was read by collectAffectedTop()
  for (Index i = 0; i < size; ++i) order[i] = i;
  const Index* new_position = a_.new_position;
  std::sort(order, order + size, [rows, new_position](Index x, Index y) {
    return new_position[rows[x]] < new_position[rows[y]];
  });
  addMembersOfOldClique(j, order);
}

template <int... S>
Status IncrementalCholesky<S...>::factorizeReordered(const InformationSource<S...>& source,
                                                     ColamdOrdering& ordering, const Index* last,
                                                     Index num_last, const Index* variable_at,
                                                     Index* new_variable_at,
                                                     Index* new_position_of) {
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
  staging_variable_at_ = new_variable_at;
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
    scatterSlots(a_.staged_start[k], a_.staged_count[k], a_.staged_d[k], -1.0);
  }
  stats_.columns_recomputed = top_size_;
  stats_.blocks_written = pool_end_ - pool_mark_;
  return Status::Ok;
}

// Installs a reordered update: the columns outside A move down to their reordered positions with
// their rows relabelled (the rows in A, always a suffix, re-sorted), and A's recomputed columns go
// on top.
template <int... S>
void IncrementalCholesky<S...>::commitReordered() {
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
    const Index size = a_.count[k];
    if (rows[size - 1] < lowest_moved) continue;  // no row of this column moved
    Index first_top = size;
    for (Index i = 0; i < size; ++i) {
      rows[i] = a_.new_position[rows[i]];
      if (rows[i] >= top_base_ && first_top == size) first_top = i;
    }
    // Insertion sort of the suffix in A (short), moving the blocks with their rows (mixed sizes:
    // their offsets and sizes; the values stay where they are, in the column's range).
    for (Index i = first_top + 1; i < size; ++i) {
      const Index row = rows[i];
      Index p = i;
      if constexpr (kUniform) {
        Block* blocks = a_.blocks + a_.start[k];
        const Block block = blocks[i];
        for (; p > first_top && rows[p - 1] > row; --p) {
          rows[p] = rows[p - 1];
          blocks[p] = blocks[p - 1];
        }
        blocks[p] = block;
      } else {
        Index* offset = a_.offset + a_.start[k];
        std::uint8_t* row_size = a_.row_size + a_.start[k];
        const Index block_offset = offset[i];
        const std::uint8_t block_size = row_size[i];
        for (; p > first_top && rows[p - 1] > row; --p) {
          rows[p] = rows[p - 1];
          offset[p] = offset[p - 1];
          row_size[p] = row_size[p - 1];
        }
        offset[p] = block_offset;
        row_size[p] = block_size;
      }
      rows[p] = row;
    }
  }
  for (Index k = top_base_; k < total; ++k) installStaged(k);
  n_ = total;
  rebuildChildLists();
  in_update_ = false;
}

// Every member defined here is instantiated here (only this file sees their definitions).
#define LSLAM_INSTANTIATE_REORDER(...)                                                           \
  template Index IncrementalCholesky<__VA_ARGS__>::collectAffectedTop();                         \
  template Index IncrementalCholesky<__VA_ARGS__>::affectedTopSize();                            \
  template void IncrementalCholesky<__VA_ARGS__>::buildCliqueIndex();                            \
  template Status IncrementalCholesky<__VA_ARGS__>::orderAffectedTop(ColamdOrdering&,            \
                                                                     const Index*, Index);       \
  template Status IncrementalCholesky<__VA_ARGS__>::buildReorderedStructure(                     \
      Index, const InformationSource<__VA_ARGS__>&, const Index*, const Index*);                 \
  template void IncrementalCholesky<__VA_ARGS__>::addOldClique(Index);                           \
  template Status IncrementalCholesky<__VA_ARGS__>::factorizeReordered(                          \
      const InformationSource<__VA_ARGS__>&, ColamdOrdering&, const Index*, Index, const Index*, \
      Index*, Index*);                                                                           \
  template void IncrementalCholesky<__VA_ARGS__>::commitReordered();
LSLAM_INSTANTIATE_REORDER(2)
LSLAM_INSTANTIATE_REORDER(3)
LSLAM_INSTANTIATE_REORDER(6)
LSLAM_INSTANTIATE_REORDER(3, 2)
LSLAM_INSTANTIATE_REORDER(6, 3)
#undef LSLAM_INSTANTIATE_REORDER

}  // namespace lslam
