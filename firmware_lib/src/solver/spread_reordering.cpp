#include "lslam/solver/spread_reordering.h"

#include "lslam/assert.h"
#include "lslam/graph/factor_graph.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"
#include "lslam/solver/graph_adapter.h"

namespace lslam {

template <class Graph, class Factor>
SpreadReordering<Graph, Factor>::SpreadReordering(const SpreadReorderingArrays<Vector>& arrays,
                                                  Graph& graph, Factor& factor,
                                                  const SolverOptions& options)
    : a_(arrays), graph_(graph), factor_(factor), driver_(arrays.driver, graph, factor, options) {
  LSLAM_ASSERT(a_.max_updates > 0);
}

template <class Graph, class Factor>
Status SpreadReordering<Graph, Factor>::start(const Index* variable_at, const Index* position_of,
                                              const Index* relinearized, Index num_relinearized,
                                              const Vector* delta) {
  LSLAM_ASSERT(phase_ == Phase::Idle && !graph_.inUpdate());
  const Index n = graph_.variables();
  for (Index k = 0; k < n; ++k) {
    a_.variable_at[k] = variable_at[k];
    a_.position_of[k] = position_of[k];
  }
  num_relinearized_ = num_relinearized;
  for (Index i = 0; i < num_relinearized; ++i) {
    a_.relinearized[i] = relinearized[i];
    a_.relinearized_by[i] = delta[relinearized[i]];
  }
  factor_.clear();
  graph_.beginUpdate();
  stageRelinearization();
  factor_.beginUpdate(n, true, a_.variable_at);
  const Status s = factor_.startFactorization(graph_, a_.variable_at, a_.position_of);
  graph_.rollback();
  if (s != Status::Ok) {
    factor_.rollback();
    return s;
  }
  a_.first_factor[0] = graph_.factors();
  a_.first_variable[0] = n;
  recorded_ = 0;
  caught_up_ = 0;
  last_products_ = factor_.lastStats().block_products;
  phase_ = Phase::Factorizing;
  return Status::Ok;
}

template <class Graph, class Factor>
void SpreadReordering<Graph, Factor>::stageRelinearization() {
  for (Index i = 0; i < num_relinearized_; ++i) {
    GraphAdapter<Graph>::relinearizeBy(graph_, a_.relinearized[i], a_.relinearized_by[i]);
  }
}

template <class Graph, class Factor>
bool SpreadReordering<Graph, Factor>::advance(std::int64_t max_products) {
  LSLAM_ASSERT(active() && !graph_.inUpdate());
  if (recorded_ == a_.max_updates) {
    finish();
    return false;
  }
  ++recorded_;
  a_.first_factor[recorded_] = graph_.factors();
  a_.first_variable[recorded_] = graph_.variables();
  last_products_ = 0;
  if (phase_ == Phase::Factorizing) {
    const std::int64_t before = factor_.lastStats().block_products;
    bool finished = false;
    const Status s = factor_.continueFactorization(max_products, &finished);
    last_products_ = factor_.lastStats().block_products - before;
    if (s != Status::Ok) {
      finish();
      return false;
    }
    if (!finished) return true;
    factor_.commit();
    build_stats_ = factor_.lastStats();
    build_blocks_ = factor_.liveBlocks();
    phase_ = Phase::CatchingUp;
    return true;  // the catching up starts with the next update
  }
  for (int applied = 0; caught_up_ < recorded_ && (applied < 2 || last_products_ < max_products);
       ++applied) {
    if (catchUpOne() != Status::Ok) {
      finish();
      return false;
    }
    last_products_ += factor_.lastStats().block_products;
  }
  if (caught_up_ == recorded_) phase_ = Phase::CaughtUp;
  return true;
}

// The next update noted, in the second factor: its variables appended to the order, its factors
// rotated in at the build's points.
template <class Graph, class Factor>
Status SpreadReordering<Graph, Factor>::catchUpOne() {
  const Index i = caught_up_;
  const Index first_variable = a_.first_variable[i];
  const Index new_columns = a_.first_variable[i + 1] - first_variable;
  for (Index c = 0; c < new_columns; ++c) {
    const Index v = first_variable + c;
    a_.variable_at[factor_.columns() + c] = v;
    a_.position_of[v] = factor_.columns() + c;
  }
  graph_.beginUpdate();
  stageRelinearization();
  Status s = driver_.addCommittedFactors(a_.first_factor[i], a_.first_factor[i + 1], new_columns,
                                         a_.variable_at, a_.position_of);
  if (s == Status::CapacityExhausted && factor_.poolEnd() > factor_.liveBlocks()) {
    // The old versions of the columns earlier row updates rewrote fill the pool: squeeze them out.
    factor_.compact();
    s = driver_.addCommittedFactors(a_.first_factor[i], a_.first_factor[i + 1], new_columns,
                                    a_.variable_at, a_.position_of);
  }
  graph_.rollback();
  if (s == Status::Ok) ++caught_up_;
  return s;
}

template <class Graph, class Factor>
void SpreadReordering<Graph, Factor>::finish() {
  if (phase_ == Phase::Factorizing) factor_.rollback();
  phase_ = Phase::Idle;
  factor_.clear();
}

// Every model's graph and factor.
template class SpreadReordering<FactorGraph<Slam2D>, IncrementalCholesky<3, 2>>;
template class SpreadReordering<FactorGraph<Slam3D>, IncrementalCholesky<6, 3>>;
template class SpreadReordering<FactorGraph<PoseSlam2D>, IncrementalCholesky<3>>;
template class SpreadReordering<FactorGraph<PoseSlam3D>, IncrementalCholesky<6>>;

}  // namespace lslam
