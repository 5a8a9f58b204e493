#pragma once
// A reordering spread over several updates (firmware_lib/README.md, Ordering): the factor in the
// fresh order is built beside the live one while the live one keeps serving, then replaces it.
//
// - start(): takes the prepared ordering and the candidates due for relinearization, and runs the
//   symbolic phase and the assembly of Lambda (the candidates at their moved points, staged in the
//   graph for that call only: the live factor keeps the old ones).
// - advance(), after each committed update: the numeric phase, max_products block products at a
//   time; then the updates committed meanwhile, each as row updates of its factors (at the same
//   points as the assembly), until the second factor has caught up with the live one.
// - ready(): the caller swaps the factors, commits the relinearization and activates the order.
// While it runs, the caller neither reorders nor relinearizes (the candidates wait, at most the
// build's updates); anything else that would change a factor already assembled (a fold, a forced
// reordering, the anchor leaving) abandons it, as does a failure of its own (its pool full, a
// pivot): the live factor never depends on it. After a failure the next reordering runs in one
// update.
//
// A template over the graph and the factor, defined and instantiated for every model in
// spread_reordering.cpp.
#include <cstdint>

#include "lslam/linear/incremental_cholesky.h"
#include "lslam/linear/index.h"
#include "lslam/solver/factorization_driver.h"
#include "lslam/solver/solver_options.h"
#include "lslam/status.h"

namespace lslam {

// Sizes: max_variables for the order and the relinearized lists, max_updates + 1 for the update
// boundaries; the driver's arrays as FactorizationArrays says.
template <class Vector>
struct SpreadReorderingArrays {
  Index* position_of = nullptr;
  Index* variable_at = nullptr;
  Index* relinearized = nullptr;
  Vector* relinearized_by = nullptr;  // each relinearized variable's step from its old point
  Index max_updates = 0;              // the updates it may take, start to swap
  Index* first_factor = nullptr;      // per update since start: its first factor...
  Index* first_variable = nullptr;    // ...and its first variable
  FactorizationArrays driver;
};

template <class Graph, class Factor>
class SpreadReordering {
 public:
  using Vector = typename Factor::Vector;

  // `factor`: the second factor (its own storage), which this unit alone changes until the swap.
  SpreadReordering(const SpreadReorderingArrays<Vector>& arrays, Graph& graph, Factor& factor,
                   const SolverOptions& options);

  bool active() const { return phase_ != Phase::Idle; }
  // Starts a build (after a committed update, no update of the graph open): the order
  // variable_at / position_of of every variable, the variables to relinearize (their steps
  // `delta[v]`). Not Ok: nothing started.
  [[nodiscard]] Status start(const Index* variable_at, const Index* position_of,
                             const Index* relinearized, Index num_relinearized,
                             const Vector* delta);
  // After an update committed while active: its factors and variables are the graph's since the
  // last note. Then spends about max_products block products: on the numeric phase, or on
  // catching up (at least two updates per call, so that it gains on the live factor); false if
  // it had to give up.
  bool advance(std::int64_t max_products);
  // The second factor holds every committed factor: the caller swaps (see the top).
  bool ready() const { return phase_ == Phase::CaughtUp; }
  // Stages the relinearization in the graph (an update of the graph must be open).
  void stageRelinearization();
  const Index* variableAt() const { return a_.variable_at; }
  const Index* positionOf() const { return a_.position_of; }
  const Index* relinearized() const { return a_.relinearized; }
  Index relinearizedCount() const { return num_relinearized_; }
  // The block products of the build's full factorization (for the ordering's work budget).
  const FactorizationStats& buildStats() const { return build_stats_; }
  Index buildBlocks() const { return build_blocks_; }  // ...and the blocks of the factor it made
  // Block products spent by the last advance() (or start()).
  std::int64_t lastProducts() const { return last_products_; }
  // Ends the build: after the swap, or abandoned.
  void finish();

 private:
  enum class Phase { Idle, Factorizing, CatchingUp, CaughtUp };
  [[nodiscard]] Status catchUpOne();

  SpreadReorderingArrays<Vector> a_;
  Graph& graph_;
  Factor& factor_;
  FactorizationDriver<Graph, Factor> driver_;
  Phase phase_ = Phase::Idle;
  Index num_relinearized_ = 0;
  Index recorded_ = 0;   // update boundaries noted (first_factor[0 .. recorded_])
  Index caught_up_ = 0;  // updates applied to the second factor
  FactorizationStats build_stats_;
  Index build_blocks_ = 0;
  std::int64_t last_products_ = 0;
};

}  // namespace lslam
