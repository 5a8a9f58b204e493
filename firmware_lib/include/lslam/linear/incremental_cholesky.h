#pragma once
// Block Cholesky factor L of Lambda (= L L^T) kept up to date one update at a time (the L-SLAM
// update of the seed, eqs. 9-13), in storage that is fixed when the object is built.
//
// What an update recomputes. Column k of L depends only on column k of Lambda and on the columns in
// its row subtree (the columns j < k with L(k, j) != 0, all descendants of k in the elimination
// tree). When Lambda changes in a set S of columns, the columns of L that change are exactly the
// ancestors of S in the (updated) elimination tree, A: the paths from S to the root. Every other
// column is bit-for-bit unchanged. With the newest variable last, an odometry step touches the last
// two columns: constant work.
//
// How it recomputes them. Write C(:,k) = L(:,k) L(k,k)^T = Lambda(:,k) - sum_{j<k} L(:,j) L(k,j)^T,
// the column before its pivot. Columns j outside A contribute the same before and after, so
//   C_new(:,k) = C_old(:,k) + dLambda(:,k) + sum_{j in A, j<k} (L_old(:,j) L_old(k,j)^T
//                                                             - L_new(:,j) L_new(k,j)^T),
// and the same for e = L(k,k) d(k) with eta. The update is therefore right-looking over A only:
// each column of A starts from its old C (rebuilt from the old L, still in the pool, and the stored
// diagonal factor), takes the change of Lambda, and once factorized sends its updated contribution
// minus its old one to the columns of its structure, all of which are in A. The work is that of
// factorizing A's columns alone (iSAM2's "top of the Bayes tree"), not their whole row subtrees.
// A full refactorization (after a reordering) is the same loop with C started from Lambda.
// Rounding of the old-C reconstruction accumulates slowly; every reordering starts afresh.
//
// Copy on write. Recomputed columns are staged in the free tail of the block pool; commit()
// installs them, rollback() forgets them. A failed update (pool full, a non-positive pivot)
// therefore leaves the factor bit-for-bit as it was. At commit, a column whose structure did not
// grow is copied back over its old blocks and the others are packed where the staging began (see
// settleStagedColumns), so only the old versions of grown columns become garbage, which
// compact() squeezes out.
// After a full refactorization the live columns are rewritten to the front of the pool in the
// order the back-substitution visits them (see layoutForSolve), by the next update or compaction
// (until then the solve reads them in column order), and the copy-back then keeps that layout.
//
// Storage of a column k: its first block is the *inverse* of the diagonal block, L(k,k)^-1, because
// every later use (forward and back substitution) needs the inverse; then the blocks L(r, k) for
// the rows r > k of its structure, rows ascending. The first of those rows is k's parent in the
// elimination tree.
//
// Block sizes (block_sizes.h). With one size D, the pool is an array of D x D blocks. With mixed
// sizes, column k is as wide as its variable and block (r, k) is size(r) x size(k): the pool is an
// array of doubles, each block slot has its offset there and its row size (the size of slot 0 is
// the column's own), and a column's values are one contiguous range (its slots may point into it
// in any order). Per-column arrays (d, the diagonal, the solution) hold the largest size, a
// column using its top-left part. The supernode and AVX2 kernels are for one block size only; the
// row update works at mixed sizes too, on fixed-size Eigen blocks.
#include <cstddef>
#include <cstdint>

#include "lslam/eigen.h"
#include "lslam/linear/block_kernels.h"
#include "lslam/linear/block_sizes.h"
#include "lslam/linear/colamd_ordering.h"
#include "lslam/linear/index.h"
#include "lslam/linear/information_source.h"
#include "lslam/status.h"

namespace lslam {

// The most added factors the row update rotates together in one pass (addFactorRows over a list).
// Each takes an update-row array of max_columns blocks: more memory against fewer passes over the
// path that a step's loop closures share.
inline constexpr int kMaxJointFactors = 3;
// At mixed block sizes two: their portable kernels (the Cortex-M7's too) take more instructions
// for three factors together than for a pair and a single, and the host gains nothing.
template <int... S>
inline constexpr int kJointFactorsOf = BlockSizes<S...>::kUniform ? kMaxJointFactors : 2;

// The arrays an IncrementalCholesky works in, owned by whoever holds the memory (see
// StaticCholeskyStorage). Sizes: pool arrays max_blocks; column arrays max_columns; the etree
// child lists max_columns + 1 (the last entry is a virtual root above every tree of the forest).
template <int... S>
struct CholeskyArrays {
  static constexpr int D = BlockSizes<S...>::kMax;
  static constexpr int kJointFactors = kJointFactorsOf<S...>;
  using Block = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;

