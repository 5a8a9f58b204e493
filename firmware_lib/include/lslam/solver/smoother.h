#pragma once
// The incremental solver of any model (models/pose_slam_2d.h, slam_2d.h, slam_3d.h,
// pose_slam_3d.h): the policy on top of a FactorGraph<Model>, the incremental Cholesky factor of
// the model's block sizes and the COLAMD ordering.
//
// Two phases, as in OSQP: StaticSmoother holds every array (capacities per kind as template
// parameters); Smoother<Model> works on pointers and counts and never allocates. It is compiled
// once per model in smoother.cpp, for every capacity.
//
// A call that returns anything but Status::Ok has changed no value: the inputs are validated
// before any change, and the factorization writes to staging memory until it has succeeded (a
// rejected update may have done the solve layout a full refactorization left pending, a storage
// order).
//
// Variables and ids. A ModelVariableInput names its kind and an id in that kind's id space (pose 4
// and landmark 4 are two variables); a ModelFactorInput names its kind and its variables' ids in
// the order of its kind's Variables. Each added variable must be held by the update's factors
// (ModelUpdateValidator): a landmark by an observation or a prior, a pose by a between factor to a
// held pose or a prior (not by landmarks alone).
//
// The gauge. Between factors fix the poses only up to a rigid motion; priors fix it. The caller's
// priors (absolute measurements: GPS, a known start) are part of the problem; when the caller has
// given none, the solver fixes the gauge itself with the anchor, a Model::PosePrior of information
// Identity * SolverOptions::anchor_information holding the first pose input where it was given:
//  - a first update with a pose prior of the caller's gets no anchor (each of its poses must then
//    be tied to a prior through its factors);
//  - a first update without one anchors its first pose, and the anchor stays exactly as long as
//    no caller prior has come: the update that brings the first one takes the anchor out of the
//    problem (disablePrior: it keeps its factor slot with zero information) and, since a factor
//    cannot be taken out of L in place, reorders and refactorizes every column, once. That update
//    must tie the map to its priors (a prior on a mapped pose, or between factors from an added
//    pose with a prior to the map); otherwise it is UnconstrainedVariable, as the map would be
//    held by nothing;
//  - chi2() sums the caller's factors only, never the anchor.
// The optimum is then always that of the caller's factors alone: with priors, theirs; without,
// theirs in the gauge of the first pose (which the anchor, at zero error there, does not move).
//
// Relinearization thresholds per kind (SolverOptions::relinearize_threshold_of_kind, max-norm of a
// variable's delta). The defaults {0, 0} take relinearize_threshold (0.01) for both kinds:
//  - Slam2D: pose (x, y in meters, theta in radians) 0.01; landmark (x, y in meters) 0.01;
//  - Slam3D: pose (body-frame translation in meters, rotation vector in radians) 0.01; landmark
//    (x, y, z in meters) 0.01.
// A map in other units (millimetres, kilometres) sets the landmark's bar to its own scale.
#include <algorithm>
#include <cstdint>
#include <type_traits>

#include "lslam/eigen.h"
#include "lslam/factors/merged_measurement.h"
#include "lslam/graph/factor_graph.h"
#include "lslam/linear/colamd_ordering.h"
#include "lslam/linear/incremental_cholesky.h"
#include "lslam/models/model_traits.h"
#include "lslam/solver/factorization_driver.h"
#include "lslam/solver/gauge.h"
#include "lslam/solver/id_map.h"
#include "lslam/solver/model_inputs.h"
#include "lslam/solver/model_update_validator.h"
#include "lslam/solver/ordering_policy.h"
#include "lslam/solver/relinearization_policy.h"
#include "lslam/solver/solver_options.h"
#include "lslam/solver/spread_reordering.h"
#include "lslam/solver/update_result.h"

