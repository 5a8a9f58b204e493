#include "lslam/solver/relinearization_policy.h"

#include <algorithm>
#include <limits>

namespace lslam {
namespace {

// How far a variable's solution moved from its linearization point (max-norm), the measure of
// every relinearization rule.
double movedBy(const Vec3& delta) {
  return delta.cwiseAbs().maxCoeff();
}

}  // namespace

RelinearizationPolicy::RelinearizationPolicy(const RelinearizationArrays& arrays,
                                             PoseGraph2D& graph,
                                             const IncrementalCholesky<3>& factor,
                                             const SolverOptions& options)
    : a_(arrays), graph_(graph), factor_(factor), options_(options) {
  for (Index v = 0; v < graph_.maxVariables(); ++v) a_.is_candidate[v] = 0;
}

// The partial bar is relinearize_partial_threshold, or relinearize_threshold where it is off (0)
// or lower; never above relinearize_urgent_threshold, so that the candidate that made an update
// urgent is always taken (above it, an urgent update could relinearize nothing and stay urgent).
RelinearizationBars RelinearizationPolicy::barsOf() const {
  RelinearizationBars bars;
  bars.threshold = options_.relinearize_threshold;
  bars.urgent = options_.relinearize_urgent_threshold;
  const double partial = options_.relinearize_partial_threshold;
  bars.partial =
      !(partial > 0.0) ? bars.threshold : std::max(bars.threshold, std::min(partial, bars.urgent));
  return bars;
}

bool RelinearizationPolicy::due(bool reorder_now) const {
  return urgent_ || reorder_now ||
         (options_.relinearize_skip > 0 &&
          updates_since_relinearization_ + 1 >= options_.relinearize_skip);
}

bool RelinearizationPolicy::partialLeavesWaiting() const {
  const RelinearizationBars bars = barsOf();
  return bars.partial > bars.threshold;
}

// The candidates whose delta lies in (above, at_most] (max-norm).
Index RelinearizationPolicy::stageCandidates(CandidateRange range, const Vec3* delta, Index count) {
  const RelinearizationBars bars = barsOf();
  const double above = range == CandidateRange::PastPartial ? bars.partial : bars.threshold;
  const double at_most =
      range == CandidateRange::LeftWaiting ? bars.partial : std::numeric_limits<double>::infinity();
  for (Index i = 0; i < candidate_count_; ++i) {
    const Index v = a_.candidates[i];
    const double moved = movedBy(delta[v]);
    if (!(moved > above && moved <= at_most)) continue;
    graph_.relinearize(v, graph_.linearizationPoint(v).retract(delta[v]));
    a_.staged[count++] = v;
  }
  return count;
}

Index RelinearizationPolicy::stageEveryMovedVariable(const Vec3* delta, double tolerance) {
  Index count = 0;
  for (Index v = 0; v < graph_.variables(); ++v) {
    if (movedBy(delta[v]) <= tolerance) continue;
    graph_.relinearize(v, graph_.linearizationPoint(v).retract(delta[v]));
    a_.staged[count++] = v;
  }
  return count;
}

// Refactorize every column when this update relinearizes a large share of the variables: that
// recomputes most columns anyway, at twice the cost of factorizing them afresh (old contributions
// are subtracted), so a full refactorization is cheaper. It reorders too only if the ordering is
// no longer fresh (reorder_refresh_growth): right after an ordering, COLAMD would cost its run
// and return about the same fill.
bool RelinearizationPolicy::relinearizesMost(Index relinearized) const {
  const Index committed = factor_.columns();
  return committed >= options_.reorder_min_variables &&
         static_cast<double>(relinearized) >
             options_.reorder_relinearized_share * static_cast<double>(committed);
}

void RelinearizationPolicy::clearCandidates() {
  for (Index i = 0; i < candidate_count_; ++i) a_.is_candidate[a_.candidates[i]] = 0;
  candidate_count_ = 0;
  urgent_ = false;
}

void RelinearizationPolicy::noteUpdate(bool relinearized, const Vec3* delta) {
  if (relinearized) {
    keepWaitingCandidates(delta);
    updates_since_relinearization_ = 0;
  } else {
    ++updates_since_relinearization_;
  }
}

// After an update that relinearized: the relinearized candidates restarted from delta = 0 and
// leave the list; those it left waiting (outside a reordering, below the partial bar) stay
// candidates, since a partial solve may not visit them again.
void RelinearizationPolicy::keepWaitingCandidates(const Vec3* delta) {
  const RelinearizationBars bars = barsOf();
  Index kept = 0;
  bool urgent = false;
  for (Index i = 0; i < candidate_count_; ++i) {
    const Index v = a_.candidates[i];
    const double moved = movedBy(delta[v]);
    if (!(moved > bars.threshold)) {
      a_.is_candidate[v] = 0;
      continue;
    }
    a_.candidates[kept++] = v;
    urgent = urgent || moved > bars.urgent;
  }
  candidate_count_ = kept;
  urgent_ = urgent;
}

// Reads each visited variable's delta from the factor's copy by position, which the solve has just
// written in the order visited (sequential in a postordered factor), rather than from delta by
// variable (the same values, in a random order).
void RelinearizationPolicy::noteCandidates(const Index* visited, Index count,
                                           const Index* variable_at) {
  const RelinearizationBars bars = barsOf();
  for (Index i = 0; i < count; ++i) {
    const Index k = visited[i];
    const double moved = factor_.solutionAt(k).cwiseAbs().maxCoeff();
    if (!(moved > bars.threshold)) continue;
    const Index v = variable_at[k];
    // Only a variable that becomes a candidate makes the relinearization urgent: one that was
    // waiting already and moved on past the urgent bar waits for the next relinearization: urgency
    // from those too would relinearize, and refactorize fully, far more often for no better chi2.
    if (a_.is_candidate[v] != 0) continue;
    a_.is_candidate[v] = 1;
    a_.candidates[candidate_count_++] = v;
    urgent_ = urgent_ || moved > bars.urgent;
  }
}

}  // namespace lslam
