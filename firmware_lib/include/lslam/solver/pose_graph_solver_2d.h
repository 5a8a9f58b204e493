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
#include "lslam/solver/factorization_driver.h"
#include "lslam/solver/gauge.h"
#include "lslam/solver/id_map.h"
#include "lslam/solver/ordering_policy.h"
#include "lslam/solver/relinearization_policy.h"
#include "lslam/solver/solver_options.h"
#include "lslam/solver/update_input.h"
#include "lslam/solver/update_result.h"
#include "lslam/solver/update_validator.h"

namespace lslam {

// Everything the solver works in besides its parts' own arrays, max_poses entries each. Each array
// belongs to one unit (named after it), which alone writes it.
struct SolverArrays {
  Index* position_of[2] = {nullptr, nullptr};  // OrderingPolicy: the order, double-buffered
  Index* variable_at[2] = {nullptr, nullptr};
  Index* ordering_parent = nullptr;  // OrderingPolicy: scratch of a computed ordering's postorder
  Index* ordering_count = nullptr;
  VariableId* id_of = nullptr;        // the solver: each variable's id
  Vec3* delta = nullptr;              // the solver: the solution
  Index* visited = nullptr;           // the solver: the solve's visit list
  Index* relinearize_list = nullptr;  // RelinearizationPolicy: the candidates
  std::uint8_t* relinearize_flag = nullptr;
  Index* marked = nullptr;           // RelinearizationPolicy: the variables the update relinearizes
  Index* last_list = nullptr;        // FactorizationDriver: positions kept last by a reordered top
  std::uint8_t* in_last = nullptr;   // per position: already in last_list
  std::uint8_t* anchored = nullptr;  // UpdateValidator: a flag per added pose
};

// The solver is a facade over its units, each in its own file: UpdateValidator (the checks before
// anything changes), Gauge (the anchor), OrderingPolicy (the order and when to replace it),
// RelinearizationPolicy (which variables to relinearize, and when) and FactorizationDriver (the
// factor's update, retry and commit). It keeps the ids and the solution, and plans each update
// from the policies. A unit holds references to the parts it reads (options, graph, factor); the
// arrays of another unit are passed to it per call.
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
  const Vec3& deltaAt(Index variable) const { return delta_[variable]; }
  VariableId idAt(Index variable) const { return id_of_[variable]; }
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
  const Index* positionOf() const { return ordering_.positionOf(); }
  const Index* variableAt() const { return ordering_.variableAt(); }

 private:
  UpdatePlan planUpdate(Index new_poses, bool drop_anchor);
  Status refactor(Index new_poses, const UpdatePlan& plan, bool allow_reorder,
                  UpdateResult& result);

  // The parts (the units below hold references to them: declared first).
  SolverOptions options_;
  PoseGraph2D graph_;
  IncrementalCholesky<3> cholesky_;
  IdMap ids_;
  // The solution bookkeeping.
  VariableId* id_of_;
  Vec3* delta_;
  Index* visited_;
  // The units.
  Gauge gauge_;
  UpdateValidator validator_;
  OrderingPolicy<PoseGraph2D, IncrementalCholesky<3>> ordering_;
  RelinearizationPolicy<PoseGraph2D, IncrementalCholesky<3>> relinearization_;
  FactorizationDriver<PoseGraph2D, IncrementalCholesky<3>> driver_;
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
  Index ordering_parent_[MaxPoses];
  Index ordering_count_[MaxPoses];
  std::uint8_t anchored_[MaxPoses];

  SolverArrays solverArrays() {
    SolverArrays s;
    for (int b = 0; b < 2; ++b) {
      s.position_of[b] = position_of_[b];
      s.variable_at[b] = variable_at_[b];
    }
    s.ordering_parent = ordering_parent_;
    s.ordering_count = ordering_count_;
    s.id_of = id_of_;
    s.delta = delta_;
    s.visited = visited_;
    s.relinearize_list = relinearize_list_;
    s.relinearize_flag = relinearize_flag_;
    s.marked = marked_;
    s.last_list = last_list_;
    s.in_last = in_last_;
    s.anchored = anchored_;
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
