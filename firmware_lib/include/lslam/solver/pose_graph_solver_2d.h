#pragma once
// The incremental 2D pose-graph solver (L-SLAM): the policy on top of the pose graph, the
// incremental Cholesky factor and the COLAMD ordering.
//
// Two phases, as in OSQP: the object is built with every buffer it will ever use (capacities are
// template parameters of StaticPoseGraphSolver2D); update() and the rest never allocate. All the
// logic lives in the size-erased PoseGraphSolver2D, compiled once for every capacity.
//
// A call that returns anything but Status::Ok has changed no value: inputs are validated before
// any change, and the factorization writes to staging memory until it has succeeded (a rejected
// update may have done the solve layout a full refactorization left pending, a storage order).
//
// The gauge. Between factors fix the poses only up to a rigid motion; priors fix it. The caller's
// priors (absolute measurements: GPS, a known start) are part of the problem; when the caller has
// given none, the solver fixes the gauge itself with the anchor, a prior of information
// SolverOptions::anchor_information holding the first pose where it was given. So:
//  - a first update with a prior of the caller's gets no anchor (each of its poses must then be
//    tied to a prior through its factors);
//  - a first update without one anchors its first pose, and the anchor stays exactly as long as
//    no caller prior has come: the update that brings the first one takes the anchor out of the
//    problem (it keeps its factor slot with zero information) and, since a factor cannot be taken
//    out of L in place, reorders and refactorizes every column, once. That update must tie the
//    map to its priors (a prior on a mapped pose, or between factors from an added pose with a
//    prior to the map); otherwise it is UnconstrainedVariable, as the map would float free;
//  - chi2() sums the caller's factors only, never the anchor.
// The optimum is then always that of the caller's factors alone: with priors, theirs; without,
// the between factors' optimum in the gauge of the first pose (which the anchor, at zero error
// there, does not move).
#include <cstddef>
#include <cstdint>

#include "lslam/eigen.h"
#include "lslam/factors/pose_graph_2d.h"
#include "lslam/geometry/se2.h"
#include "lslam/linear/colamd_ordering.h"
#include "lslam/linear/incremental_cholesky.h"
#include "lslam/solver/id_map.h"
#include "lslam/solver/solver_options.h"
#include "lslam/solver/update_result.h"

namespace lslam {

struct PoseInput {
  VariableId id = 0;
  SE2 initial;
};

// A measurement: a prior on pose `from` (to is ignored), or pose `to` seen from pose `from`. A
// kind outside FactorKind is rejected (InvalidArgument). The information must be symmetric
// positive definite (checkInformation); one symmetric only to rounding is used as its symmetric
// part (symmetricPart), whichever path the update takes.
struct FactorInput {
  FactorKind kind = FactorKind::BetweenSE2;
  VariableId from = 0;
  VariableId to = 0;
  SE2 measurement;
  Mat3 information = Mat3::Identity();
};

// Everything the solver works in besides its parts' own arrays.
struct SolverArrays {
  Index* position_of[2] = {nullptr, nullptr};  // double-buffered: a reordering is staged
  Index* variable_at[2] = {nullptr, nullptr};
  VariableId* id_of = nullptr;
  Vec3* delta = nullptr;
  Index* relinearize_list = nullptr;
  std::uint8_t* relinearize_flag = nullptr;
  Index* visited = nullptr;         // the solve's visit list; also scratch of computeOrdering()
  Index* marked = nullptr;          // the variables relinearized by the update in progress
  Index* last_list = nullptr;       // positions kept last by a reordered update; also scratch
                                    // of computeOrdering()
  std::uint8_t* in_last = nullptr;  // per position: already in last_list
};

class PoseGraphSolver2D {
 public:
  PoseGraphSolver2D(const SolverArrays& arrays, const PoseGraph2DArrays& graph,
                    const CholeskyArrays<3>& factor, const ColamdArrays& ordering,
                    const IdMapArrays& ids, const SolverOptions& options);
  PoseGraphSolver2D(const PoseGraphSolver2D&) = delete;
  PoseGraphSolver2D& operator=(const PoseGraphSolver2D&) = delete;

  // Adds poses and measurements (each added pose must be tied to the graph by a measurement
  // of this call, or by a prior), updates the factor and, by default, the solution.
  [[nodiscard]] Status update(const PoseInput* poses, Index num_poses, const FactorInput* factors,
                              Index num_factors, UpdateResult* result = nullptr);
  // Back-substitution on demand (partial per options, or full).
  void solve(bool full, UpdateResult* result = nullptr);
  // Gauss-Newton to convergence: relinearize every variable that moved, refactor, solve, until the
  // largest step is below `tolerance` or `max_iterations` were done.
  [[nodiscard]] Status optimize(Index max_iterations, double tolerance,
                                UpdateResult* result = nullptr);

