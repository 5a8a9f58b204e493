#pragma once
// The steps of an update of Smoother<Model>: the plan of what an update does besides adding its
// inputs, and the factorization through the driver with the restart of the variables' solution.
// Templates over the smoother's parts.
#include "lslam/solver/factorization_driver.h"
#include "lslam/solver/ordering_policy.h"
#include "lslam/solver/relinearization_policy.h"

namespace lslam {
namespace detail {

// What an update does besides adding its variables and factors (their graph change is staged): a
// prepared ordering is applied now; a stale one is replaced now, or prepared at the end of this
// update and applied by the next (prepare_ordering_ahead). The candidates are relinearized when
// one is urgent, at a reordering, or every relinearize_skip updates; in place, or by a full
// refactorization when that is cheaper (relinearizationDear); one dearer than
// relinearize_defer_products both ways waits for the next reordering (defersRelinearization). An
// update that drops the anchor reorders now, a full refactorization: a factor cannot be taken out
// of L in place; so does one that the caller asks to (force_reorder).
// With a spread reordering (SpreadReordering): a reordering dearer than its bar starts one
// instead, and while one runs an update neither reorders nor relinearizes, unless it must reorder
// at once (the anchor leaves, a burst, the caller asks), which abandons it.
struct SpreadState {
  bool available = false;
  bool active = false;
  std::int64_t above_products = 0;  // SolverOptions::spread_reorder_products
};

template <class Graph, class Ordering, class Relinearization, class Driver, class Vector>
UpdatePlan planUpdate(Graph& graph, Ordering& ordering, Relinearization& relinearization,
                      Driver& driver, const Vector* delta, Index new_variables, bool drop_anchor,
                      bool force_reorder = false, const SpreadState& spread = SpreadState{}) {
  UpdatePlan plan;
  plan.drop_anchor = drop_anchor;
  plan.reorder_required = force_reorder;
  ordering.placeAddedVariablesLast();
  const Index* position_of = ordering.positionOf();
  plan.fresh_ordering = ordering.wantsFreshOrdering(graph.factors() - driver.firstNewFactor(), [&] {
    return driver.addedLoopClosures(position_of);
  });
  const bool prepared = ordering.prepared();
  const bool ordering_stale =
      force_reorder || prepared || plan.fresh_ordering || ordering.wantsReorder();
  plan.prepare_ordering = ordering_stale && !prepared && !plan.fresh_ordering && !drop_anchor &&
                          !force_reorder &&
                          ordering.preparesOrderingAhead(driver.lastFull().products);
  plan.reorder_now = (ordering_stale || drop_anchor) && !plan.prepare_ordering;
  const bool at_once = force_reorder || drop_anchor || plan.fresh_ordering;
  // A spread reordering in progress: the update only adds its inputs. The candidates wait for the
  // next reordering (a relinearization here would abandon the build, and on the maps that spread
  // one it costs about a refactorization: the worst step the spreading is for).
  if (spread.active && !at_once) {
    plan.reorder_now = false;
    plan.prepare_ordering = false;
    return plan;
  }
  plan.abandon_spread = spread.active;
  const auto startsSpread = [&] {
    return spread.available && !spread.active && !at_once && spread.above_products > 0 &&
           driver.lastFull().products > spread.above_products;
  };
  if (plan.reorder_now && prepared && startsSpread()) {
    plan.reorder_now = false;
    plan.start_spread = true;
    return plan;
  }
  plan.relinearize_now = relinearization.due(plan.reorder_now);
  // Outside a reordering only the candidates past the partial bar (see relinearize_partial_...).
  plan.relinearized = plan.relinearize_now ? relinearization.stageCandidates(
                                                 plan.reorder_now ? CandidateRange::PastThreshold
                                                                  : CandidateRange::PastPartial,
                                                 delta, 0)
                                           : 0;
  std::int64_t in_place = -1;  // estimated once, when a rule asks
  const auto in_place_products = [&] {
    if (in_place < 0) {
      in_place = driver.inPlaceProducts(
          new_variables, position_of, StagedVariables{relinearization.staged(), plan.relinearized});
    }
    return in_place;
  };
  // (The in-place estimate counts the update's own columns too: relinearizing turns a loop
  // closure's row update into the recomputation of its path.)
  if (!plan.reorder_now && relinearization.defersRelinearization(
                               plan.relinearized, driver.lastFull(), in_place_products)) {
    // Too dear either way (relinearize_defer_products): the candidates wait for the reordering
    // that the charge of their first wait brings closer.
    graph.unstageRelinearization();
    plan.relinearization_deferred = true;
    plan.deferred_products = relinearization.deferralCharged() ? 0 : in_place;
    plan.relinearized = 0;
    plan.relinearize_now = false;
  }
  plan.refactor_fully =
      !plan.reorder_now &&
      relinearization.relinearizationDear(plan.relinearized, driver.lastFull(), in_place_products);
  if (plan.refactor_fully && !ordering.orderingFresh() &&
      ordering.preparesOrderingAhead(driver.lastFull().products)) {
    // A full refactorization in a stale ordering is nearly the price of a reordering: this update
    // only adds its factors, and the next one reorders and relinearizes (the candidates wait).
    graph.unstageRelinearization();
    plan.relinearized = 0;
    plan.relinearize_now = false;
    plan.refactor_fully = false;
    plan.prepare_ordering = true;  // (a prepared ordering would have been applied: not stale)
  } else if (plan.refactor_fully && relinearization.partialLeavesWaiting()) {
    // Every column is refactorized anyway: the waiting candidates come along for their
    // linearization alone.
    plan.relinearized =
        relinearization.stageCandidates(CandidateRange::LeftWaiting, delta, plan.relinearized);
  }
  if (plan.refactor_fully && startsSpread()) {
    // A relinearization by a full refactorization costs what a reordering does: spread it too, in
    // the current order.
    graph.unstageRelinearization();
    plan.relinearized = 0;
    plan.relinearize_now = false;
    plan.refactor_fully = false;
    plan.prepare_ordering = false;  // (the spread's swap does not count as a reordering)
    plan.start_spread = true;
    plan.spread_in_current_order = true;
  }
  return plan;
}

// The driver commits the factor and the graph; the relinearized and the added variables then
// restart from delta = 0. The factor's copy of the solution (by position) follows them, or is
// reloaded whole after a reordering moved the variables.
template <class Factor, class Ordering, class Relinearization, class Driver, class Vector>
Status refactorAndRestart(Factor& factor, Ordering& ordering, Relinearization& relinearization,
                          Driver& driver, Vector* delta, Index new_variables,
                          const UpdatePlan& plan, bool allow_reorder, UpdateResult& r) {
  const Index n = factor.columns();
  const StagedVariables relinearized{relinearization.staged(), plan.relinearized};
  bool positions_moved = false;
  const Status s = driver.refactor(ordering, plan, relinearized, new_variables, allow_reorder,
                                   &positions_moved, r);
  if (s != Status::Ok) return s;
  const Index* position_of = ordering.positionOf();
  const auto restart = [&](Index v) {
    delta[v].setZero();
    if (!positions_moved) factor.setSolution(position_of[v], Vector::Zero());
  };
  for (Index i = 0; i < relinearized.count; ++i) restart(relinearized.list[i]);
  for (Index v = n; v < n + new_variables; ++v) restart(v);
  if (positions_moved) factor.loadSolution(delta, ordering.variableAt());
  return Status::Ok;
}

}  // namespace detail
}  // namespace lslam
