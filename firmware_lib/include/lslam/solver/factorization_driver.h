#pragma once
// Drives the factor through one update (firmware_lib/README.md, One update, Update paths): which
// path the staged graph change takes (recomputed columns, row updates, a full refactorization, a
// reordered top), the compaction and the retry in a fresh ordering when the pool is full, the
// commit or rollback of the graph and the factor together, and the bookkeeping of the update's
// added factors and of the work its factorizations cost.
//
// A template over the graph and the factor, defined and instantiated for the solver's pairs in
// factorization_driver.cpp.
#include <cstdint>

#include "lslam/linear/incremental_cholesky.h"
#include "lslam/linear/index.h"
#include "lslam/solver/graph_adapter.h"
#include "lslam/solver/ordering_policy.h"
#include "lslam/solver/relinearization_policy.h"
#include "lslam/solver/solver_options.h"
#include "lslam/solver/update_result.h"
#include "lslam/status.h"

namespace lslam {

// What an update does besides adding its variables and factors (planUpdate, update_steps.h).
struct UpdatePlan {
  bool reorder_now = false;       // a full refactorization in a fresh (or the prepared) ordering
  bool prepare_ordering = false;  // COLAMD at the end of the update, for the next
  bool relinearize_now = false;   // the candidates were due (their points staged, or waiting)
  Index relinearized = 0;         // variables whose linearization points are staged
  bool refactor_fully = false;    // relinearize by a full refactorization in the current order
  bool fresh_ordering = false;    // reorder_now, in an ordering with this update's factors
  bool drop_anchor = false;       // the anchor leaves: every column refactorized, whatever else
  bool reorder_required = false;  // reorder_now asked by the caller: without an ordering it fails
  bool start_spread = false;      // the reordering is spread over the next updates instead
  bool spread_in_current_order = false;  // ...of a relinearization by a full refactorization
  bool abandon_spread = false;  // a spread reordering in progress ends (this one reorders now)
  // The due relinearization waits for the next reordering (relinearize_defer_products), and the
  // block products charged to that reordering's work budget once the update commits (its in-place
  // estimate the first time it waits, 0 after).
  bool relinearization_deferred = false;
  std::int64_t deferred_products = 0;
};

// The variables an update relinearizes (their points staged in the graph).
struct StagedVariables {
  const Index* list = nullptr;
  Index count = 0;
};

// Sizes: max_variables each. Two lists and a mark per position, used by one path of an update at
// a time, all zero between uses.
struct FactorizationArrays {
  Index* last_list = nullptr;       // the positions a reordered update keeps last; the row
                                    // update's seeding factors (see seedAddedColumns)
  std::uint8_t* in_last = nullptr;  // per position: already in last_list; an added column seeded
};

template <class Graph, class Factor>
class FactorizationDriver {
 public:
  using Ordering = OrderingPolicy<Graph, Factor>;

  FactorizationDriver(const FactorizationArrays& arrays, Graph& graph, Factor& factor,
                      const SolverOptions& options);

  // The graph's update has begun: the factors from here on are the update's.
  void beginStaging() {
    first_new_factor_ = graph_.factors();
    end_new_factor_ = kNoIndex;
  }
  Index firstNewFactor() const { return first_new_factor_; }
  // The factors of this update that reach back before the newest committed pose.
  Index addedLoopClosures(const Index* position_of) const;
  const FullRefactorizationCost& lastFull() const { return last_full_; }
  // The block products of recomputing in place, in `position_of`, the columns that adding
  // new_columns and relinearizing `relinearized` would change (nothing changes).
  std::int64_t inPlaceProducts(Index new_columns, const Index* position_of,
                               const StagedVariables& relinearized);

  // Factorizes the staged graph change (added poses at the end, `relinearized` staged), reordering
  // first if the plan says so (the prepared ordering, unless the plan wants a fresh one with this
  // update's factors); commits the graph and the factor, and activates the order they are in, or
  // rolls the graph back. positions_moved: the variables changed positions (a reordering).
  // Rotates the committed factors [first, end) into the factor, new_columns added columns last
  // (variable_at / position_of: the factor's order, those columns included): an update of the
  // factor alone, committed, or rolled back on failure. A spread reordering's catching up.
  [[nodiscard]] Status addCommittedFactors(Index first, Index end, Index new_columns,
                                           const Index* variable_at, const Index* position_of);
  // The last full refactorization, when one was done elsewhere (a spread reordering): its block
  // products and the blocks of the factor it made.
  void noteFullRefactorization(std::int64_t products, Index blocks) {
    last_full_.products = products;
    last_full_.blocks = blocks;
  }

  [[nodiscard]] Status refactor(Ordering& ordering, const UpdatePlan& plan,
                                const StagedVariables& relinearized, Index new_poses,
                                bool allow_reorder, bool* positions_moved, UpdateResult& result);

 private:
  Status factorizeWithRetry(Ordering& ordering, bool full, bool allow_top_reorder,
                            Index new_columns, const Index* variable_at, const Index* position_of,
                            const StagedVariables& relinearized, bool* top_reordered,
                            UpdateResult& result);
  Status factorizeOnce(Ordering& ordering, bool full, bool allow_top_reorder, Index new_columns,
                       const Index* variable_at, const Index* position_of,
                       const StagedVariables& relinearized, bool* top_reordered);
  bool likelyOutOfPool(bool full, Index relinearized, const Index* position_of) const;
  Index collectLastColumns(const Index* position_of, Index new_columns);
  void markAffectedColumns(const Index* position_of, const StagedVariables& relinearized);
  bool reachesBack(const Index* position_of) const;
  // Calls visit(column) for the column of each variable of this update's factors, in `position_of`
  // (a column once per factor that holds it).
  template <class Visit>
  void visitAddedFactorColumns(const Index* position_of, Visit visit) const {
    for (Index f = first_new_factor_; f < newFactorsEnd(); ++f) {
      visit(position_of[graph_.firstVariable(f)]);
      const Index second = graph_.secondVariable(f);
      if (second != kNoIndex) visit(position_of[second]);
    }
  }
  bool factorReachesBack(Index f, const Index* position_of) const;
  Index newFactorsEnd() const {
    return end_new_factor_ == kNoIndex ? graph_.factors() : end_new_factor_;
  }
  [[nodiscard]] Status addRowsOfAddedFactors(const Index* position_of, Index new_columns);
  [[nodiscard]] Status rowUpdateAndCommit(const Index* position_of, Index new_columns);
  [[nodiscard]] Status seedAddedColumns(const Index* position_of, Index* num_seeds);
  bool seedsColumns(Index f, const Index* position_of);
  [[nodiscard]] Status addRowsAlone(Index f, const Index* position_of);

  FactorizationArrays a_;
  Graph& graph_;
  Factor& factor_;
  const SolverOptions& options_;
  Index first_new_factor_ = 0;
  Index end_new_factor_ = kNoIndex;  // kNoIndex: the graph's factors end the update's
  FullRefactorizationCost last_full_;
  Index largest_staging_ = 0;  // the most pool blocks an update other than a full one staged
};

}  // namespace lslam