  Index max_columns = 0;
  Index max_blocks = 0;
  Index* rows = nullptr;
  Block* blocks = nullptr;
  Index* start = nullptr;
  Index* count = nullptr;
  Block* diagonal = nullptr;  // L(k,k) per column (the pool holds its inverse)
  Block* staged_diagonal = nullptr;
  Vector* d = nullptr;
  std::uint8_t* needs_solve = nullptr;
  Index* first_child = nullptr;
  Index* next_sibling = nullptr;
  Index* prev_sibling = nullptr;
  Index* staged_start = nullptr;
  Index* staged_count = nullptr;
  Vector* staged_d = nullptr;
  std::uint32_t* queued = nullptr;
  std::uint32_t* mark = nullptr;
  Index* slot = nullptr;
  Index* heap = nullptr;
  Index* affected = nullptr;
  Index* child_head = nullptr;
  Index* child_next = nullptr;
  Index* row_list = nullptr;  // also: the row update's block sources (see mergeRows)
  // Mixed block sizes only (one size: unused, blocks holds the pool). values: max_values doubles;
  // offset and row_size: per pool slot; variable_kind: the caller's kind of each variable (an
  // index into the size list), read when a column's structure is built.
  Index max_values = 0;
  double* values = nullptr;
  Index* offset = nullptr;
  std::uint8_t* row_size = nullptr;
  const std::uint8_t* variable_kind = nullptr;
  Index* scratch = nullptr;
  // The reordered update (see factorizeReordered): old position -> reordered position, the affected
  // columns in their fresh order, each affected column's rank in the affected set, and the cliques
  // (old affected columns) that hold each affected variable, as compressed lists.
  Index* new_position = nullptr;  // max_columns
  Index* top_order = nullptr;     // max_columns; also: the rows of two factors' shared path
  Index* rank_of = nullptr;       // max_columns
  Index* clique_start = nullptr;  // max_columns + 1
  Index* clique_entry = nullptr;  // max_blocks
  // The row update (see addFactorRows): the update rows' block at each column position, one array
  // for each of the factors rotated together (the first also for a factor taken alone).
  Block* update_rows[kJointFactors] = {};  // max_columns each
  // The back-substitution's solution by column position, detail::kSolutionStride<D> doubles per
  // column (padding zero): max_columns * detail::kSolutionStride<D>.
  double* solution = nullptr;
};

// What one update did, for diagnostics.
struct FactorizationStats {
  Index columns_recomputed = 0;     // |ancestors of the changed columns|
  Index blocks_written = 0;         // blocks of those columns
  std::int64_t block_products = 0;  // D x D block products of the column updates
};

template <int... S>
class IncrementalCholesky {
 public:
  using Sizes = BlockSizes<S...>;
  static constexpr int D = Sizes::kMax;  // the largest block size
  static constexpr bool kUniform = Sizes::kUniform;
  static constexpr int kJointFactors = kJointFactorsOf<S...>;
  using Block = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;

  explicit IncrementalCholesky(const CholeskyArrays<S...>& arrays);

  Index columns() const { return n_; }
  Index maxColumns() const { return a_.max_columns; }
  Index liveBlocks() const { return live_blocks_; }
  Index poolEnd() const { return pool_end_; }
  Index poolCapacity() const { return a_.max_blocks; }
  Index valuesEnd() const { return value_end_; }  // mixed sizes: doubles of the pool in use
  // A full refactorization's columns wait for their layout (done by the next beginUpdate() or
  // compact()); the solve meanwhile reads them in column order.
  bool layoutPending() const { return layout_pending_; }