namespace lslam {

// The options a smoother of a model starts from (StaticSmoother's default): SolverOptions{}, whose
// values were tuned on 2D pose graphs, except the urgent relinearization bar for models with
// landmarks or SE3 poses: 0.3 for Slam2D, 0.8 for a model of SE3 poses. Loop closures and
// re-observations routinely move a pose by 0.1 to 0.5 (m or rad) in its first solves; at 0.1 most
// updates relinearize (sphere2500: 1,700 of 2,500, 7x the time of 0.5; victoriaPark 1.3x the time
// of 0.3) for an estimate a few thousandths of a percent nearer the optimum. The SE3 bar trades
// time for the last hundredths of a percent: sphere2500 takes 1.3x the time at 0.5 and ends
// 0.004 % above the optimum, against 0.023 % at 0.8; the other 3D sets end the same either way. A
// 2D pose graph keeps 0.1: past it, its estimate lags the optimum by millimetres
// (manhattan_world_500 at 0.3: 4 mm).
template <class Model>
SolverOptions defaultSolverOptions() {
  SolverOptions options;
  const bool se3 = std::is_same_v<TypeAtT<0, typename Model::Variables>, SE3>;
  const bool landmarks = Model::Variables::kSize > 1;
  if (se3) options.relinearize_urgent_threshold = 0.8;
  if (!se3 && landmarks) options.relinearize_urgent_threshold = 0.3;
  return options;
}

// The options for a stream with range-bearing observations (RangeBearingSE2Factor), from `options`:
// the bearing's derivative grows as 1 / range, so a step of a few centimetres moves a near
// landmark's linearization point far, and a step taken there lags the optimum (simulated grid2d
// worlds: 0.1-0.7 % above it at the Slam2D defaults). A tighter urgent bar, and re-solving within
// the update while a candidate passes it, bring it within 0.02 % (either alone leaves some seeds
// above 0.1 %), at about three times the time.
inline SolverOptions withRangeBearingObservations(SolverOptions options) {
  options.relinearize_urgent_threshold = std::min(options.relinearize_urgent_threshold, 0.05);
  options.urgent_iterations = std::max<Index>(options.urgent_iterations, 4);
  return options;
}

namespace detail {

// IncrementalCholesky and CholeskyArrays of a BlockSizes<...>.
template <class Sizes>
struct CholeskyTypesOf;
template <int... S>
struct CholeskyTypesOf<BlockSizes<S...>> {
  using Factor = IncrementalCholesky<S...>;
  using Arrays = CholeskyArrays<S...>;
};

}  // namespace detail

// Everything the smoother works in besides its parts' own arrays: max_variables entries each
// (the sum of the per-kind capacities), held: max_variables + 1. Each array belongs to one unit.
template <class Model>
struct SmootherArrays {
  using Vector = Eigen::Matrix<double, ModelBlockSizes<Model>::kMax, 1>;
  Index* position_of[2] = {nullptr, nullptr};  // OrderingPolicy: the order, double-buffered
  Index* variable_at[2] = {nullptr, nullptr};
  Index* ordering_parent = nullptr;  // OrderingPolicy: scratch of a computed ordering's postorder
  Index* ordering_count = nullptr;
  VariableId* id_of = nullptr;        // the smoother: each variable's id (in its kind's id space)
  Vector* delta = nullptr;            // the smoother: the solution (a smaller kind in the head)
  Index* visited = nullptr;           // the smoother: the solve's visit list
  Index* relinearize_list = nullptr;  // RelinearizationPolicy: the candidates
  std::uint8_t* relinearize_flag = nullptr;
  Index* marked = nullptr;          // RelinearizationPolicy: the variables the update relinearizes
  Index* last_list = nullptr;       // FactorizationDriver: positions kept last by a reordered top
  std::uint8_t* in_last = nullptr;  // per position: already in last_list
  std::uint8_t* held = nullptr;     // ModelUpdateValidator: max_variables + 1 flags
};

// The memory of a spread reordering (SolverOptions::spread_reorder_products): a second factor of
// the live one's capacities and the unit's arrays (SpreadReorderingArrays).
template <class Model>
struct SpreadArrays {
  typename detail::CholeskyTypesOf<ModelBlockSizes<Model>>::Arrays factor;
  SpreadReorderingArrays<typename SmootherArrays<Model>::Vector> reordering;
};

template <class Model>
class Smoother {
 public:
  using Graph = FactorGraph<Model>;
  using Factor = typename detail::CholeskyTypesOf<ModelBlockSizes<Model>>::Factor;
  using FactorArrays = typename detail::CholeskyTypesOf<ModelBlockSizes<Model>>::Arrays;
  using Vector = typename Factor::Vector;
  using Variable = ModelVariableInput<Model>;
  using Measurement = ModelFactorInput<Model>;
  using Pose = TypeAtT<0, typename Model::Variables>;
  static constexpr int kKinds = Model::Variables::kSize;
  static_assert(kKinds == 1 || kKinds == 2, "a pose kind and at most one landmark kind");

  // ids: one map per variable kind (kKinds of them). The factor's variable_kind is set here to the
  // graph's kinds.
  // `spread`: the memory of a spread reordering, or none (reorderings then run in one update).
  Smoother(const SmootherArrays<Model>& arrays, const FactorGraphArrays& graph,
           const FactorArrays& factor, const ColamdArrays& ordering, const IdMapArrays* ids,
           const SolverOptions& options, const SpreadArrays<Model>* spread = nullptr);
  Smoother(const Smoother&) = delete;
  Smoother& operator=(const Smoother&) = delete;

