#include "lslam/solver/ordering_policy.h"

#include <limits>

#include "lslam/assert.h"
#include "lslam/graph/factor_graph.h"
#include "lslam/linear/elimination_tree.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"

namespace lslam {

template <class Graph, class Factor>
void OrderingPolicy<Graph, Factor>::placeAddedVariablesLast() {
  for (Index v = factor_.columns(); v < graph_.variables(); ++v) {
    a_.variable_at[active_][v] = v;
    a_.position_of[active_][v] = v;
  }
}

// Reorder the whole graph (and refactorize every column) when the factor has grown well past what
// the last ordering produced, when the updates since have spent more extra work on that growth
// than the ordering's factorization cost (see reorder_excess_ratio), or when the last update had to
// walk a long elimination-tree path (a loop closure far back in the order).
template <class Graph, class Factor>
bool OrderingPolicy<Graph, Factor>::wantsReorder() const {
  // The update's poses are already in the staged graph.
  if (graph_.variables() < options_.reorder_min_variables) return false;
  if (blocks_at_last_order_ == 0) return true;
  if (excess_budget_ > 0 && excess_work_ > excess_budget_) return true;
  // Compared in double: a huge factor (a trigger switched off) must not overflow an Index.
  return static_cast<double>(factor_.liveBlocks()) >
             options_.reorder_growth * static_cast<double>(blocks_at_last_order_) ||
         (options_.reorder_path_columns > 0 &&
          last_columns_refactored_ > options_.reorder_path_columns);
}

// The work an update spent on the growth of the factor since the last ordering is estimated as its
// block products times that growth (an update's work scales with the structure of the columns it
// touches), summed and set against reorder_excess_ratio times the block products of the ordering's
// own factorization. Both are kept scaled by the factor's size at the ordering (products x blocks)
// in integers, the budget computed once per ordering: per update only an integer multiply-add and
// compare, whose cost does not depend on the values: a division, or a conversion of the sum to
// double in software, costs the Cortex-M more as the sum grows, and an odometry step's cost must
// not drift. A relinearization that waits for the next ordering (relinearize_defer_products) is
// charged its in-place estimate in full, once. The sum stops once past the budget (the trigger
// stays), so that it cannot overflow however long the ordering lasts.
template <class Graph, class Factor>
void OrderingPolicy<Graph, Factor>::noteFactorization(bool reordered, bool full,
                                                      const FactorizationStats& stats,
                                                      std::int64_t deferred_products) {
  last_columns_refactored_ = full ? 0 : stats.columns_recomputed;
  const std::int64_t block_products = stats.block_products;
  if (reordered) {
    blocks_at_last_order_ = factor_.liveBlocks();
    const double budget = options_.reorder_excess_ratio * static_cast<double>(block_products) *
                          static_cast<double>(blocks_at_last_order_);
    excess_budget_ = budget < 9e18 ? static_cast<std::int64_t>(budget)
                                   : std::numeric_limits<std::int64_t>::max();
    excess_work_ = 0;
    return;
  }
  if (excess_budget_ == 0 || excess_work_ > excess_budget_) return;
  const Index growth = factor_.liveBlocks() - blocks_at_last_order_;
  if (growth > 0) excess_work_ += block_products * growth;
  excess_work_ += deferred_products * blocks_at_last_order_;
}

template <class Graph, class Factor>
bool OrderingPolicy<Graph, Factor>::orderingFresh() const {
  return blocks_at_last_order_ > 0 &&
         static_cast<double>(factor_.liveBlocks()) <=
             options_.reorder_refresh_growth * static_cast<double>(blocks_at_last_order_);
}

// COLAMD on the factor-variable incidence of every variable except the newest committed one,
// which goes last, followed by the variables this update adds: the next odometry factor then
// touches only the last columns, so it stays constant-time after a reordering too. With nothing
// committed (a first update that reorders, or retries for room) the ordered variables are the
// update's own, its newest last.
template <class Graph, class Factor>
Status OrderingPolicy<Graph, Factor>::computeOrdering(Index* variable_at, Index* position_of) {
  const Index ordered = factor_.columns() > 0 ? factor_.columns() : graph_.variables();
  if (ordered == 0) return Status::Ok;  // an empty graph: nothing to order
  const Index last = ordered - 1;
  colamd_.begin();
  for (Index v = 0; v < last; ++v) {
    colamd_.startColumn();
    for (Index e = graph_.firstEntry(v); e != kNoIndex; e = graph_.nextEntry(e)) {
      if (!colamd_.addEntry(graph_.entryFactor(e))) return Status::WorkspaceExhausted;
    }
  }
  const Status s = colamd_.order(graph_.factors(), variable_at);
  if (s != Status::Ok) return s;
  // The columns given to COLAMD were the variables 0 .. last - 1 in order: its output is already
  // in variable numbers.
  for (Index v = last; v < graph_.variables(); ++v) variable_at[v] = v;
  for (Index k = 0; k < graph_.variables(); ++k) position_of[variable_at[k]] = k;
  // Postordered (same fill) so that the solve reads the per-column arrays in sequence.
  postorderEliminationOrder(ordered, variable_at, position_of, graph_, a_.parent_scratch,
                            a_.count_scratch);
  LSLAM_ASSERT(variable_at[last] == last);
  for (Index k = 0; k < ordered; ++k) position_of[variable_at[k]] = k;
  return Status::Ok;
}

template <class Graph, class Factor>
bool OrderingPolicy<Graph, Factor>::preparesOrderingAhead(std::int64_t full_products) const {
  return options_.prepare_ordering_ahead && full_products >= options_.prepare_ordering_min_products;
}

// Without ordering workspace nothing is prepared, and the next update asks again.
template <class Graph, class Factor>
bool OrderingPolicy<Graph, Factor>::prepareOrdering() {
  const int o = other();
  ordering_prepared_ = computeOrdering(a_.variable_at[o], a_.position_of[o]) == Status::Ok;
  prepared_variables_ = graph_.variables();
  return ordering_prepared_;
}

// The variables added since the preparation follow in the order they came: the newest stays last.
template <class Graph, class Factor>
void OrderingPolicy<Graph, Factor>::takePreparedOrdering() {
  Index* variable_at = a_.variable_at[other()];
  Index* position_of = a_.position_of[other()];
  for (Index v = prepared_variables_; v < graph_.variables(); ++v) {
    variable_at[v] = v;
    position_of[v] = v;
  }
}

template <class Graph, class Factor>
void OrderingPolicy<Graph, Factor>::adoptOrder(const Index* variable_at, const Index* position_of) {
  const int o = other();
  for (Index k = 0; k < graph_.variables(); ++k) {
    a_.variable_at[o][k] = variable_at[k];
    a_.position_of[o][k] = position_of[k];
  }
  ordering_prepared_ = false;
  active_ = o;
}

template <class Graph, class Factor>
bool OrderingPolicy<Graph, Factor>::computeFreshOrdering(bool* prepared_overwritten) {
  const int o = other();
  *prepared_overwritten = ordering_prepared_;
  return computeOrdering(a_.variable_at[o], a_.position_of[o]) == Status::Ok;
}

// Every model's graph and factor.
template class OrderingPolicy<FactorGraph<Slam2D>, IncrementalCholesky<3, 2>>;
template class OrderingPolicy<FactorGraph<Slam3D>, IncrementalCholesky<6, 3>>;
template class OrderingPolicy<FactorGraph<PoseSlam2D>, IncrementalCholesky<3>>;
template class OrderingPolicy<FactorGraph<PoseSlam3D>, IncrementalCholesky<6>>;

}  // namespace lslam