  // The current estimate of a pose (linearization point moved by the solution).
  [[nodiscard]] Status estimate(VariableId id, SE2* pose) const;
  SE2 estimateAt(Index variable) const;
  // The solution's step of a variable from its linearization point (estimateAt() retracts it).
  const Vec3& deltaAt(Index variable) const { return a_.delta[variable]; }
  VariableId idAt(Index variable) const { return a_.id_of[variable]; }
  // Sum of e^T Omega e over the caller's factors at the current estimate (its priors included,
  // the anchor not: see the gauge above).
  double chi2() const;

  Index poses() const { return graph_.variables(); }
  Index factors() const { return graph_.factors(); }
  Index factorBlocks() const { return cholesky_.liveBlocks(); }
  const SolverOptions& options() const { return options_; }
  void setOptions(const SolverOptions& options) { options_ = options; }
  const PoseGraph2D& graph() const { return graph_; }
  const IncrementalCholesky<3>& factor() const { return cholesky_; }
  const Index* positionOf() const { return a_.position_of[active_]; }
  const Index* variableAt() const { return a_.variable_at[active_]; }

 private:
  struct UpdatePlan {
    bool reorder_now = false;       // a full refactorization in a fresh (or the prepared) ordering
    bool prepare_ordering = false;  // COLAMD at the end of the update, for the next
    bool relinearize_now = false;   // the candidates were due (their points staged, or waiting)
    Index relinearized = 0;         // variables whose linearization points are staged
    bool refactor_fully = false;    // relinearize by a full refactorization in the current order
    bool fresh_ordering = false;    // reorder_now, in an ordering with this update's factors
    bool drop_anchor = false;       // the anchor leaves: every column refactorized, whatever else
  };

  // Also counts the caller's priors among the factors (valid or not: read only on Ok).
  Status validate(const PoseInput* poses, Index num_poses, const FactorInput* factors,
                  Index num_factors, Index* priors);
  Status checkAnchored(Index num_poses, const FactorInput* factors, Index num_factors, bool anchor,
                       bool drop_anchor) const;
  // Whether an update of num_poses poses and `priors` caller priors gets the anchor (the gauge).
  bool anchorsFirstPose(Index num_poses, Index priors) const {
    return graph_.variables() == 0 && num_poses > 0 && priors == 0;
  }
  // Whether an update with `priors` caller priors takes the anchor out (the caller's first prior).
  bool dropsAnchor(Index priors) const { return anchor_factor_ != kNoIndex && priors > 0; }
  void forgetNewIds(const PoseInput* poses, Index num_poses);
  bool wantsReorder() const;
  bool relinearizesMost(Index relinearized) const;
  bool relinearizationDear(Index new_poses, Index relinearized);
  UpdatePlan planUpdate(Index new_poses, bool drop_anchor);
  bool orderingFresh() const;
  bool likelyOutOfPool(bool full, Index relinearized, const Index* position_of) const;
  void noteOrderingWork(bool reordered, std::int64_t block_products);
  Status computeOrdering(Index* variable_at, Index* position_of);
  bool prepareOrdering();
  bool preparesOrderingAhead() const;
  void takePreparedOrdering(Index* variable_at, Index* position_of) const;
  // How far a variable's solution moved from its linearization point (max-norm), the measure of
  // every relinearization rule.
  double movedBy(Index variable) const { return a_.delta[variable].cwiseAbs().maxCoeff(); }
  Index stageCandidates(double above, double at_most, Index count);
  double partialThreshold() const;
  Index stageEveryMovedVariable(double tolerance);
  void placeAddedVariablesLast();
  Index addedLoopClosures(const Index* position_of) const;
  bool computeFreshOrdering(bool* prepared_overwritten);
  Status refactor(Index new_poses, const UpdatePlan& plan, bool allow_reorder,
                  UpdateResult& result);
  Status factorizeWithRetry(bool full, bool allow_top_reorder, Index new_columns,
                            const Index* variable_at, const Index* position_of, Index relinearized,
                            bool* top_reordered, UpdateResult& result);
  Status factorizeOnce(bool full, bool allow_top_reorder, Index new_columns,
                       const Index* variable_at, const Index* position_of, Index relinearized,
                       bool* top_reordered);
  Index collectLastColumns(const Index* position_of, Index new_columns);
  void markAffectedColumns(const Index* position_of, Index relinearized);
  bool reachesBack(const Index* position_of) const;
  // Calls visit(column) for the column of each variable of this update's factors, in `position_of`
  // (a column once per factor that holds it).
  template <class Visit>
  void visitAddedFactorColumns(const Index* position_of, Visit visit) const {
    for (Index f = first_new_factor_; f < graph_.factors(); ++f) {
      visit(position_of[graph_.firstVariable(f)]);
      const Index second = graph_.secondVariable(f);
      if (second != kNoIndex) visit(position_of[second]);
    }
  }
  bool factorReachesBack(Index f, const Index* position_of) const;
  [[nodiscard]] Status addRowsOfAddedFactors(const Index* position_of);
  void noteRelinearizationCandidates(Index visited);
  void clearRelinearizationCandidates();
  void keepWaitingCandidates();