  // Adds variables and measurements (each added variable held by this call's factors, see above),
  // updates the factor and, by default, the solution.
  [[nodiscard]] Status update(const Variable* variables, Index num_variables,
                              const Measurement* factors, Index num_factors,
                              UpdateResult* result = nullptr);
  // A repeated measurement of a pair that factor `into` already joins: update() adds it (a row
  // update of L, as any loop closure), then the graph stores it merged into `into`
  // (mergedMeasurement) instead of as a factor of its own, so that repeated loop closures between
  // the same poses take no more factor memory. `into` must be a factor of the caller's of the same
  // kind on the same ids in the same order, a between factor of two poses or the model's point
  // observation (Model::PointObservation) (else InvalidArgument, nothing changed).
  // What it trades: L keeps both shares until the next full refactorization, while the graph's
  // merged factor differs from their sum at second order in the measurements' spread; a
  // relinearization subtracts the merged factor's share, so that difference stays in L until a
  // reordering rebuilds it from the graph.
  [[nodiscard]] Status addFolded(const Measurement& factor, Index into,
                                 UpdateResult* result = nullptr);
  // An update without inputs that reorders now: every column refactorized in a fresh COLAMD order
  // (or the one prepared for the next update), the waiting candidates relinearized with them,
  // then solved as an update is. For a caller that needs the fill back (CompactPoseGraph): the
  // incremental order fills more as the graph grows. CapacityExhausted when the pool cannot hold
  // the reordered factor beside the live one, WorkspaceExhausted when COLAMD's workspace cannot
  // hold the graph: nothing changed (as for a rejected update).
  [[nodiscard]] Status reorder(UpdateResult* result = nullptr);
  // Back-substitution on demand (partial per options, or full), then up to
  // SolverOptions::urgent_iterations relinearizations of urgent candidates, each solved again.
  void solve(bool full, UpdateResult* result = nullptr);
  // Gauss-Newton to convergence: relinearize every variable that moved, refactor, solve, until the
  // largest step is below `tolerance` or `max_iterations` were done.
  [[nodiscard]] Status optimize(Index max_iterations, double tolerance,
                                UpdateResult* result = nullptr);

  // The current estimate (lin (+) delta) of variable `id` of kind V, in V's id space.
  template <class V>
  [[nodiscard]] Status estimate(VariableId id, V* out) const {
    if (out == nullptr) return Status::InvalidArgument;
    const Index v = ids_[kVariableKind<Model, V>].find(id);
    if (v == kNoIndex) return Status::UnknownVariable;
    *out = estimateAt<V>(v);
    return Status::Ok;
  }
  // The graph index of variable `id` of kind V, or kNoIndex.
  template <class V>
  Index indexOf(VariableId id) const {
    return ids_[kVariableKind<Model, V>].find(id);
  }
  // The estimate of graph variable `variable` (of kind V).
  template <class V>
  V estimateAt(Index variable) const {
    return graph_.template estimate<V>(variable, delta_[variable]);
  }
  // The solution's step of a variable from its linearization point (its kind's size in the head).
  const Vector& deltaAt(Index variable) const { return delta_[variable]; }
  VariableId idAt(Index variable) const { return id_of_[variable]; }
  int kindAt(Index variable) const { return graph_.variableKind(variable); }
  // Sum of e^T Omega e over the caller's factors at the current estimate (the anchor not).
  double chi2() const;

  Index variables() const { return graph_.variables(); }
  Index variablesOfKind(int kind) const { return graph_.variablesOfKind(kind); }
  Index poses() const { return graph_.variablesOfKind(0); }
  Index landmarks() const { return kKinds > 1 ? graph_.variablesOfKind(kKinds - 1) : 0; }
  Index factors() const { return graph_.factors(); }
  Index factorBlocks() const { return cholesky_.liveBlocks(); }
  // The live blocks right after the last reordering (0 before the first).
  Index blocksAtLastOrder() const { return ordering_.blocksAtLastOrder(); }
  // The solver's anchor factor while it is in the problem, else kNoIndex.
  Index anchorFactor() const { return gauge_.anchorFactor(); }
  const SolverOptions& options() const { return options_; }
  void setOptions(const SolverOptions& options) { options_ = options; }
  const Graph& graph() const { return graph_; }
  const Factor& factor() const { return cholesky_; }
  const Index* positionOf() const { return ordering_.positionOf(); }
  const Index* variableAt() const { return ordering_.variableAt(); }

