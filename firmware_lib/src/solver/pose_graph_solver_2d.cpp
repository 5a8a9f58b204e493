#include "lslam/solver/pose_graph_solver_2d.h"

#include "lslam/factors/se2_factors.h"

namespace lslam {
namespace {

OrderingArrays orderingArrays(const SolverArrays& a) {
  OrderingArrays o;
  for (int b = 0; b < 2; ++b) {
    o.position_of[b] = a.position_of[b];
    o.variable_at[b] = a.variable_at[b];
  }
  o.parent_scratch = a.ordering_parent;
  o.count_scratch = a.ordering_count;
  return o;
}

RelinearizationArrays relinearizationArrays(const SolverArrays& a) {
  RelinearizationArrays r;
  r.candidates = a.relinearize_list;
  r.is_candidate = a.relinearize_flag;
  r.staged = a.marked;
  return r;
}

FactorizationArrays factorizationArrays(const SolverArrays& a) {
  FactorizationArrays f;
  f.last_list = a.last_list;
  f.in_last = a.in_last;
  return f;
}

}  // namespace

PoseGraphSolver2D::PoseGraphSolver2D(const SolverArrays& arrays, const PoseGraph2DArrays& graph,
                                     const CholeskyArrays<3>& factor, const ColamdArrays& ordering,
                                     const IdMapArrays& ids, const SolverOptions& options)
    : options_(options),
      graph_(graph, options.cache_linearizations),
      cholesky_(factor),
      ids_(ids),
      id_of_(arrays.id_of),
      delta_(arrays.delta),
      visited_(arrays.visited),
      validator_(arrays.anchored, graph_, ids_),
      ordering_(orderingArrays(arrays), ordering, graph_, cholesky_, options_),
      relinearization_(relinearizationArrays(arrays), graph_, cholesky_, options_),
      driver_(factorizationArrays(arrays), graph_, cholesky_, options_) {}

Status PoseGraphSolver2D::update(const PoseInput* poses, Index num_poses,
                                 const FactorInput* factors, Index num_factors,
                                 UpdateResult* result) {
  UpdateResult local;
  UpdateResult& r = result != nullptr ? *result : local;
  r = UpdateResult{};
  Index priors = 0;
  Status s = validator_.validate(poses, num_poses, factors, num_factors, gauge_, &priors);
  if (s != Status::Ok) {
    r.status = s;
    return s;
  }
  // The gauge (see the class comment): the first update anchors its first pose unless it brings a
  // prior of the caller's; the first caller prior after that takes the anchor out.
  const bool anchor = Gauge::anchorsFirstPose(graph_.variables(), num_poses, priors);
  const bool drop_anchor = gauge_.dropsAnchor(priors);
  graph_.beginUpdate();
  driver_.beginStaging();
  for (Index i = 0; i < num_poses; ++i) graph_.addVariable(poses[i].initial);
  if (anchor) {
    // The first pose stays where it was given (chi2 is gauge-invariant, so the strength of this
    // prior does not change the optimum).
    graph_.addPrior(0, poses[0].initial, Mat3::Identity() * options_.anchor_information);
  }
  if (drop_anchor) graph_.disablePrior(gauge_.anchorFactor());
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
    validator_.forgetNewIds(poses, num_poses);
    return s;
  }
  gauge_.commit(anchor, drop_anchor, driver_.firstNewFactor());
  relinearization_.noteUpdate(plan.relinearize_now, delta_);
  for (Index i = 0; i < num_poses; ++i) id_of_[graph_.variables() - num_poses + i] = poses[i].id;
  r.variables_added = num_poses;
  r.factors_added = graph_.factors() - driver_.firstNewFactor();
  // (planUpdate never plans a preparation together with a reordering.)
  LSLAM_DEBUG_ASSERT(!(plan.prepare_ordering && r.reordered));
  if (plan.prepare_ordering) r.ordering_prepared = ordering_.prepareOrdering();
  if (options_.solve_after_update) solve(false, &r);
  return Status::Ok;
}

