#include "lslam/solver/pose_graph_solver_2d.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "lslam/factors/information.h"
#include "lslam/factors/se2_factors.h"
#include "lslam/linear/elimination_tree.h"

namespace lslam {
namespace {

bool isFinite(const SE2& pose) {
  return std::isfinite(pose.x()) && std::isfinite(pose.y()) && std::isfinite(pose.theta());
}

class ColumnMarker final : public NeighbourVisitor {
 public:
  ColumnMarker(IncrementalCholesky<3>& factor, const Index* position_of)
      : factor_(factor), position_of_(position_of) {}
  void visit(Index variable) override { factor_.markChanged(position_of_[variable]); }

 private:
  IncrementalCholesky<3>& factor_;
  const Index* position_of_;
};

}  // namespace

PoseGraphSolver2D::PoseGraphSolver2D(const SolverArrays& arrays, const PoseGraph2DArrays& graph,
                                     const CholeskyArrays<3>& factor, const ColamdArrays& ordering,
                                     const IdMapArrays& ids, const SolverOptions& options)
    : a_(arrays),
      graph_(graph, options.cache_linearizations),
      cholesky_(factor),
      ordering_(ordering),
      ids_(ids),
      options_(options) {
  for (Index v = 0; v < graph_.maxVariables(); ++v) {
    a_.relinearize_flag[v] = 0;
    a_.in_last[v] = 0;
  }
}

Status PoseGraphSolver2D::validate(const PoseInput* poses, Index num_poses,
                                   const FactorInput* factors, Index num_factors, Index* priors) {
  *priors = 0;
  if (num_poses < 0 || num_factors < 0 || (num_poses > 0 && poses == nullptr) ||
      (num_factors > 0 && factors == nullptr)) {
    return Status::InvalidArgument;
  }
  if (num_poses > graph_.maxVariables() - graph_.variables() ||
      num_factors > graph_.maxFactors() - graph_.factors()) {
    return Status::CapacityExhausted;
  }
  for (Index i = 0; i < num_poses; ++i) {
    if (!isFinite(poses[i].initial)) return Status::NonFiniteInput;
    if (poses[i].id < 0) return Status::InvalidArgument;
  }
  // New ids enter the map now so that every lookup below is uniform; forgetNewIds() undoes it.
  Index inserted = 0;
  Status status = Status::Ok;
  for (; inserted < num_poses; ++inserted) {
    if (ids_.find(poses[inserted].id) != kNoIndex) {
      status = Status::DuplicateVariable;
      break;
    }
    ids_.insert(poses[inserted].id, graph_.variables() + inserted);
  }
  Index prior_count = 0;
  for (Index f = 0; f < num_factors && status == Status::Ok; ++f) {
    const FactorInput& in = factors[f];
    const int arity = factorArity(in.kind);
    if (arity == 0) {
      status = Status::InvalidArgument;  // not a FactorKind
    } else if (ids_.find(in.from) == kNoIndex || (arity == 2 && ids_.find(in.to) == kNoIndex)) {
      status = Status::UnknownVariable;
    } else if (arity == 2 && in.from == in.to) {
      status = Status::InvalidArgument;
    } else if (!isFinite(in.measurement)) {
      status = Status::NonFiniteInput;
    } else {
      status = checkInformation(in.information);
    }
    prior_count += arity == 1 ? 1 : 0;
  }
  *priors = prior_count;
  // The anchor takes a factor too (update()).
  const bool anchor = anchorsFirstPose(num_poses, prior_count);
  if (status == Status::Ok && anchor && num_factors + 1 > graph_.maxFactors()) {
    status = Status::CapacityExhausted;
  }
  if (status == Status::Ok) {
    status = checkAnchored(num_poses, factors, num_factors, anchor, dropsAnchor(prior_count));
  }
  if (status != Status::Ok) forgetNewIds(poses, inserted);
  return status;
}

// Every added pose must be tied to the existing graph (or to a prior) through this call's factors;
// a pose floating free would make Lambda singular, and rounding could hide that from the pivots.
// `anchor`: the solver anchors the first added pose (update() adds a prior). `drop_anchor`: this
// call takes the anchor out, so the committed graph (one connected piece, held by the anchor
// alone) must itself be tied to one of this call's priors: by a prior on a committed pose, or
// through this call's between factors to a pose it adds that is.
Status PoseGraphSolver2D::checkAnchored(Index num_poses, const FactorInput* factors,
                                        Index num_factors, bool anchor, bool drop_anchor) const {
  const Index first_new = graph_.variables();
  // a_.visited is free scratch outside solve(): a flag per added pose, and at [num_poses] one for
  // the committed graph as a whole (index `committed`). Few poses per call: the repeated sweeps
  // stay small.
  Index* is_anchored = a_.visited;
  const Index committed = num_poses;
  const auto node = [&](VariableId id) {
    const Index v = ids_.find(id) - first_new;
    return v < 0 ? committed : v;
  };
  for (Index i = 0; i < num_poses; ++i) is_anchored[i] = 0;
  // (An empty graph has no committed node; then num_poses may fill the whole array.)
  if (first_new > 0) is_anchored[committed] = drop_anchor ? 0 : 1;
  Index anchored = 0;
  const Index required = num_poses + (drop_anchor ? 1 : 0);
  if (anchor) {
    is_anchored[0] = 1;
    anchored = 1;
  }
  bool progress = true;
  while (progress && anchored < required) {
    progress = false;
    for (Index f = 0; f < num_factors; ++f) {
      const FactorInput& in = factors[f];
      const Index a = node(in.from);
      if (factorArity(in.kind) == 1) {
        if (is_anchored[a] == 0) {
          is_anchored[a] = 1;
          ++anchored;
          progress = true;
        }
        continue;
      }
      const Index b = node(in.to);
      if ((is_anchored[a] != 0) != (is_anchored[b] != 0)) {
        is_anchored[is_anchored[a] != 0 ? b : a] = 1;
        ++anchored;
        progress = true;
      }
    }
  }
  return anchored == required ? Status::Ok : Status::UnconstrainedVariable;
}

void PoseGraphSolver2D::forgetNewIds(const PoseInput* poses, Index num_poses) {
  for (Index i = num_poses - 1; i >= 0; --i) ids_.eraseNewest(poses[i].id);
}

// Reorder the whole graph (and refactorize every column) when the factor has grown well past what
// the last ordering produced, when the updates since have spent more extra work on that growth
// than the ordering's factorization cost (see reorder_excess_ratio), or when the last update had to
// walk a long elimination-tree path (a loop closure far back in the order).
bool PoseGraphSolver2D::wantsReorder() const {
  // The update's poses are already in the staged graph.
  if (graph_.variables() < options_.reorder_min_variables) return false;
  if (blocks_at_last_order_ == 0) return true;
  if (excess_budget_ > 0 && excess_work_ > excess_budget_) return true;
  // Compared in double: a huge factor (a trigger switched off) must not overflow an Index.
  return static_cast<double>(cholesky_.liveBlocks()) >
             options_.reorder_growth * static_cast<double>(blocks_at_last_order_) ||
         (options_.reorder_path_columns > 0 &&
          last_columns_refactored_ > options_.reorder_path_columns);
}

// Whether this update's relinearization should refactorize every column rather than recompute the
// affected columns in place: most variables relinearized, or the in-place work estimated above a
// full refactorization's (relinearize_full_cost_ratio).
bool PoseGraphSolver2D::relinearizationDear(Index new_poses, Index relinearized) {
  if (relinearized == 0) return false;
  if (relinearizesMost(relinearized)) return true;
  if (options_.relinearize_full_cost_ratio <= 0.0 || full_products_ == 0) return false;
  Index* position_of = a_.position_of[active_];
  cholesky_.beginUpdate(new_poses, false);
  markAffectedColumns(position_of, relinearized);
  const std::int64_t in_place = cholesky_.inPlaceProducts();
  cholesky_.rollback();
  const double full = options_.relinearize_full_cost_ratio * static_cast<double>(full_products_) *
                      static_cast<double>(cholesky_.liveBlocks()) /
                      static_cast<double>(blocks_at_last_full_);
  return static_cast<double>(in_place) > full;
}

// Refactorize every column when this update relinearizes a large share of the variables: that
// recomputes most columns anyway, at twice the cost of factorizing them afresh (old contributions
// are subtracted), so a full refactorization is cheaper. It reorders too only if the ordering is
// no longer fresh (reorder_refresh_growth): right after an ordering, COLAMD would cost its run
// and return about the same fill.
bool PoseGraphSolver2D::relinearizesMost(Index relinearized) const {
  const Index committed = cholesky_.columns();
  return committed >= options_.reorder_min_variables &&
         static_cast<double>(relinearized) >
             options_.reorder_relinearized_share * static_cast<double>(committed);
}

// The work an update spent on the growth of the factor since the last ordering is estimated as its
// block products times that growth (an update's work scales with the structure of the columns it
// touches), summed and set against reorder_excess_ratio times the block products of the ordering's
// own factorization. Both are kept scaled by the factor's size at the ordering (products x blocks)
// in integers, the budget computed once per ordering: per update only an integer multiply-add and
// compare, whose cost does not depend on the values: a division, or a conversion of the sum to
// double in software, costs the Cortex-M more as the sum grows, and an odometry step's cost must
// not drift.
void PoseGraphSolver2D::noteOrderingWork(bool reordered, std::int64_t block_products) {
  if (reordered) {
    blocks_at_last_order_ = cholesky_.liveBlocks();
    const double budget = options_.reorder_excess_ratio * static_cast<double>(block_products) *
                          static_cast<double>(blocks_at_last_order_);
    excess_budget_ = budget < 9e18 ? static_cast<std::int64_t>(budget)
                                   : std::numeric_limits<std::int64_t>::max();
    excess_work_ = 0;
    return;
  }
  const Index growth = cholesky_.liveBlocks() - blocks_at_last_order_;
  if (blocks_at_last_order_ > 0 && growth > 0) excess_work_ += block_products * growth;
}

bool PoseGraphSolver2D::orderingFresh() const {
  return blocks_at_last_order_ > 0 &&
         static_cast<double>(cholesky_.liveBlocks()) <=
             options_.reorder_refresh_growth * static_cast<double>(blocks_at_last_order_);
}

// COLAMD on the factor-variable incidence of every variable except the newest committed one,
// which goes last, followed by the variables this update adds: the next odometry factor then
// touches only the last columns, so it stays constant-time after a reordering too. With nothing
// committed (a first update that reorders, or retries for room) the ordered variables are the
// update's own, its newest last.
Status PoseGraphSolver2D::computeOrdering(Index* variable_at, Index* position_of) {
  const Index ordered = cholesky_.columns() > 0 ? cholesky_.columns() : graph_.variables();
  if (ordered == 0) return Status::Ok;  // an empty graph: nothing to order
  const Index last = ordered - 1;
  ordering_.begin();
  for (Index v = 0; v < last; ++v) {
    ordering_.startColumn();
    for (Index e = graph_.firstEntry(v); e != kNoIndex; e = graph_.nextEntry(e)) {
      if (!ordering_.addEntry(graph_.entryFactor(e))) return Status::WorkspaceExhausted;
    }
  }
  const Status s = ordering_.order(graph_.factors(), variable_at);
  if (s != Status::Ok) return s;
  // The columns given to COLAMD were the variables 0 .. last - 1 in order: its output is already
  // in variable numbers.
  for (Index v = last; v < graph_.variables(); ++v) variable_at[v] = v;
  for (Index k = 0; k < graph_.variables(); ++k) position_of[variable_at[k]] = k;
  // Postordered (same fill) so that the solve reads the per-column arrays in sequence. The solve's
  // visit list and the reordered update's list are idle while an ordering is computed.
  postorderEliminationOrder(ordered, variable_at, position_of, graph_, a_.visited, a_.last_list);
  LSLAM_ASSERT(variable_at[last] == last);
  for (Index k = 0; k < ordered; ++k) position_of[variable_at[k]] = k;
  return Status::Ok;
}

bool PoseGraphSolver2D::preparesOrderingAhead() const {
  return options_.prepare_ordering_ahead &&
         full_products_ >= options_.prepare_ordering_min_products;
}

// The ordering of every committed variable, into the inactive buffer, for the next update. Without
// ordering workspace nothing is prepared, and the next update asks again.
bool PoseGraphSolver2D::prepareOrdering() {
  const int other = 1 - active_;
  ordering_prepared_ = computeOrdering(a_.variable_at[other], a_.position_of[other]) == Status::Ok;
  prepared_variables_ = graph_.variables();
  return ordering_prepared_;
}

// The prepared ordering (in the buffers given, the inactive ones) extended by the variables added
// since, in the order they came: the newest stays last.
void PoseGraphSolver2D::takePreparedOrdering(Index* variable_at, Index* position_of) const {
  for (Index v = prepared_variables_; v < graph_.variables(); ++v) {
    variable_at[v] = v;
    position_of[v] = v;
  }
}

Status PoseGraphSolver2D::update(const PoseInput* poses, Index num_poses,
                                 const FactorInput* factors, Index num_factors,
                                 UpdateResult* result) {
  UpdateResult local;
  UpdateResult& r = result != nullptr ? *result : local;
  r = UpdateResult{};
  Index priors = 0;
  Status s = validate(poses, num_poses, factors, num_factors, &priors);
  if (s != Status::Ok) {
    r.status = s;
    return s;
  }
  // The gauge (see the class comment): the first update anchors its first pose unless it brings a
  // prior of the caller's; the first caller prior after that takes the anchor out.
  const bool anchor = anchorsFirstPose(num_poses, priors);
  const bool drop_anchor = dropsAnchor(priors);
  graph_.beginUpdate();
  first_new_factor_ = graph_.factors();
  for (Index i = 0; i < num_poses; ++i) graph_.addVariable(poses[i].initial);
  if (anchor) {
    // The first pose stays where it was given (chi2 is gauge-invariant, so the strength of this
    // prior does not change the optimum).
    graph_.addPrior(0, poses[0].initial, Mat3::Identity() * options_.anchor_information);
  }
  if (drop_anchor) graph_.disablePrior(anchor_factor_);
  for (Index f = 0; f < num_factors; ++f) {
    const FactorInput& in = factors[f];
    // (validate() let through only arities 1 and 2.)
    if (factorArity(in.kind) == 1) {
      graph_.addPrior(ids_.find(in.from), in.measurement, in.information);
    } else {
      graph_.addBetween(ids_.find(in.from), ids_.find(in.to), in.measurement, in.information);
    }
  }
  // Every update begins the factor's update at least once, which does a pending layout.
  r.laid_out = cholesky_.layoutPending();
  const UpdatePlan plan = planUpdate(num_poses, drop_anchor);
  s = refactor(num_poses, plan, true, r);
  if (s != Status::Ok) {
    forgetNewIds(poses, num_poses);
    return s;
  }
  if (anchor) anchor_factor_ = first_new_factor_;
  if (drop_anchor) anchor_factor_ = kNoIndex;
  if (plan.relinearize_now) {
    keepWaitingCandidates();
    updates_since_relinearization_ = 0;
  } else {
    ++updates_since_relinearization_;
  }
  for (Index i = 0; i < num_poses; ++i) a_.id_of[graph_.variables() - num_poses + i] = poses[i].id;
  r.variables_added = num_poses;
  r.factors_added = graph_.factors() - first_new_factor_;
  // (planUpdate never plans a preparation together with a reordering.)
  LSLAM_DEBUG_ASSERT(!(plan.prepare_ordering && r.reordered));
  if (plan.prepare_ordering) r.ordering_prepared = prepareOrdering();
  if (options_.solve_after_update) solve(false, &r);
  return Status::Ok;
}

// What an update does besides adding its poses and factors (their graph change is staged): a
// prepared ordering is applied now; a stale one is replaced now, or prepared at the end of this
// update and applied by the next (prepare_ordering_ahead). The candidates are relinearized when
// one is urgent, at a reordering, or every relinearize_skip updates; in place, or by a full
// refactorization when that is cheaper (relinearizationDear). An update that drops the anchor
// reorders now, a full refactorization: a factor cannot be taken out of L in place.
PoseGraphSolver2D::UpdatePlan PoseGraphSolver2D::planUpdate(Index new_poses, bool drop_anchor) {
  UpdatePlan plan;
  plan.drop_anchor = drop_anchor;
  placeAddedVariablesLast();
  // (Counting the loop closures is skipped when the update has too few factors to be a burst.)
  const Index burst = options_.reorder_burst_loop_closures;
  plan.fresh_ordering = burst > 0 && graph_.factors() - first_new_factor_ > burst &&
                        graph_.variables() >= options_.reorder_min_variables &&
                        addedLoopClosures(a_.position_of[active_]) > burst;
  const bool ordering_stale = ordering_prepared_ || plan.fresh_ordering || wantsReorder();
  plan.prepare_ordering = ordering_stale && !ordering_prepared_ && !plan.fresh_ordering &&
                          !drop_anchor && preparesOrderingAhead();
  plan.reorder_now = (ordering_stale || drop_anchor) && !plan.prepare_ordering;
  plan.relinearize_now = relinearization_urgent_ || plan.reorder_now ||
                         (options_.relinearize_skip > 0 &&
                          updates_since_relinearization_ + 1 >= options_.relinearize_skip);
  // Outside a reordering only the candidates past relinearize_partial_threshold (see there).
  const double threshold = options_.relinearize_threshold;
  const double first = plan.reorder_now ? threshold : partialThreshold();
  plan.relinearized =
      plan.relinearize_now ? stageCandidates(first, std::numeric_limits<double>::infinity(), 0) : 0;
  plan.refactor_fully = !plan.reorder_now && relinearizationDear(new_poses, plan.relinearized);
  if (plan.refactor_fully && !orderingFresh() && preparesOrderingAhead()) {
    // A full refactorization in a stale ordering is nearly the price of a reordering: this update
    // only adds its factors, and the next one reorders and relinearizes (the candidates wait).
    graph_.unstageRelinearization();
    plan.relinearized = 0;
    plan.relinearize_now = false;
    plan.refactor_fully = false;
    plan.prepare_ordering = true;  // (a prepared ordering would have been applied: not stale)
  } else if (plan.refactor_fully && first > threshold) {
    // Every column is refactorized anyway: the waiting candidates come along for their
    // linearization alone.
    plan.relinearized = stageCandidates(threshold, first, plan.relinearized);
  }
  return plan;
}

// The variables this update adds take the last positions of the active order, as the update in
// place gives them (a reordering writes its own order to the other buffer). Once per update, before
// anything reads their positions.
void PoseGraphSolver2D::placeAddedVariablesLast() {
  for (Index v = cholesky_.columns(); v < graph_.variables(); ++v) {
    a_.variable_at[active_][v] = v;
    a_.position_of[active_][v] = v;
  }
}

// The factors of this update that reach back before the newest committed pose.
Index PoseGraphSolver2D::addedLoopClosures(const Index* position_of) const {
  Index count = 0;
  for (Index f = first_new_factor_; f < graph_.factors(); ++f) {
    if (factorReachesBack(f, position_of)) ++count;
  }
  return count;
}

// The candidates whose delta lies in (above, at_most] (max-norm), staged for relinearization and
// listed in a_.marked from position `count` on; returns the count after them.
Index PoseGraphSolver2D::stageCandidates(double above, double at_most, Index count) {
  for (Index i = 0; i < relinearize_count_; ++i) {
    const Index v = a_.relinearize_list[i];
    const double moved = movedBy(v);
    if (!(moved > above && moved <= at_most)) continue;
    graph_.relinearize(v, graph_.linearizationPoint(v).retract(a_.delta[v]));
    a_.marked[count++] = v;
  }
  return count;
}

// The bar of a relinearization outside a reordering: relinearize_partial_threshold, or
// relinearize_threshold where it is off (0) or lower; never above relinearize_urgent_threshold,
// so that the candidate that made an update urgent is always taken (above it, an urgent update
// could relinearize nothing and stay urgent).
double PoseGraphSolver2D::partialThreshold() const {
  const double partial = options_.relinearize_partial_threshold;
  if (!(partial > 0.0)) return options_.relinearize_threshold;
  return std::max(options_.relinearize_threshold,
                  std::min(partial, options_.relinearize_urgent_threshold));
}

Index PoseGraphSolver2D::stageEveryMovedVariable(double tolerance) {
  Index count = 0;
  for (Index v = 0; v < graph_.variables(); ++v) {
    if (movedBy(v) <= tolerance) continue;
    graph_.relinearize(v, graph_.linearizationPoint(v).retract(a_.delta[v]));
    a_.marked[count++] = v;
  }
  return count;
}

// A fresh COLAMD ordering of the staged graph (this update's factors in it) into the inactive
// buffer; `prepared_overwritten` tells whether it wrote over a prepared ordering.
bool PoseGraphSolver2D::computeFreshOrdering(bool* prepared_overwritten) {
  const int other = 1 - active_;
  *prepared_overwritten = ordering_prepared_;
  return computeOrdering(a_.variable_at[other], a_.position_of[other]) == Status::Ok;
}

// Factorizes the staged graph change (added poses at the end, relinearized variables in a_.marked),
// reordering first if the plan says so (the prepared ordering, unless the plan wants a fresh one
// with this update's factors); commits everything or rolls the graph back.
Status PoseGraphSolver2D::refactor(Index new_poses, const UpdatePlan& plan, bool allow_reorder,
                                   UpdateResult& r) {
  LSLAM_ASSERT(allow_reorder || !plan.reorder_now);
  const Index n = cholesky_.columns();
  const Index relinearized = plan.relinearized;
  bool full = plan.reorder_now || plan.refactor_fully;
  bool reorder = plan.reorder_now || (full && !orderingFresh());
  int buffer = active_;
  bool fresh = false;  // the ordering computed here, with this update's factors in it
  bool prepared_overwritten = false;
  if (reorder) {
    buffer = 1 - active_;
    if (ordering_prepared_ && !plan.fresh_ordering) {
      takePreparedOrdering(a_.variable_at[buffer], a_.position_of[buffer]);
    } else {
      reorder = fresh = computeFreshOrdering(&prepared_overwritten);
    }
    if (!reorder) buffer = active_;  // no workspace for an ordering: keep the current one
    full = reorder || plan.drop_anchor;
  }
  // (In the active order the added variables are last already: placeAddedVariablesLast.)
  const Index* variable_at = a_.variable_at[buffer];
  const Index* position_of = a_.position_of[buffer];
  bool top_reordered = false;
  Status s = factorizeWithRetry(full, allow_reorder, new_poses, variable_at, position_of,
                                relinearized, &top_reordered, r);
  if (s == Status::CapacityExhausted && allow_reorder && !fresh) {
    // The update's fill does not fit in an order chosen without its factors (a burst of loop
    // closures, say from a file that lists them after every pose): a fresh order over every
    // factor, this update's included, usually fits.
    const int other = 1 - active_;
    fresh = computeFreshOrdering(&prepared_overwritten);
    if (fresh) {
      buffer = other;
      reorder = full = true;
      r.reordered_for_room = true;
      s = factorizeWithRetry(true, allow_reorder, new_poses, a_.variable_at[other],
                             a_.position_of[other], relinearized, &top_reordered, r);
    }
  }
  if (s != Status::Ok) {
    graph_.rollback();
    // A fresh ordering overwrote the prepared one; the same committed graph prepares it again.
    if (prepared_overwritten) prepareOrdering();
    r.status = s;
    return s;
  }
  if (top_reordered) buffer = 1 - active_;  // the reordered update wrote the other buffer
  // Applied, or overwritten (by a reordered update of the top, or by an ordering that could not
  // be computed).
  if (reorder || top_reordered || prepared_overwritten) ordering_prepared_ = false;
  graph_.commit();
  active_ = buffer;
  // The relinearized and the added variables restart from delta = 0. The factor's copy of the
  // solution (by position) follows them, or is reloaded whole after a reordering moved the
  // variables.
  const bool positions_moved = reorder || top_reordered;
  const auto restart = [&](Index v) {
    a_.delta[v].setZero();
    if (!positions_moved) cholesky_.setSolution(position_of[v], Vec3::Zero());
  };
  for (Index i = 0; i < relinearized; ++i) restart(a_.marked[i]);
  for (Index v = n; v < n + new_poses; ++v) restart(v);
  if (positions_moved) cholesky_.loadSolution(a_.delta, a_.variable_at[active_]);
  const FactorizationStats& stats = cholesky_.lastStats();
  noteOrderingWork(reorder, stats.block_products);
  if (full) {
    full_products_ = stats.block_products;
    blocks_at_last_full_ = cholesky_.liveBlocks();
  }
  if (!full) largest_staging_ = std::max(largest_staging_, stats.blocks_written);
  last_columns_refactored_ = full ? 0 : stats.columns_recomputed;
  r.reordered = reorder;
  r.refactored_fully = full;
  r.top_reordered = top_reordered;
  r.variables_relinearized = relinearized;
  r.columns_refactored = stats.columns_recomputed;
  r.block_products = stats.block_products;
  r.factor_blocks = cholesky_.liveBlocks();
  return Status::Ok;
}

Status PoseGraphSolver2D::factorizeWithRetry(bool full, bool allow_top_reorder, Index new_columns,
                                             const Index* variable_at, const Index* position_of,
                                             Index relinearized, bool* top_reordered,
                                             UpdateResult& r) {
  if (likelyOutOfPool(full, relinearized, position_of) &&
      cholesky_.poolEnd() > cholesky_.liveBlocks()) {
    cholesky_.compact();
    r.compacted = true;
  }
  for (int attempt = 0;; ++attempt) {
    const Status s = factorizeOnce(full, allow_top_reorder, new_columns, variable_at, position_of,
                                   relinearized, top_reordered);
    if (s == Status::Ok) return s;
    // A full pool is often only garbage left by earlier updates: squeeze it out and try once more.
    if (s != Status::CapacityExhausted || attempt > 0) return s;
    cholesky_.compact();
    r.compacted = true;
  }
}

// Compacting before an update that would probably not fit saves the attempt that would fail (work
// of nearly the update's own size, thrown away). A full refactorization stages about the live
// factor again (a quarter more for a fresh order's fill), a loop closure or a relinearization at
// most about what the largest such update so far staged. An odometry update (the last columns
// only) is never compacted ahead: its need is tiny, and its cost must not depend on the pool's
// fill.
bool PoseGraphSolver2D::likelyOutOfPool(bool full, Index relinearized,
                                        const Index* position_of) const {
  const Index live = cholesky_.liveBlocks();
  const Index need = full ? live + live / 4 : largest_staging_;
  if (cholesky_.poolEnd() + need <= cholesky_.poolCapacity()) return false;  // the common case
  return full || relinearized > 0 || reachesBack(position_of);
}

// One attempt: a full refactorization, a reordered update of the affected top, or the plain
// update in the current order. The reordered update writes the fresh order to the inactive buffer.
Status PoseGraphSolver2D::factorizeOnce(bool full, bool allow_top_reorder, Index new_columns,
                                        const Index* variable_at, const Index* position_of,
                                        Index relinearized, bool* top_reordered) {
  *top_reordered = false;
  cholesky_.beginUpdate(new_columns, full);
  // A full refactorization in the active order (a reordering reads the other buffer) keeps the
  // structure of every column outside the etree paths of this update's factors.
  if (full && variable_at == a_.variable_at[active_]) {
    cholesky_.keepUnchangedStructures();
    visitAddedFactorColumns(position_of,
                            [this](Index column) { cholesky_.markStructureChanged(column); });
  }
  if (!full && relinearized == 0 && options_.row_updates && reachesBack(position_of)) {
    Status s = addRowsOfAddedFactors(position_of);
    if (s == Status::Ok) s = cholesky_.finishRowUpdate();
    if (s == Status::Ok) {
      cholesky_.commit();
    } else {
      cholesky_.rollback();
    }
    return s;
  }
  if (!full) markAffectedColumns(position_of, relinearized);
  if (!full && allow_top_reorder && options_.reorder_affected_top &&
      cholesky_.affectedTopSize() - new_columns >= options_.reorder_top_min_columns) {
    const int other = 1 - active_;
    const Index num_last = collectLastColumns(position_of, new_columns);
    const Status s =
        cholesky_.factorizeReordered(graph_, ordering_, a_.last_list, num_last, variable_at,
                                     a_.variable_at[other], a_.position_of[other]);
    if (s == Status::Ok) {
      cholesky_.commit();
      *top_reordered = true;
      return s;
    }
    cholesky_.rollback();
    // No ordering workspace for this top: the plain update below still works.
    if (s != Status::WorkspaceExhausted) return s;
    cholesky_.beginUpdate(new_columns, false);
    markAffectedColumns(position_of, relinearized);
  }
  const Status s = cholesky_.factorize(graph_, variable_at, position_of);
  if (s == Status::Ok) {
    cholesky_.commit();
  } else {
    cholesky_.rollback();
  }
  return s;
}

// The columns a reordered update keeps last: the existing variables of the added factors and the
// newest existing pose (ascending), then the added poses, newest last, so that the next odometry
// factor again touches only the last columns.
Index PoseGraphSolver2D::collectLastColumns(const Index* position_of, Index new_columns) {
  const Index first_new = cholesky_.columns();
  Index count = 0;
  auto add = [&](Index position) {
    if (position < first_new && a_.in_last[position] == 0) {
      a_.in_last[position] = 1;
      a_.last_list[count++] = position;
    }
  };
  visitAddedFactorColumns(position_of, add);
  if (first_new > 0) add(position_of[first_new - 1]);
  std::sort(a_.last_list, a_.last_list + count);
  for (Index i = 0; i < count; ++i) a_.in_last[a_.last_list[i]] = 0;
  for (Index k = first_new; k < first_new + new_columns; ++k) a_.last_list[count++] = k;
  return count;
}

// Whether an added factor touches a column before the newest committed one (a loop closure).
// Only then is the path long enough for the row update to pay: an odometry step touches the last
// two columns, and recomputing those is cheaper than whitening and rotating (on the Cortex-M7
// about 6,100 against 9,000 instructions per step).
bool PoseGraphSolver2D::reachesBack(const Index* position_of) const {
  return addedLoopClosures(position_of) > 0;
}

// Whether factor f touches a column before the newest committed one.
bool PoseGraphSolver2D::factorReachesBack(Index f, const Index* position_of) const {
  const Index newest_committed = cholesky_.columns() - 1;
  if (position_of[graph_.firstVariable(f)] < newest_committed) return true;
  const Index second = graph_.secondVariable(f);
  return second != kNoIndex && position_of[second] < newest_committed;
}

// The factors that reach back (loop closures) go in pairs, each pair rotated together along the
// part of their paths they share; the rest (odometry: the last two columns) one by one.
Status PoseGraphSolver2D::addRowsOfAddedFactors(const Index* position_of) {
  using FactorRows = IncrementalCholesky<3>::FactorRows;
  struct Whitened {
    Index positions[2];
    Mat3 rows[2];
    FactorRows rows_of;
  };
  Whitened whitened[2];
  int pending = 0;  // reaching-back factors whitened, waiting for a partner
  for (Index f = first_new_factor_; f < graph_.factors(); ++f) {
    Whitened& w = whitened[pending];
    w.rows_of.count = graph_.whitenedRows(f, position_of, w.positions, w.rows, &w.rows_of.rhs);
    w.rows_of.positions = w.positions;
    w.rows_of.rows_transposed = w.rows;
    Status s = Status::Ok;
    if (!factorReachesBack(f, position_of)) {
      s = cholesky_.addFactorRows(w.rows_of);
    } else if (pending == 0) {
      pending = 1;
    } else {
      s = cholesky_.addFactorRows(whitened[0].rows_of, w.rows_of);
      pending = 0;
    }
    if (s != Status::Ok) return s;
  }
  return pending == 1 ? cholesky_.addFactorRows(whitened[0].rows_of) : Status::Ok;
}

void PoseGraphSolver2D::markAffectedColumns(const Index* position_of, Index relinearized) {
  visitAddedFactorColumns(position_of, [this](Index column) { cholesky_.markChanged(column); });
  // A relinearized variable changes its own column of Lambda and those of its neighbours.
  ColumnMarker marker(cholesky_, position_of);
  for (Index i = 0; i < relinearized; ++i) {
    const Index v = a_.marked[i];
    cholesky_.markChanged(position_of[v]);
    graph_.visitNeighbours(v, marker);
  }
}

void PoseGraphSolver2D::solve(bool full, UpdateResult* result) {
  const bool exact = full || !options_.partial_backsubstitution;
  const Index visited = cholesky_.backSubstitute(
      a_.delta, variableAt(), options_.backsubstitution_tolerance, exact, a_.visited);
  noteRelinearizationCandidates(visited);
  if (result != nullptr) result->variables_solved = visited;
}

void PoseGraphSolver2D::clearRelinearizationCandidates() {
  for (Index i = 0; i < relinearize_count_; ++i) a_.relinearize_flag[a_.relinearize_list[i]] = 0;
  relinearize_count_ = 0;
  relinearization_urgent_ = false;
}

// After an update that relinearized: the relinearized candidates restarted from delta = 0 and
// leave the list; those it left waiting (outside a reordering, below
// relinearize_partial_threshold) stay candidates, since a partial solve may not visit them again.
void PoseGraphSolver2D::keepWaitingCandidates() {
  Index kept = 0;
  bool urgent = false;
  for (Index i = 0; i < relinearize_count_; ++i) {
    const Index v = a_.relinearize_list[i];
    const double moved = movedBy(v);
    if (!(moved > options_.relinearize_threshold)) {
      a_.relinearize_flag[v] = 0;
      continue;
    }
    a_.relinearize_list[kept++] = v;
    urgent = urgent || moved > options_.relinearize_urgent_threshold;
  }
  relinearize_count_ = kept;
  relinearization_urgent_ = urgent;
}

// Reads each visited variable's delta from the factor's copy by position, which the solve has just
// written in the order visited (sequential in a postordered factor), rather than from delta by
// variable (the same values, in a random order).
void PoseGraphSolver2D::noteRelinearizationCandidates(Index visited) {
  const Index* variable_at = variableAt();
  for (Index i = 0; i < visited; ++i) {
    const Index k = a_.visited[i];
    const double moved = cholesky_.solutionAt(k).cwiseAbs().maxCoeff();
    if (!(moved > options_.relinearize_threshold)) continue;
    const Index v = variable_at[k];
    // Only a variable that becomes a candidate makes the relinearization urgent: one that was
    // waiting already and moved on past the urgent bar waits for the next relinearization: urgency
    // from those too would relinearize, and refactorize fully, far more often for no better chi2.
    if (a_.relinearize_flag[v] != 0) continue;
    a_.relinearize_flag[v] = 1;
    a_.relinearize_list[relinearize_count_++] = v;
    relinearization_urgent_ =
        relinearization_urgent_ || moved > options_.relinearize_urgent_threshold;
  }
}

Status PoseGraphSolver2D::optimize(Index max_iterations, double tolerance, UpdateResult* result) {
  UpdateResult local;
  UpdateResult& r = result != nullptr ? *result : local;
  r = UpdateResult{};
  if (max_iterations < 0 || !(tolerance >= 0.0)) return Status::InvalidArgument;
  solve(true, nullptr);
  for (Index it = 0; it < max_iterations; ++it) {
    graph_.beginUpdate();
    first_new_factor_ = graph_.factors();
    const Index relinearized = stageEveryMovedVariable(tolerance);
    if (relinearized == 0) {
      graph_.commit();  // nothing staged: commit is a no-op
      break;
    }
    UpdateResult step;
    UpdatePlan plan;
    plan.relinearized = relinearized;
    const Status s = refactor(0, plan, false, step);
    if (s != Status::Ok) {
      r.status = s;
      return s;
    }
    clearRelinearizationCandidates();
    solve(true, nullptr);
    r.iterations = it + 1;
    r.variables_relinearized += step.variables_relinearized;
    r.columns_refactored += step.columns_refactored;
    r.block_products += step.block_products;
  }
  r.factor_blocks = cholesky_.liveBlocks();
  return Status::Ok;
}

SE2 PoseGraphSolver2D::estimateAt(Index variable) const {
  return graph_.linearizationPoint(variable).retract(a_.delta[variable]);
}

Status PoseGraphSolver2D::estimate(VariableId id, SE2* pose) const {
  if (pose == nullptr) return Status::InvalidArgument;
  const Index v = ids_.find(id);
  if (v == kNoIndex) return Status::UnknownVariable;
  *pose = estimateAt(v);
  return Status::Ok;
}

// The caller's factors only: the anchor is skipped (a dropped one has zero information).
double PoseGraphSolver2D::chi2() const {
  double total = 0.0;
  for (Index f = 0; f < graph_.factors(); ++f) {
    if (f == anchor_factor_) continue;
    const Index i = graph_.firstVariable(f);
    Vec3 e;
    if (graph_.kind(f) == FactorKind::PriorSE2) {
      e = priorErrorSE2(estimateAt(i), graph_.measurement(f));
    } else {
      e = betweenErrorSE2(estimateAt(i), estimateAt(graph_.secondVariable(f)),
                          graph_.measurement(f));
    }
    total += e.dot(graph_.information(f) * e);
  }
  return total;
}

}  // namespace lslam