  // --- one update: begin, mark changed columns, factorize, then commit or roll back ---
  // Adds `new_columns` columns at the end. With full_refactor every column is recomputed from
  // scratch (after a reordering: old columns are then ignored). Mixed sizes: a row update reads
  // the added columns' sizes through variable_at (the order of the update; factorize() is given
  // it anyway).
  void beginUpdate(Index new_columns, bool full_refactor, const Index* variable_at = nullptr);
  // Column `column` of Lambda (or of eta) changed in this update.
  void markChanged(Index column);
  // For a full refactorization in the order of the live factor (after beginUpdate(.., true)):
  // every column keeps its structure, without the symbolic pass, unless it or a column in its
  // subtree was marked by markStructureChanged() (a factor added in this update: relinearized
  // factors change values, not structure). Structures only grow, so the others are exactly what
  // the symbolic pass would give.
  void keepUnchangedStructures();
  void markStructureChanged(Index column);
  // Recomputes every column on the etree paths from the changed ones to the root, and their part
  // of d (L d = eta). variable_at[k] is the variable at column k, position_of its inverse.
  [[nodiscard]] Status factorize(const InformationSource<S...>& source, const Index* variable_at,
                                 const Index* position_of);
  // factorize() in two phases, so that the numeric one can be spread over several calls (a
  // reordered factor built beside the live one, see SpreadReordering): the symbolic phase and the
  // assembly of Lambda (the only reads of `source`), then the columns in order, a column (or a
  // supernode) at a time, until max_products block products are spent or every column is done
  // (*finished). The update stays open in between; commit() or rollback() ends it.
  [[nodiscard]] Status startFactorization(const InformationSource<S...>& source,
                                          const Index* variable_at, const Index* position_of);
  [[nodiscard]] Status continueFactorization(std::int64_t max_products, bool* finished);
  void commit();
  void rollback();
  // What factorize() would cost for the columns marked so far: the block products of recomputing
  // them and their etree ancestors in place, about count^2 per column (its updated contribution and
  // its old one), from the current structures (which can only grow, so a lower bound). For
  // choosing, before either starts, between that and a full refactorization.
  std::int64_t inPlaceProducts();

  // --- a reordered update (iSAM2's re-elimination of the top of the tree) ---
  // Instead of factorize(): the affected set A (the changed columns, their etree ancestors, and the
  // added columns) is upward closed, so its Schur complement is exactly L_old(A,A) L_old(A,A)^T and
  // no column outside A changes numerically. A is therefore reordered with COLAMD on the cliques of
  // its old columns, keeping `last` (current positions, in that order: the variables of the added
  // factors, the newest last) at the end, moved behind every other column, and refactorized from
  // its Schur complement plus the change of Lambda. Columns outside A keep their values and
  // relative order; their positions shift down. variable_at is the current order (added columns
  // included); the fresh order goes to new_variable_at / new_position_of.
  // Returns WorkspaceExhausted when the ordering workspace is too small (nothing changed: roll
  // back and take the plain update).
  Index affectedTopSize();
  [[nodiscard]] Status factorizeReordered(const InformationSource<S...>& source,
                                          ColamdOrdering& ordering, const Index* last,
                                          Index num_last, const Index* variable_at,
                                          Index* new_variable_at, Index* new_position_of);
  const FactorizationStats& lastStats() const { return stats_; }

  // --- a row update (a multiple-rank update of L, for factors added without relinearization) ---
  // Instead of markChanged() + factorize(): when Lambda and eta change only by added factors, each
  // added factor is whitened rows [A b] with Lambda += A^T A and eta += A^T b, and L is updated by
  // orthogonal transformations of [L(:,k) A^T] column by column along the updated etree path of
  // the factor's first column (Householder reflections; no old-column reconstruction, no
  // subtraction of old contributions). A column of structure s costs O(s) block products here
  // against O(s^2) in factorize(), which is what makes loop closures into a dense top cheap.
  // The rows of one factor: `count` column positions (ascending not required) and, for each, the
  // D x D block A_r^T (D rows of the factor, so a rank-D update), and the whitened right-hand side
  // b. Mixed sizes: block r holds size(r) x m (a factor of m <= D error rows) in its top-left
  // corner and zeros elsewhere, b its m entries and zeros. Added columns start empty; every one
  // must receive rows before finishRowUpdate().
  struct FactorRows {
    const Index* positions;
    const Block* rows_transposed;
    Index count;
    Vector rhs;
  };
  [[nodiscard]] Status addFactorRows(const FactorRows& factor);
  // Up to kJointFactors factors at once, the same result up to rounding: each is rotated alone
  // until its path meets another's; from the column where they meet, together, in one pass (a
  // rank-mD update for m factors), so that the shared path's columns are read, reflected and
  // staged once, not once per factor.
  [[nodiscard]] Status addFactorRows(const FactorRows* const* factors, int count);
  [[nodiscard]] Status addFactorRows(const FactorRows& first, const FactorRows& second);
  // Ends the row updates of this update: NotPositiveDefinite if an added column received none;
  // else, at one block size, writes each rotated column's L(k,k)^-1 (once, however often the
  // column was rotated; mixed sizes write it at every rotation).
  [[nodiscard]] Status finishRowUpdate();