 private:
  UpdatePlan planUpdate(Index new_variables, bool drop_anchor, bool force_reorder = false);
  Status refactor(Index new_variables, const UpdatePlan& plan, bool allow_reorder,
                  UpdateResult& result);
  void addInputs(const Variable* variables, Index num_variables, const Measurement* factors,
                 Index num_factors);
  void backSubstitute(bool full, UpdateResult* result);
  // An update without inputs that relinearizes the due candidates.
  Status relinearizeCandidates(UpdateResult& result);
  // The spread reordering after a committed update (see SpreadReordering): started, advanced,
  // swapped in, or abandoned as the plan says.
  void stepSpread(const UpdatePlan& plan, UpdateResult& result);
  void swapInSpread(UpdateResult& result);
  bool spreadActive() const { return spread_ != nullptr && spread_->active(); }
  void abandonSpread() {
    if (spreadActive()) spread_->finish();
  }

  // The parts (the units below hold references to them: declared first).
  SolverOptions options_;
  Graph graph_;
  Factor cholesky_;
  IdMap ids_[2];  // per kind (a model of one kind leaves the second empty)
  IdMap* id_maps_[2];
  // The solution bookkeeping.
  VariableId* id_of_;
  Vector* delta_;
  Index* visited_;
  // The units.
  Gauge gauge_;
  ModelUpdateValidator<Model> validator_;
  OrderingPolicy<Graph, Factor> ordering_;
  RelinearizationPolicy<Graph, Factor> relinearization_;
  FactorizationDriver<Graph, Factor> driver_;
  // The spread reordering and its second factor, built in place when the memory is given.
  using Spread = SpreadReordering<Graph, Factor>;
  // The updates a spread reordering's numeric phase takes at most: beyond, each takes a larger
  // share (a longer build lets the live factor fill more, and leaves more to catch up).
  static constexpr std::int64_t kSpreadUpdates = 16;
  Factor* spare_ = nullptr;
  Spread* spread_ = nullptr;
  std::int64_t spread_share_ = 0;  // the block products of each update's share of the build
  // The last spread reordering failed or was abandoned: the next reordering runs in one update.
  bool spread_failed_ = false;
  bool spread_in_current_order_ = false;  // the build relinearizes in the current order
  alignas(Factor) unsigned char spare_storage_[sizeof(Factor)];
  alignas(Spread) unsigned char spread_storage_[sizeof(Spread)];
};

namespace detail {

// The memory of a spread reordering (SpreadArrays): a second factor of the live one's capacities,
// the unit's arrays, and the updates a reordering may take (MaxUpdates); MaxUpdates 0: none.
template <class Model, Index MaxVariables, Index MaxFactorBlocks, Index MaxFactorBlockValues,
          Index MaxUpdates>
class SpreadStorage {
  using Vector = typename SmootherArrays<Model>::Vector;

 public:
  const SpreadArrays<Model>* arrays() {
    SpreadArrays<Model>& a = arrays_;
    a.factor = factor_storage_.arrays();
    SpreadReorderingArrays<Vector>& r = a.reordering;
    r.position_of = position_of_;
    r.variable_at = variable_at_;
    r.relinearized = relinearized_;
    r.relinearized_by = relinearized_by_;
    r.max_updates = MaxUpdates;
    r.first_factor = first_factor_;
    r.first_variable = first_variable_;
    r.driver.last_list = last_list_;
    r.driver.in_last = in_last_;
    return &arrays_;
  }

 private:
  StaticCholeskyStorageFor<ModelBlockSizes<Model>, MaxVariables, MaxFactorBlocks,
                           MaxFactorBlockValues>
      factor_storage_;
  Index position_of_[MaxVariables];
  Index variable_at_[MaxVariables];
  Index relinearized_[MaxVariables];
  Vector relinearized_by_[MaxVariables];
  Index first_factor_[MaxUpdates + 1];
  Index first_variable_[MaxUpdates + 1];
  Index last_list_[MaxVariables];
  std::uint8_t in_last_[MaxVariables];
  SpreadArrays<Model> arrays_;
};

template <class Model, Index MaxVariables, Index MaxFactorBlocks, Index MaxFactorBlockValues>
class SpreadStorage<Model, MaxVariables, MaxFactorBlocks, MaxFactorBlockValues, 0> {
 public:
  const SpreadArrays<Model>* arrays() { return nullptr; }
};

// The memory of a smoother, a base class so that it is built before the smoother that points into
// it.
template <class Model, Index MaxPoses, Index MaxLandmarks, Index MaxFactors, Index MaxFactorValues,
          Index MaxFactorBlocks, Index MaxFactorBlockValues, Index MaxSpreadUpdates>
class SmootherStorage {
 protected:
  static constexpr Index kMaxVariables = MaxPoses + MaxLandmarks;
  using Vector = typename SmootherArrays<Model>::Vector;

