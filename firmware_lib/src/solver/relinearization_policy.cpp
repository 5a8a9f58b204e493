#include "lslam/solver/relinearization_policy.h"

#include <algorithm>
#include <limits>

#include "lslam/graph/factor_graph.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"

namespace lslam {
namespace {

// The max-norm of the head of x, `size` long (one of the block sizes), at a fixed size.
template <class Sizes>
struct HeadMaxNorm;
template <int... S>
struct HeadMaxNorm<BlockSizes<S...>> {
  template <class Vector>
  static double of(int size, const Vector& x) {
    double m = 0.0;
    withSize<S...>(
        size, [&](auto n) { m = x.template head<decltype(n)::value>().cwiseAbs().maxCoeff(); });
    return m;
  }
};

}  // namespace

template <class Graph, class Factor>
RelinearizationPolicy<Graph, Factor>::RelinearizationPolicy(const RelinearizationArrays& arrays,
                                                            Graph& graph, const Factor& factor,
                                                            const SolverOptions& options)
    : a_(arrays), graph_(graph), factor_(factor), options_(options) {
  static_assert(kKinds >= 1 && kKinds <= 2, "relinearize_threshold_of_kind has two kinds");
  for (Index v = 0; v < graph_.maxVariables(); ++v) a_.is_candidate[v] = 0;
}

template <class Graph, class Factor>
int RelinearizationPolicy<Graph, Factor>::kindOf(Index v) const {
  if constexpr (kKinds == 1) {
    static_cast<void>(v);
    return 0;
  } else {
    return Adapter::kindOf(graph_, v);
  }
}

// How far a variable's solution moved from its linearization point (max-norm), the measure of
// every relinearization rule. With mixed sizes a variable's solution is the head of its Vector.
template <class Graph, class Factor>
double RelinearizationPolicy<Graph, Factor>::movedBy(int kind, const Vector& delta) const {
  if constexpr (Factor::kUniform) {
    static_cast<void>(kind);
    return delta.cwiseAbs().maxCoeff();
  } else {
    return HeadMaxNorm<typename Factor::Sizes>::of(Adapter::dofOfKind(kind), delta);
  }
}

// Per kind, the threshold is relinearize_threshold_of_kind, or relinearize_threshold where that is
// 0. The urgent bar is relinearize_urgent_threshold, or the threshold in a graph below
// converge_below_variables. The partial bar is relinearize_partial_threshold, or the threshold
// where it is off (0) or lower; never above the urgent bar, so that the candidate that made an
// update urgent is always taken (above it, an urgent update could relinearize nothing and stay
// urgent).
template <class Graph, class Factor>
typename RelinearizationPolicy<Graph, Factor>::Bars RelinearizationPolicy<Graph, Factor>::bars()
    const {
  Bars result;
  const bool converge = convergesWithinUpdates();
  for (int kind = 0; kind < kKinds; ++kind) {
    RelinearizationBars& b = result.of[kind];
    const double of_kind = options_.relinearize_threshold_of_kind[kind];
    b.threshold = of_kind > 0.0 ? of_kind : options_.relinearize_threshold;
    b.urgent = converge ? b.threshold : options_.relinearize_urgent_threshold;
    const double partial = options_.relinearize_partial_threshold;
    b.partial = !(partial > 0.0) ? b.threshold : std::max(b.threshold, std::min(partial, b.urgent));
  }
  return result;
}

template <class Graph, class Factor>
bool RelinearizationPolicy<Graph, Factor>::convergesWithinUpdates() const {
  return graph_.variables() < options_.converge_below_variables;
}

template <class Graph, class Factor>
Index RelinearizationPolicy<Graph, Factor>::iterationsWithinSolve() const {
  return convergesWithinUpdates()
             ? std::max(options_.urgent_iterations, options_.converge_iterations)
             : options_.urgent_iterations;
}

template <class Graph, class Factor>
bool RelinearizationPolicy<Graph, Factor>::due(bool reorder_now) const {
  return urgent_ || reorder_now ||
         (options_.relinearize_skip > 0 &&
          updates_since_relinearization_ + 1 >= options_.relinearize_skip);
}

template <class Graph, class Factor>
bool RelinearizationPolicy<Graph, Factor>::partialLeavesWaiting() const {
  const Bars b = bars();
  bool waiting = false;
  for (int kind = 0; kind < kKinds; ++kind) {
    waiting = waiting || b.of[kind].partial > b.of[kind].threshold;
  }
  return waiting;
}

// The candidates whose delta lies in (above, at_most] of their kind's bars (max-norm).
template <class Graph, class Factor>
Index RelinearizationPolicy<Graph, Factor>::stageCandidates(CandidateRange range,
                                                            const Vector* delta, Index count) {
  const Bars b = bars();
  for (Index i = 0; i < candidate_count_; ++i) {
    const Index v = a_.candidates[i];
    const int kind = kindOf(v);
    const RelinearizationBars& bar = b.of[kind];
    const double above = range == CandidateRange::PastPartial ? bar.partial : bar.threshold;
    const double at_most = range == CandidateRange::LeftWaiting
                               ? bar.partial
                               : std::numeric_limits<double>::infinity();
    const double moved = movedBy(kind, delta[v]);
    if (!(moved > above && moved <= at_most)) continue;
    Adapter::relinearizeBy(graph_, v, delta[v]);
    a_.staged[count++] = v;
  }
  return count;
}

template <class Graph, class Factor>
Index RelinearizationPolicy<Graph, Factor>::stageEveryMovedVariable(const Vector* delta,
                                                                    double tolerance) {
  Index count = 0;
  for (Index v = 0; v < graph_.variables(); ++v) {
    if (movedBy(kindOf(v), delta[v]) <= tolerance) continue;
    Adapter::relinearizeBy(graph_, v, delta[v]);
    a_.staged[count++] = v;
  }
  return count;
}

// Refactorize every column when this update relinearizes a large share of the variables: that
// recomputes most columns anyway, at twice the cost of factorizing them afresh (old contributions
// are subtracted), so a full refactorization is cheaper. It reorders too only if the ordering is
// no longer fresh (reorder_refresh_growth): right after an ordering, COLAMD would cost its run
// and return about the same fill.
template <class Graph, class Factor>
bool RelinearizationPolicy<Graph, Factor>::relinearizesMost(Index relinearized) const {
  const Index committed = factor_.columns();
  return committed >= options_.reorder_min_variables &&
         static_cast<double>(relinearized) >
             options_.reorder_relinearized_share * static_cast<double>(committed);
}

template <class Graph, class Factor>
void RelinearizationPolicy<Graph, Factor>::clearCandidates() {
  for (Index i = 0; i < candidate_count_; ++i) a_.is_candidate[a_.candidates[i]] = 0;
  candidate_count_ = 0;
  urgent_ = false;
  updates_deferred_ = 0;
}

template <class Graph, class Factor>
void RelinearizationPolicy<Graph, Factor>::noteUpdate(bool relinearized, bool deferred,
                                                      const Vector* delta) {
  if (relinearized) {
    keepWaitingCandidates(delta);
    updates_since_relinearization_ = 0;
    updates_deferred_ = 0;
  } else {
    if (deferred) ++updates_deferred_;
    ++updates_since_relinearization_;
  }
}

// After an update that relinearized: the relinearized candidates restarted from delta = 0 and
// leave the list; those it left waiting (outside a reordering, below the partial bar) stay
// candidates, since a partial solve may not visit them again.
template <class Graph, class Factor>
void RelinearizationPolicy<Graph, Factor>::keepWaitingCandidates(const Vector* delta) {
  const Bars b = bars();
  Index kept = 0;
  bool urgent = false;
  for (Index i = 0; i < candidate_count_; ++i) {
    const Index v = a_.candidates[i];
    const int kind = kindOf(v);
    const double moved = movedBy(kind, delta[v]);
    if (!(moved > b.of[kind].threshold)) {
      a_.is_candidate[v] = 0;
      continue;
    }
    a_.candidates[kept++] = v;
    urgent = urgent || moved > b.of[kind].urgent;
  }
  candidate_count_ = kept;
  urgent_ = urgent;
}

// Reads each visited variable's delta from the factor's copy by position, which the solve has just
// written in the order visited (sequential in a postordered factor), rather than from delta by
// variable (the same values, in a random order).
template <class Graph, class Factor>
void RelinearizationPolicy<Graph, Factor>::noteCandidates(const Index* visited, Index count,
                                                          const Index* variable_at) {
  const Bars b = bars();
  for (Index i = 0; i < count; ++i) {
    const Index k = visited[i];
    // (One kind: the variable is read only for a candidate.)
    const int kind = kKinds == 1 ? 0 : kindOf(variable_at[k]);
    const double moved = movedBy(kind, factor_.solutionAt(k));
    if (!(moved > b.of[kind].threshold)) continue;
    const Index v = variable_at[k];
    // Only a variable that becomes a candidate makes the relinearization urgent: one that was
    // waiting already and moved on past the urgent bar waits for the next relinearization: urgency
    // from those too would relinearize, and refactorize fully, far more often for no better chi2.
    if (a_.is_candidate[v] != 0) continue;
    a_.is_candidate[v] = 1;
    a_.candidates[candidate_count_++] = v;
    urgent_ = urgent_ || moved > b.of[kind].urgent;
  }
}

// Every model's graph and factor.
template class RelinearizationPolicy<FactorGraph<Slam2D>, IncrementalCholesky<3, 2>>;
template class RelinearizationPolicy<FactorGraph<Slam3D>, IncrementalCholesky<6, 3>>;
template class RelinearizationPolicy<FactorGraph<PoseSlam2D>, IncrementalCholesky<3>>;
template class RelinearizationPolicy<FactorGraph<PoseSlam3D>, IncrementalCholesky<6>>;

}  // namespace lslam
