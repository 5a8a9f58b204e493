#pragma once
// Which variables are relinearized, and when (firmware_lib/README.md, Relinearization): the
// candidates a solve leaves (their delta past the threshold), the urgency and skip rules, the
// partial bar outside a reordering, and the list of variables an update stages.
//
// Each variable is measured against the bars of its kind (RelinearizationBars: its kind's
// threshold, relinearize_threshold_of_kind; the urgent and partial options are shared). A template
// over the graph and the factor, defined and instantiated for the solver's pairs in
// relinearization_policy.cpp; GraphAdapter hides how each graph relinearizes a variable.
#include <cstdint>

#include "lslam/eigen.h"
#include "lslam/linear/incremental_cholesky.h"
#include "lslam/linear/index.h"
#include "lslam/solver/graph_adapter.h"
#include "lslam/solver/solver_options.h"

namespace lslam {

// Sizes: max_variables each.
struct RelinearizationArrays {
  Index* candidates = nullptr;           // the candidates, in the order they came
  std::uint8_t* is_candidate = nullptr;  // per variable: in `candidates`
  Index* staged = nullptr;               // the variables relinearized by the update in progress
};

// The relinearization bars of one kind of variable (max-norm of its delta).
struct RelinearizationBars {
  double threshold = 0.0;  // a candidate past this
  double urgent = 0.0;     // relinearize at the next update past this
  double partial = 0.0;    // outside a reordering, take the candidates past this
};

// The candidates an update stages: past the threshold, past the partial bar, or those the partial
// bar left waiting (past the threshold, at most the partial bar).
enum class CandidateRange : std::uint8_t { PastThreshold, PastPartial, LeftWaiting };

// The block products of the last full refactorization and the factor's blocks after it.
struct FullRefactorizationCost {
  std::int64_t products = 0;
  Index blocks = 0;
};

// The block products of a full refactorization of a factor of live_blocks blocks: the last one's,
// scaled by the growth since.
inline double predictedFullProducts(const FullRefactorizationCost& last, Index live_blocks) {
  return static_cast<double>(last.products) * static_cast<double>(live_blocks) /
         static_cast<double>(last.blocks > 0 ? last.blocks : 1);
}

template <class Graph, class Factor>
class RelinearizationPolicy {
 public:
  // A variable's solution (the factor's Vector: a variable of a smaller kind in its head).
  using Vector = typename Factor::Vector;

  RelinearizationPolicy(const RelinearizationArrays& arrays, Graph& graph, const Factor& factor,
                        const SolverOptions& options);

  // The variables staged by the update in progress (stageCandidates, stageEveryMovedVariable).
  const Index* staged() const { return a_.staged; }
  // Whether the candidates are due at this update (urgent, a reordering, or relinearize_skip).
  bool due(bool reorder_now) const;
  // Whether a waiting candidate passed the urgent bar.
  bool urgent() const { return urgent_; }
  // How many relinearize-and-solve passes a solve may add while a candidate is urgent:
  // urgent_iterations, or at least converge_iterations in a graph below converge_below_variables
  // (SolverOptions), where every candidate is urgent.
  Index iterationsWithinSolve() const;
  // Whether the partial bar leaves candidates waiting that a full refactorization takes along.
  bool partialLeavesWaiting() const;
  // Stages the candidates in `range` (their points moved to lin (+) delta) and lists them in
  // staged() from position `count` on; returns the count after them.
  Index stageCandidates(CandidateRange range, const Vector* delta, Index count);
  // Stages every variable whose delta exceeds `tolerance` (Gauss-Newton); returns their count.
  Index stageEveryMovedVariable(const Vector* delta, double tolerance);
  // Whether relinearizing `relinearized` variables should refactorize every column rather than
  // recompute the affected ones in place. in_place_products() estimates the in-place work (it is
  // called only when the cheaper rules do not decide).
  template <class InPlaceProducts>
  bool relinearizationDear(Index relinearized, const FullRefactorizationCost& last_full,
                           InPlaceProducts in_place_products) const {
    if (relinearized == 0) return false;
    if (relinearizesMost(relinearized)) return true;
    if (options_.relinearize_full_cost_ratio <= 0.0 || last_full.products == 0) return false;
    const std::int64_t in_place = in_place_products();
    return static_cast<double>(in_place) >
           options_.relinearize_full_cost_ratio * fullProducts(last_full);
  }

  // Whether relinearizing `relinearized` variables would take more block products than
  // relinearize_defer_products both in place and by a full refactorization (estimated from the
  // last one, scaled by the factor's growth), and the candidates have waited fewer than
  // relinearize_defer_updates updates; in_place_products() is called only if the rest holds.
  template <class InPlaceProducts>
  bool defersRelinearization(Index relinearized, const FullRefactorizationCost& last_full,
                             InPlaceProducts in_place_products) const {
    const double bar = static_cast<double>(options_.relinearize_defer_products);
    if (relinearized == 0 || !(bar > 0.0) || last_full.products == 0) return false;
    if (updates_deferred_ >= options_.relinearize_defer_updates) return false;
    return fullProducts(last_full) > bar && static_cast<double>(in_place_products()) > bar;
  }

  // After a solve that visited the columns visited[0 .. count) (positions in variable_at's order).
  void noteCandidates(const Index* visited, Index count, const Index* variable_at);
  // After a committed update: relinearized (the candidates were due), deferred (due, and left
  // waiting for the next reordering: see defersRelinearization), or neither.
  void noteUpdate(bool relinearized, bool deferred, const Vector* delta);
  // Whether the candidates wait for a reordering already, their charge paid.
  bool deferralCharged() const { return updates_deferred_ > 0; }
  // Every candidate relinearized (Gauss-Newton).
  void clearCandidates();

 private:
  using Adapter = GraphAdapter<Graph>;
  static constexpr int kKinds = Adapter::kKinds;
  // The bars of every kind of variable, by kind.
  struct Bars {
    RelinearizationBars of[kKinds];
  };
  Bars bars() const;
  // The block products of a full refactorization now: the last one's, scaled by the growth since.
  double fullProducts(const FullRefactorizationCost& last_full) const {
    return predictedFullProducts(last_full, factor_.liveBlocks());
  }
  // Whether the graph is below converge_below_variables (SolverOptions).
  bool convergesWithinUpdates() const;
  int kindOf(Index v) const;
  // How far a variable of `kind` moved from its linearization point (max-norm over its size).
  double movedBy(int kind, const Vector& delta) const;
  bool relinearizesMost(Index relinearized) const;
  void keepWaitingCandidates(const Vector* delta);

  RelinearizationArrays a_;
  Graph& graph_;
  const Factor& factor_;
  const SolverOptions& options_;
  Index candidate_count_ = 0;
  Index updates_since_relinearization_ = 0;
  bool urgent_ = false;         // a waiting candidate passed the urgent bar
  Index updates_deferred_ = 0;  // updates the due candidates have waited (defersRelinearization)
};

}  // namespace lslam