  StaticFactorGraphStorage<Model, MaxPoses, MaxLandmarks, MaxFactors, MaxFactorValues>
      graph_storage_;
  StaticCholeskyStorageFor<ModelBlockSizes<Model>, kMaxVariables, MaxFactorBlocks,
                           MaxFactorBlockValues>
      factor_storage_;
  StaticColamdStorage<2 * MaxFactors, MaxFactors, kMaxVariables> ordering_storage_;
  SpreadStorage<Model, kMaxVariables, MaxFactorBlocks, MaxFactorBlockValues, MaxSpreadUpdates>
      spread_storage_;
  StaticIdMapStorage<MaxPoses> pose_id_storage_;
  StaticIdMapStorage<(MaxLandmarks > 0 ? MaxLandmarks : 1)> landmark_id_storage_;
  Index position_of_[2][kMaxVariables];
  Index variable_at_[2][kMaxVariables];
  VariableId id_of_[kMaxVariables];
  Vector delta_[kMaxVariables];
  Index relinearize_list_[kMaxVariables];
  std::uint8_t relinearize_flag_[kMaxVariables];
  Index visited_[kMaxVariables];
  Index marked_[kMaxVariables];
  Index last_list_[kMaxVariables];
  std::uint8_t in_last_[kMaxVariables];
  Index ordering_parent_[kMaxVariables];
  Index ordering_count_[kMaxVariables];
  std::uint8_t held_[kMaxVariables + 1];
  IdMapArrays id_arrays_[2];

  SmootherArrays<Model> smootherArrays() {
    SmootherArrays<Model> s;
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
    s.held = held_;
    return s;
  }
  const IdMapArrays* idArrays() {
    id_arrays_[0] = pose_id_storage_.arrays();
    id_arrays_[1] = landmark_id_storage_.arrays();
    return id_arrays_;
  }
};

}  // namespace detail

// A smoother with all its memory inside: MaxPoses variables of the model's pose kind and
// MaxLandmarks of its landmark kind; MaxFactors measurements (the anchor takes one) and
// MaxFactorValues doubles for them (kFactorValues<F> each: SE2 between 12, SE3 between 43, a 2D
// landmark observation 6, a 3D one 12); MaxFactorBlocks blocks for the Cholesky factor (the live
// factor plus room for the columns one update rewrites; leave about twice the expected fill) and
// MaxFactorBlockValues doubles for their values (a block of rows r and columns c takes r * c:
// MaxFactorBlocks * kMax^2 always suffices). MaxSpreadUpdates > 0: a second factor of the same
// pool for reorderings spread over at most that many updates (SolverOptions::
// spread_reorder_products), which about doubles the factor's memory.
template <class Model, Index MaxPoses, Index MaxLandmarks, Index MaxFactors, Index MaxFactorValues,
          Index MaxFactorBlocks, Index MaxFactorBlockValues, Index MaxSpreadUpdates = 0>
class StaticSmoother
    : private detail::SmootherStorage<Model, MaxPoses, MaxLandmarks, MaxFactors, MaxFactorValues,
                                      MaxFactorBlocks, MaxFactorBlockValues, MaxSpreadUpdates>,
      public Smoother<Model> {
  using Storage =
      detail::SmootherStorage<Model, MaxPoses, MaxLandmarks, MaxFactors, MaxFactorValues,
                              MaxFactorBlocks, MaxFactorBlockValues, MaxSpreadUpdates>;

 public:
  static constexpr Index max_poses = MaxPoses;
  static constexpr Index max_landmarks = MaxLandmarks;
  static constexpr Index max_factors = MaxFactors;
  static constexpr Index max_factor_values = MaxFactorValues;
  static constexpr Index max_factor_blocks = MaxFactorBlocks;
  static constexpr Index max_factor_block_values = MaxFactorBlockValues;

  explicit StaticSmoother(const SolverOptions& options = defaultSolverOptions<Model>())
      : Storage(),
        Smoother<Model>(Storage::smootherArrays(), Storage::graph_storage_.arrays(),
                        Storage::factor_storage_.arrays(), Storage::ordering_storage_.arrays(),
                        Storage::idArrays(), options, Storage::spread_storage_.arrays()) {}
};

}  // namespace lslam