  // Moves the live columns to the front of the pool (no update may be in progress).
  void compact();
  // Forgets every column: the factor of an empty problem (no update may be in progress).
  void clear();
  // Exchanges the two factors' columns, storage and state (neither in an update).
  void swap(IncrementalCholesky& other);

  // Solves L^T x = d for the variables' x = delta[variable_at[k]], from the root down. Partial
  // (full == false): a subtree is entered only when its parent's x, or any x its column refers
  // to, changed by more than `tolerance` (max-norm), or when it holds columns factorized since the
  // last solve. Writes the visited columns to `visited` (capacity columns()); returns their count.
  // The solve reads and compares with its own copy of x by column position (one index per row
  // block instead of two dependent loads), which it writes to delta as it goes; whoever changes
  // delta in between says so with setSolution() or loadSolution().
  Index backSubstitute(Vector* delta, const Index* variable_at, double tolerance, bool full,
                       Index* visited);
  // x(k) := x, for a committed column (a variable relinearized or added: its delta restarts).
  void setSolution(Index k, const Vector& x) {
    LSLAM_ASSERT(k >= 0 && k < n_);
    solutionEntry(k) = x;
  }
  // x(k) := delta[variable_at[k]] for every committed column: after a reordering (a full one or
  // of the affected top), which moves the variables' positions.
  void loadSolution(const Vector* delta, const Index* variable_at);

  // Read access to a committed column: rows[0] == k, blocks[0] == L(k,k)^-1.
  Index columnSize(Index k) const { return a_.count[k]; }
  const Index* columnRows(Index k) const { return a_.rows + a_.start[k]; }
  const Block* columnBlocks(Index k) const {
    static_assert(kUniform, "mixed sizes: read blocks with blockValues()");
    return a_.blocks + a_.start[k];
  }
  // The width of column k (its variable's size) and, for mixed sizes, block i of column k as
  // size(row i) x width doubles, column-major.
  int columnWidth(Index k) const { return slotSize(a_.start[k]); }
  const double* blockValues(Index k, Index i) const { return slotValues(a_.start[k] + i); }
  Index parent(Index k) const { return a_.count[k] > 1 ? a_.rows[a_.start[k] + 1] : kNoIndex; }
  const Vector& rhs(Index k) const { return a_.d[k]; }
  // The solve's copy of x(k) (see backSubstitute).
  Vector solutionAt(Index k) const { return solutionEntry(k); }