// What an update does besides adding its poses and factors (their graph change is staged): a
// prepared ordering is applied now; a stale one is replaced now, or prepared at the end of this
// update and applied by the next (prepare_ordering_ahead). The candidates are relinearized when
// one is urgent, at a reordering, or every relinearize_skip updates; in place, or by a full
// refactorization when that is cheaper (relinearizationDear). An update that drops the anchor
// reorders now, a full refactorization: a factor cannot be taken out of L in place.
UpdatePlan PoseGraphSolver2D::planUpdate(Index new_poses, bool drop_anchor) {
  UpdatePlan plan;
  plan.drop_anchor = drop_anchor;
  ordering_.placeAddedVariablesLast();
  const Index* position_of = ordering_.positionOf();
  plan.fresh_ordering =
      ordering_.wantsFreshOrdering(graph_.factors() - driver_.firstNewFactor(),
                                   [&] { return driver_.addedLoopClosures(position_of); });
  const bool prepared = ordering_.prepared();
  const bool ordering_stale = prepared || plan.fresh_ordering || ordering_.wantsReorder();
  plan.prepare_ordering = ordering_stale && !prepared && !plan.fresh_ordering && !drop_anchor &&
                          ordering_.preparesOrderingAhead(driver_.lastFull().products);
  plan.reorder_now = (ordering_stale || drop_anchor) && !plan.prepare_ordering;
  plan.relinearize_now = relinearization_.due(plan.reorder_now);
  // Outside a reordering only the candidates past the partial bar (see relinearize_partial_...).
  plan.relinearized = plan.relinearize_now ? relinearization_.stageCandidates(
                                                 plan.reorder_now ? CandidateRange::PastThreshold
                                                                  : CandidateRange::PastPartial,
                                                 delta_, 0)
                                           : 0;
  plan.refactor_fully =
      !plan.reorder_now &&
      relinearization_.relinearizationDear(plan.relinearized, driver_.lastFull(), [&] {
        return driver_.inPlaceProducts(
            new_poses, position_of, StagedVariables{relinearization_.staged(), plan.relinearized});
      });
  if (plan.refactor_fully && !ordering_.orderingFresh() &&
      ordering_.preparesOrderingAhead(driver_.lastFull().products)) {
    // A full refactorization in a stale ordering is nearly the price of a reordering: this update
    // only adds its factors, and the next one reorders and relinearizes (the candidates wait).
    graph_.unstageRelinearization();
    plan.relinearized = 0;
    plan.relinearize_now = false;
    plan.refactor_fully = false;
    plan.prepare_ordering = true;  // (a prepared ordering would have been applied: not stale)
  } else if (plan.refactor_fully && relinearization_.partialLeavesWaiting()) {
    // Every column is refactorized anyway: the waiting candidates come along for their
    // linearization alone.
    plan.relinearized =
        relinearization_.stageCandidates(CandidateRange::LeftWaiting, delta_, plan.relinearized);
  }
  return plan;
}

// The driver commits the factor and the graph; the relinearized and the added variables then
// restart from delta = 0. The factor's copy of the solution (by position) follows them, or is
// reloaded whole after a reordering moved the variables.
Status PoseGraphSolver2D::refactor(Index new_poses, const UpdatePlan& plan, bool allow_reorder,
                                   UpdateResult& r) {
  const Index n = cholesky_.columns();
  const StagedVariables relinearized{relinearization_.staged(), plan.relinearized};
  bool positions_moved = false;
  const Status s = driver_.refactor(ordering_, plan, relinearized, new_poses, allow_reorder,
                                    &positions_moved, r);
  if (s != Status::Ok) return s;
  const Index* position_of = ordering_.positionOf();
  const auto restart = [&](Index v) {
    delta_[v].setZero();
    if (!positions_moved) cholesky_.setSolution(position_of[v], Vec3::Zero());
  };
  for (Index i = 0; i < relinearized.count; ++i) restart(relinearized.list[i]);
  for (Index v = n; v < n + new_poses; ++v) restart(v);
  if (positions_moved) cholesky_.loadSolution(delta_, ordering_.variableAt());
  return Status::Ok;
}

void PoseGraphSolver2D::solve(bool full, UpdateResult* result) {
  const bool exact = full || !options_.partial_backsubstitution;
  const Index visited = cholesky_.backSubstitute(
      delta_, variableAt(), options_.backsubstitution_tolerance, exact, visited_);
  relinearization_.noteCandidates(visited_, visited, variableAt());
  if (result != nullptr) result->variables_solved = visited;
}

Status PoseGraphSolver2D::optimize(Index max_iterations, double tolerance, UpdateResult* result) {
  UpdateResult local;
  UpdateResult& r = result != nullptr ? *result : local;
  r = UpdateResult{};
  if (max_iterations < 0 || !(tolerance >= 0.0)) return Status::InvalidArgument;
  solve(true, nullptr);
  for (Index it = 0; it < max_iterations; ++it) {
    graph_.beginUpdate();
    driver_.beginStaging();
    const Index relinearized = relinearization_.stageEveryMovedVariable(delta_, tolerance);
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
    relinearization_.clearCandidates();
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
  return graph_.linearizationPoint(variable).retract(delta_[variable]);
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
    if (f == gauge_.anchorFactor()) continue;
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
