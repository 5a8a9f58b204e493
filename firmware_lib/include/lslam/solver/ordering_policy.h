#pragma once
// The elimination order of the solver and when to replace it (firmware_lib/README.md, Ordering):
// the two order buffers (a reordering is staged in the inactive one), the triggers of a
// reordering and their work budget, and the COLAMD ordering prepared one update ahead.
//
// A template over the graph and the factor (the FactorGraph of a model with the factor of the
// model's block sizes), defined and instantiated for every model in ordering_policy.cpp.
#include <cstdint>

#include "lslam/linear/colamd_ordering.h"
#include "lslam/linear/incremental_cholesky.h"
#include "lslam/linear/index.h"
#include "lslam/solver/solver_options.h"
#include "lslam/status.h"

namespace lslam {

// Sizes: max_variables each.
struct OrderingArrays {
  Index* position_of[2] = {nullptr, nullptr};  // double-buffered: a reordering is staged
  Index* variable_at[2] = {nullptr, nullptr};
  Index* parent_scratch = nullptr;  // the postorder of a computed ordering
  Index* count_scratch = nullptr;
};

template <class Graph, class Factor>
class OrderingPolicy {
 public:
  OrderingPolicy(const OrderingArrays& arrays, const ColamdArrays& colamd, const Graph& graph,
                 const Factor& factor, const SolverOptions& options)
      : a_(arrays), colamd_(colamd), graph_(graph), factor_(factor), options_(options) {}

  // The order in use: position_of[variable], variable_at[position].
  const Index* positionOf() const { return a_.position_of[active_]; }
  const Index* variableAt() const { return a_.variable_at[active_]; }
  // The buffers by number: active() holds the order in use, other() a staged one.
  int active() const { return active_; }
  int other() const { return 1 - active_; }
  const Index* positionOf(int buffer) const { return a_.position_of[buffer]; }
  const Index* variableAt(int buffer) const { return a_.variable_at[buffer]; }
  Index* otherPositionOf() { return a_.position_of[other()]; }
  Index* otherVariableAt() { return a_.variable_at[other()]; }
  // The committed update ran in `buffer`'s order.
  void activate(int buffer) { active_ = buffer; }
  // The COLAMD workspace, also lent to the factor's reordered update of the affected top.
  ColamdOrdering& colamd() { return colamd_; }

  // The variables the update adds take the last positions of the active order. Once per update,
  // before anything reads their positions.
  void placeAddedVariablesLast();
  // The triggers of a reordering that an update's size and the factor's growth fire.
  bool wantsReorder() const;
  // The burst rule: more loop closures than reorder_burst_loop_closures reorder at once, in an
  // ordering with them in it. count_loop_closures() is called only for an update with that many
  // factors.
  template <class CountLoopClosures>
  bool wantsFreshOrdering(Index added_factors, CountLoopClosures count_loop_closures) const {
    const Index burst = options_.reorder_burst_loop_closures;
    return burst > 0 && added_factors > burst &&
           graph_.variables() >= options_.reorder_min_variables && count_loop_closures() > burst;
  }
  // The live blocks right after the last reordering (0 before the first).
  Index blocksAtLastOrder() const { return blocks_at_last_order_; }
  // The factor has grown little since the last ordering (reorder_refresh_growth).
  bool orderingFresh() const;
  // After a committed factorization (see the work budget in the source); deferred_products: the
  // in-place estimate of a relinearization that waits for the next reordering, charged in full.
  void noteFactorization(bool reordered, bool full, const FactorizationStats& stats,
                         std::int64_t deferred_products);

  // Whether a reordering is split over two updates, given the block products of the last full
  // refactorization.
  bool preparesOrderingAhead(std::int64_t full_products) const;
  // The ordering of every committed variable, into the inactive buffer, for the next update.
  bool prepareOrdering();
  bool prepared() const { return ordering_prepared_; }
  // The prepared ordering (in the inactive buffer) extended by the variables added since.
  void takePreparedOrdering();
  // A fresh ordering of the staged graph into the inactive buffer; false without workspace.
  // `prepared_overwritten` tells whether it wrote over a prepared ordering.
  bool computeFreshOrdering(bool* prepared_overwritten);
  // The prepared ordering was applied or overwritten.
  void forgetPrepared() { ordering_prepared_ = false; }
  // An order of every variable built elsewhere (a spread reordering) becomes the active one.
  void adoptOrder(const Index* variable_at, const Index* position_of);

 private:
  Status computeOrdering(Index* variable_at, Index* position_of);

  OrderingArrays a_;
  ColamdOrdering colamd_;
  const Graph& graph_;
  const Factor& factor_;
  const SolverOptions& options_;
  int active_ = 0;
  Index blocks_at_last_order_ = 0;
  Index last_columns_refactored_ = 0;
  // Work spent on the factor's growth since the last ordering, and the budget for it (both
  // products x blocks; 0: no budget). See noteFactorization.
  std::int64_t excess_work_ = 0;
  std::int64_t excess_budget_ = 0;
  // The inactive order buffer holds a COLAMD ordering of the first `prepared_variables_`
  // variables, prepared by an earlier update for the next one (see prepare_ordering_ahead).
  bool ordering_prepared_ = false;
  Index prepared_variables_ = 0;
};

}  // namespace lslam