 private:
  // The row size of a pool slot and its values (see "Block sizes" above).
  int slotSize(Index slot) const {
    if constexpr (kUniform) {
      static_cast<void>(slot);
      return D;
    } else {
      return a_.row_size[slot];
    }
  }
  double* slotValues(Index slot) {
    if constexpr (kUniform) {
      return a_.blocks[slot].data();
    } else {
      return a_.values + a_.offset[slot];
    }
  }
  const double* slotValues(Index slot) const {
    if constexpr (kUniform) {
      return a_.blocks[slot].data();
    } else {
      return a_.values + a_.offset[slot];
    }
  }
  // The size of the variable at column position k of the order the update stages.
  int positionSize(Index k) const {
    if constexpr (kUniform) {
      static_cast<void>(k);
      return D;
    } else {
      return Sizes::sizeOfKind(a_.variable_kind[staging_variable_at_[k]]);
    }
  }
  Index columnValues(Index start, Index count) const;
  void queue(Index column);
  Index popSmallest();
  [[nodiscard]] Status buildStructure(Index k, const InformationSource<S...>& source,
                                      const Index* variable_at, const Index* position_of);
  Index addChildrenFill(Index k, std::uint32_t id, Index* rows, Index count);
  [[nodiscard]] Status stageStructure(Index k, Index* rows, Index count);
  bool keepsStructure(Index k);
  [[nodiscard]] Status stageOldStructure(Index k);
  void linkStagedChild(Index k, Index parent);
  void startColumn(Index k, const InformationSource<S...>& source, const Index* variable_at,
                   const Index* position_of);
  void assembleAllColumns(const InformationSource<S...>& source, const Index* variable_at,
                          const Index* position_of);
  [[nodiscard]] Status finishColumn(Index k);
  void scatter(const Index* rows, const Block* blocks, Index size, const Vector& d, double sign);
  [[nodiscard]] Status factorizeSupernode(Index* next);
  Index supernodeEnd(Index i) const;
  void scatterWithinSupernode(Index column, Index last);
  void scatterFromSupernode(Index first, Index last);
  std::uint32_t nextMark();
  void linkChild(Index parent, Index child);
  void unlinkChild(Index parent, Index child);
  void rebuildChildLists();
  Index collectAffectedTop();
  void buildCliqueIndex();
  [[nodiscard]] Status orderAffectedTop(ColamdOrdering& ordering, const Index* last,
                                        Index num_last);
  [[nodiscard]] Status buildReorderedStructure(Index k, const InformationSource<S...>& source,
                                               const Index* new_variable_at,
                                               const Index* new_position_of);
  void addOldClique(Index j);
  void commitReordered();
  void installStaged(Index k);
  void settleStagedColumns();
  void layoutForSolve();
  Index solveInColumnOrder(Vector* delta, const Index* variable_at, Index* visited);
  // Column k's entry of the solution by position (the first D of its kSolutionStride doubles).
  Eigen::Map<Vector> solutionEntry(Index k) {
    return Eigen::Map<Vector>(a_.solution + detail::kSolutionStride<D> * k);
  }
  Eigen::Map<const Vector> solutionEntry(Index k) const {
    return Eigen::Map<const Vector>(a_.solution + detail::kSolutionStride<D> * k);
  }
  struct PoolEnd {
    Index blocks;
    Index values;
  };
  PoolEnd packColumns(Index* columns, Index num, Index* start, const Index* count, PoolEnd write);
  // Column k's update of the later columns (scatter) for either block layout, from its slots.
  void scatterSlots(Index start, Index count, const Vector& d, double sign);
  // x(k) of the back-substitution (detail::solveColumnInPlace for one size); whether it moved by
  // more than tolerance.
  bool solveColumn(Index k, double tolerance, Vector& delta);
  // --- mixed block sizes (incremental_cholesky_mixed.cpp) ---
  void startMixedColumn(Index k, const InformationSource<S...>& source, const Index* variable_at,
                        const Index* position_of);
  void assembleMixedColumn(Index k, const InformationSource<S...>& source, const Index* variable_at,
                           const Index* position_of, LaterDiagonals<S...>& later);
  [[nodiscard]] Status finishMixedColumn(Index k);
  void scatterMixed(Index start, Index count, const Vector& d, double sign);
  bool solveMixedColumn(Index k, double tolerance, Vector& delta);
  void addMembersOfOldClique(Index j, const Index* order);
  template <int R, int C>
  Eigen::Matrix<double, R, C> member(const Eigen::Matrix<double, C, C>& l_jj, Index start,
                                     Index i) const;
  // Moves the slots [from, from + count) of one column, with their values, to `write` (towards
  // the front); returns the end of the values written.
  Index moveColumn(Index from, Index count, PoolEnd write);
  // Copies the values of slots [from, from + count) over those of [to, to + count) (equal sizes).
  void copyColumnValues(Index from, Index count, Index to);
  void loadFactorRows(const FactorRows& factor, Index* pattern, Block* w);
  template <int M>
  [[nodiscard]] Status rotateToRoot(const Index* rest, Index rest_size, Block* const* w,
                                    Vector* rhs);
  template <int M>
  [[nodiscard]] Status rotateNextColumn(const Index*& rest, Index& rest_size, Block* const* w,
                                        Vector* rhs);
  // Factors rotated together from their rest[0] on (see addFactorRows over a list).
  struct RowGroup {
    const Index* rest;
    Index size;
    int count;
    Block* w[kJointFactors];
    Vector rhs[kJointFactors];
  };
  [[nodiscard]] Status rotateGroupColumn(RowGroup& group);
  void uniteGroups(RowGroup* const* groups, int count, Index* united);
  template <int M>
  [[nodiscard]] Status rowUpdateColumn(Index k, const Index* pattern, Index pattern_size,
                                       Block* const* w, Vector* rhs);
  template <int C, int M>
  [[nodiscard]] Status rowUpdateMixedColumn(Index k, const Index* pattern, Index pattern_size,
                                            Block* const* w, Vector* rhs);
  // Column k's latest version for the row update (staged, committed or none) and its recording.
  template <int C>
  struct LatestColumn {
    bool staged;
    Index start;
    Index size;
    Eigen::Matrix<double, C, C> l;
    Eigen::Matrix<double, C, 1> d;
  };
  template <int C>
  LatestColumn<C> latestColumn(Index k) const;
  template <int C>
  void stageRotatedColumn(Index k, bool staged, Index start, Index size,
                          const Eigen::Matrix<double, C, C>& l,
                          const Eigen::Matrix<double, C, 1>& d);
  template <int M>
  bool zeroUnreachedRows(const Index* rows, Index size, const Index* pattern, Index pattern_size,
                         Block* const* w);
  template <int M>
  Index mergeRows(Index k, const Index* old_rows, Index old_size, const Index* pattern,
                  Index pattern_size, bool zero_unreached, Block* const* w, Index* rows,
                  Index* source, Index* kept);

