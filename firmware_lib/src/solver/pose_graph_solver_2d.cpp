#include "lslam/solver/pose_graph_solver_2d.h"

#include "lslam/factors/se2_factors.h"
#include "update_steps.h"

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

// See detail::planUpdate (update_steps.h), shared with the other façade.
UpdatePlan PoseGraphSolver2D::planUpdate(Index new_poses, bool drop_anchor) {
  return detail::planUpdate(graph_, ordering_, relinearization_, driver_, delta_, new_poses,
                            drop_anchor);
}

// See detail::refactorAndRestart (update_steps.h), shared with the other façade.
Status PoseGraphSolver2D::refactor(Index new_poses, const UpdatePlan& plan, bool allow_reorder,
                                   UpdateResult& r) {
  return detail::refactorAndRestart(cholesky_, ordering_, relinearization_, driver_, delta_,
                                    new_poses, plan, allow_reorder, r);
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