  SolverArrays a_;
  PoseGraph2D graph_;
  IncrementalCholesky<3> cholesky_;
  ColamdOrdering ordering_;
  IdMap ids_;
  SolverOptions options_;
  int active_ = 0;
  Index relinearize_count_ = 0;
  Index marked_count_ = 0;
  Index first_new_factor_ = 0;
  Index blocks_at_last_order_ = 0;
  // The block products of the last full refactorization and the factor's blocks after it.
  std::int64_t full_products_ = 0;
  Index blocks_at_last_full_ = 0;
  Index last_columns_refactored_ = 0;
  Index largest_staging_ = 0;  // the most pool blocks an update other than a full one staged
  // Work spent on the factor's growth since the last ordering, and the budget for it (both
  // products x blocks; 0: no budget). See noteOrderingWork.
  std::int64_t excess_work_ = 0;
  std::int64_t excess_budget_ = 0;
  Index updates_since_relinearization_ = 0;
  bool relinearization_urgent_ = false;  // a waiting candidate passed the urgent threshold
  // The inactive order buffer holds a COLAMD ordering of the first `prepared_variables_`
  // variables, prepared by an earlier update for the next one (see prepare_ordering_ahead).
  bool ordering_prepared_ = false;
  Index prepared_variables_ = 0;
  Index anchor_factor_ = kNoIndex;  // the anchor's factor while it is in the problem
};

namespace detail {

// The memory of a solver, a base class so that it is built before the solver that points into it.
template <Index MaxPoses, Index MaxFactors, Index MaxFactorBlocks, bool LinearizationCache>
class SolverStorage2D {
 protected:
  StaticPoseGraph2DStorage<MaxPoses, MaxFactors, LinearizationCache> graph_storage_;
  StaticCholeskyStorage<3, MaxPoses, MaxFactorBlocks> factor_storage_;
  StaticColamdStorage<2 * MaxFactors, MaxFactors, MaxPoses> ordering_storage_;
  StaticIdMapStorage<MaxPoses> id_storage_;
  Index position_of_[2][MaxPoses];
  Index variable_at_[2][MaxPoses];
  VariableId id_of_[MaxPoses];
  Vec3 delta_[MaxPoses];
  Index relinearize_list_[MaxPoses];
  std::uint8_t relinearize_flag_[MaxPoses];
  Index visited_[MaxPoses];
  Index marked_[MaxPoses];
  Index last_list_[MaxPoses];
  std::uint8_t in_last_[MaxPoses];

  SolverArrays solverArrays() {
    SolverArrays s;
    for (int b = 0; b < 2; ++b) {
      s.position_of[b] = position_of_[b];
      s.variable_at[b] = variable_at_[b];
    }
    s.id_of = id_of_;
    s.delta = delta_;
    s.relinearize_list = relinearize_list_;
    s.relinearize_flag = relinearize_flag_;
    s.visited = visited_;
    s.marked = marked_;
    s.last_list = last_list_;
    s.in_last = in_last_;
    return s;
  }
};

}  // namespace detail

// A solver with all its memory inside: max_poses variables, max_factors measurements, and
// max_factor_blocks 3x3 blocks for the Cholesky factor (the live factor plus room for the columns
// one update rewrites; a reordering rewrites them all, so leave about twice the expected fill).
// LinearizationCache keeps every factor's linearization for the next full refactorization (268
// bytes per factor; SolverOptions::cache_linearizations turns its use off at run time).
template <Index MaxPoses, Index MaxFactors, Index MaxFactorBlocks, bool LinearizationCache = true>
class StaticPoseGraphSolver2D
    : private detail::SolverStorage2D<MaxPoses, MaxFactors, MaxFactorBlocks, LinearizationCache>,
      public PoseGraphSolver2D {
  using Storage =
      detail::SolverStorage2D<MaxPoses, MaxFactors, MaxFactorBlocks, LinearizationCache>;

 public:
  static constexpr Index max_poses = MaxPoses;
  static constexpr Index max_factors = MaxFactors;
  static constexpr Index max_factor_blocks = MaxFactorBlocks;

  explicit StaticPoseGraphSolver2D(const SolverOptions& options = SolverOptions{})
      : Storage(),
        PoseGraphSolver2D(Storage::solverArrays(), Storage::graph_storage_.arrays(),
                          Storage::factor_storage_.arrays(), Storage::ordering_storage_.arrays(),
                          Storage::id_storage_.arrays(), options) {}
};

}  // namespace lslam