  CholeskyArrays<S...> a_;
  Index n_ = 0;
  Index value_end_ = 0;   // mixed sizes: the value pool's end, as pool_end_ for slots
  Index value_mark_ = 0;  // value_end_ when the update began
  const Index* staging_variable_at_ = nullptr;  // the order positionSize() reads
  Index staged_columns_ = 0;
  Index pool_end_ = 0;
  Index pool_mark_ = 0;
  Index live_blocks_ = 0;
  Index heap_size_ = 0;
  Index affected_count_ = 0;
  std::uint32_t stamp_ = 0;
  std::uint32_t mark_id_ = 0;
  bool full_ = false;
  bool keep_structures_ = false;  // full_ in the live order: see keepUnchangedStructures()
  bool reordered_ = false;
  bool by_supernodes_ = false;  // the numeric phase runs by supernodes (see factorizeSupernode)
  Index next_affected_ = 0;     // the numeric phase's next column, in `affected`
  Index top_size_ = 0;          // |A| of a reordered update
  Index top_base_ = 0;          // the first reordered position of A
  bool top_collected_ = false;  // affectedTopSize() has filled `affected` in this update
  bool in_update_ = false;
  bool layout_pending_ = false;        // a full refactorization's columns await layoutForSolve()
  std::uint32_t row_update_mark_ = 0;  // a_.mark of the columns a row update staged (0: none)
  FactorizationStats stats_;
};

// Memory for an IncrementalCholesky, all of it inside the object: no allocation anywhere.
// Sizes is a BlockSizes<...>. With one size, the pool is MaxBlocks blocks; with mixed sizes it is
// MaxValues doubles (plus an offset and a row size per slot), and variable_kind must be set on
// the arrays (the caller's kinds) before the factor is built.
template <class Sizes, Index MaxColumns, Index MaxBlocks, Index MaxValues = 0>
class StaticCholeskyStorageFor;

template <int... S, Index MaxColumns, Index MaxBlocks, Index MaxValues>
class StaticCholeskyStorageFor<BlockSizes<S...>, MaxColumns, MaxBlocks, MaxValues> {
 public:
  static constexpr int D = BlockSizes<S...>::kMax;
  static constexpr bool kUniform = BlockSizes<S...>::kUniform;
  static constexpr int kJointFactors = kJointFactorsOf<S...>;
  using Block = Eigen::Matrix<double, D, D>;
  using Vector = Eigen::Matrix<double, D, 1>;
  static_assert(MaxColumns > 0 && MaxBlocks >= MaxColumns, "capacities");
  static_assert(kUniform == (MaxValues == 0), "a value pool for mixed block sizes only");
  // Storage of one size for the arrays a size does not use (one element, never read).
  static constexpr Index kPoolBlocks = kUniform ? MaxBlocks : 1;
  static constexpr Index kMixedBlocks = kUniform ? 1 : MaxBlocks;

  CholeskyArrays<S...> arrays() {
    CholeskyArrays<S...> a;
    a.max_columns = MaxColumns;
    a.max_blocks = MaxBlocks;
    a.rows = rows_;
    a.blocks = kUniform ? blocks_ : nullptr;
    if constexpr (!kUniform) {
      a.max_values = MaxValues;
      a.values = values_;
      a.offset = offset_;
      a.row_size = row_size_;
    }
    a.start = start_;
    a.count = count_;
    a.diagonal = diagonal_;
    a.staged_diagonal = staged_diagonal_;
    a.d = d_;
    a.needs_solve = needs_solve_;
    a.first_child = first_child_;
    a.next_sibling = next_sibling_;
    a.prev_sibling = prev_sibling_;
    a.staged_start = staged_start_;
    a.staged_count = staged_count_;
    a.staged_d = staged_d_;
    a.queued = queued_;
    a.mark = mark_;
    a.slot = slot_;
    a.heap = heap_;
    a.affected = affected_;
    a.child_head = child_head_;
    a.child_next = child_next_;
    a.row_list = row_list_;
    a.scratch = scratch_;
    a.new_position = new_position_;
    a.top_order = top_order_;
    a.rank_of = rank_of_;
    a.clique_start = clique_start_;
    a.clique_entry = clique_entry_;
    for (int m = 0; m < kJointFactors; ++m) a.update_rows[m] = update_rows_[m];
    a.solution = solution_;
    return a;
  }

 private:
  Block blocks_[kPoolBlocks];
  double values_[kUniform ? 1 : MaxValues];
  Index offset_[kMixedBlocks];
  std::uint8_t row_size_[kMixedBlocks];
  Index rows_[MaxBlocks];
  Index start_[MaxColumns];
  Index count_[MaxColumns];
  Block diagonal_[MaxColumns];
  Block staged_diagonal_[MaxColumns];
  Vector d_[MaxColumns];
  std::uint8_t needs_solve_[MaxColumns];
  Index first_child_[MaxColumns + 1];
  Index next_sibling_[MaxColumns + 1];
  Index prev_sibling_[MaxColumns + 1];
  Index staged_start_[MaxColumns];
  Index staged_count_[MaxColumns];
  Vector staged_d_[MaxColumns];
  std::uint32_t queued_[MaxColumns];
  std::uint32_t mark_[MaxColumns];
  Index slot_[MaxColumns];
  Index heap_[MaxColumns];
  Index affected_[MaxColumns];
  Index child_head_[MaxColumns];
  Index child_next_[MaxColumns];
  Index row_list_[MaxColumns];
  Index scratch_[MaxColumns];
  Index new_position_[MaxColumns];
  Index top_order_[MaxColumns];
  Index rank_of_[MaxColumns];
  Index clique_start_[MaxColumns + 1];
  Index clique_entry_[MaxBlocks];
  Block update_rows_[kJointFactors][MaxColumns];
  alignas(32) double solution_[MaxColumns * detail::kSolutionStride<D>];
};

// One block size D: the storage of IncrementalCholesky<D>.
template <int D, Index MaxColumns, Index MaxBlocks>
using StaticCholeskyStorage = StaticCholeskyStorageFor<BlockSizes<D>, MaxColumns, MaxBlocks>;

// Block sizes <2>, <3>, <6>, <3, 2> and <6, 3> are compiled once each: every member defined out of
// the class is instantiated, member by member, in the source file that defines it
// (src/linear/incremental_cholesky*.cpp); the members defined in the class body are inline and
// instantiated where they are used. No `extern template class` here: with it, GCC at -O0 expects
// those inline members from an explicit instantiation of the whole class, which the sources do
// not make (see incremental_cholesky.cpp).

}  // namespace lslam
