#pragma once
// Feeds a dataset of any model (2D or 3D poses, with or without point landmarks) step by step, in
// online or file order (model_steps.h), to the firmware's Smoother<Model> and records what each
// step cost.
//
// The solver's factors have g2o's errors (factors/se2_factors.h, se3_factors.h). A factor of a
// dataset in the iSAM convention whose error differs is handed over with its information carried
// into the solver's error coordinates (solverInformation): exact for SE2 (the errors differ by a
// rotation of the translation), to first order about the measurement for SE3 (iSAM's Euler
// angles), so the solver minimises iSAM's objective up to second-order terms in the errors. chi2
// is always evaluated in the file's own convention (model_chi2.h).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"
#include "host_sim/model_steps.h"
#include "host_sim/sized_smoother.h"
#include "lslam/solver/model_inputs.h"
#include "lslam/solver/solver_options.h"
#include "lslam/solver/update_result.h"

namespace lslam::sim {

enum class StepKind { First, Odometry, LoopClosure };
const char* stepKindName(StepKind kind);

struct StepRecord {
  std::size_t index = 0;
  StepKind kind = StepKind::Odometry;
  double microseconds = 0.0;        // the whole step: update and back-substitution
  double solve_microseconds = 0.0;  // of which the back-substitution
  UpdateResult result;
};

// Where a run stands, for a progress display: called between steps, outside their clocks.
struct RunProgress {
  std::size_t steps_done = 0;
  std::size_t steps_total = 0;
  double wall_seconds = 0.0;  // since the run started (steps, conversions and reports)
  double chi2 = 0.0;          // the solver's chi2 (Smoother::chi2) at the current estimate
};

struct IncrementalOptions {
  StepOrder order = StepOrder::Online;
  int solve_every = 1;  // back-substitute after every N-th step (and after the last)
  SolverOptions solver;
  // If set, called after a step once progress_interval_s has passed since the last call (and
  // after the last step). Each call evaluates the solver's chi2: O(factors).
  std::function<void(const RunProgress&)> progress;
  double progress_interval_s = 0.5;
  // The Cholesky factor's block pool; 0: modelCapacities' rule.
  Index factor_blocks = 0;
  // > 0: a CompactPoseGraph of at most this many nodes (online order; pose graphs, and point
  // landmarks observed as positions), every pose of the file a place on them; 0: full smoothing.
  Index max_poses = 0;
};

// What a compact run (IncrementalOptions::max_poses) did besides its steps.
struct CompactStats {
  Index nodes = 0;        // poses the solver holds
  Index folded = 0;       // loop closures merged into a factor already there
  Index dropped = 0;      // loop closures that found no room
  Index relocalized = 0;  // steps that moved the current pose to a loop closure's node
};

// The factors a compact run's solver holds per node: on the grid worlds the block pool binds
// first (CompactPoseGraph::kNewPairPoolShare), and 4 or 16 per node run the same.
inline constexpr Index kCompactFactorsPerNode = 4;

struct ModelRun {
  ModelEstimate initial;   // each variable's value when it was introduced (the batch starts here)
  ModelEstimate estimate;  // the solver's final estimate
  std::vector<StepRecord> steps;
  double total_seconds = 0.0;     // sum of the steps' time (no file reading, no batch)
  std::size_t solver_bytes = 0;   // SizedSmoother::bytes()
  SmootherCapacities capacities;  // the solver's
  Index poses = 0;
  Index landmarks = 0;
  Index factors = 0;             // the solver's, the anchor included
  Index factor_blocks = 0;       // live blocks of L at the end
  Index peak_factor_blocks = 0;  // ... and the most after any step
  Index reorders = 0;
  VariableKey anchor{VariableRole::Pose, -1};  // the pose the solver anchors (id -1: none)
  std::string gauge_note;  // "file:line: FIX ..." when the file fixes another pose (else empty)
  std::optional<CompactStats> compact;  // a compact run's (max_poses > 0)
};

// Runs `d` in options.order (model_steps.h). The solver anchors the first step's pose (step 0's)
// with a prior and has no FIX: a FIX of one other pose only moves the gauge and is noted in
// gauge_note, a second fixed pose throws DatasetError at its line. If the solver rejects a step,
// throws DatasetError at the line of the step's first factor, naming the step, its pose, the lines
// of its factors and the solver's status. A dataset beyond the solver's capacity is such a
// rejection (Status::CapacityExhausted; the message names the capacity). Whatever buildModelSteps
// throws.
//
// The solver is a SizedSmoother of modelCapacities(d, options.order, options.factor_blocks),
// allocated and zeroed before the first step.
ModelRun runModelIncremental(const ModelDataset& d, const IncrementalOptions& options);

// The capacities runModelIncremental gives the solver of `d` fed in `order`: exactly the poses,
// landmarks and factors its steps add (and the anchor prior) and their factor values; a block pool
// of `factor_blocks`, or if 0 a margin (its evidence in model_run.cpp) times
// batchFactorBlocks(d) (at least the variables);
// block values for the largest block size. With spread_above_products > 0
// (SolverOptions::spread_reorder_products), a second factor of the same pool for spread
// reorderings if the batch factorization of the whole dataset takes more block products than
// that (a smaller one never spreads).
SmootherCapacities modelCapacities(const ModelDataset& d, StepOrder order, Index factor_blocks = 0,
                                   std::int64_t spread_above_products = 0);

// The capacities of a compact run's solver (IncrementalOptions::max_poses): max_poses poses (at
// most the file's), every landmark of the file, kCompactFactorsPerNode factors per pose and per
// landmark, and a block pool of `factor_blocks`
// or, if 0, modelCapacities' margin times the batch fill of the graph of the first max_poses
// online steps (the run's full-smoothing part; CompactPoseGraph adds new pairs up to
// kNewPairPoolShare of the pool, about 1.6 times that fill).
SmootherCapacities compactCapacities(const ModelDataset& d, Index max_poses, Index factor_blocks);

// The nonzero blocks (variable x variable, the diagonal included) of the Cholesky factor of the
// whole dataset's normal equations under a COLAMD ordering of its block pattern, and the block
// products of factorizing it (s (s - 1) / 2 per column of s blocks, as the solver counts them).
struct BatchFill {
  std::int64_t blocks = 0;
  std::int64_t products = 0;
};
BatchFill batchFactorFill(const ModelDataset& d);
std::int64_t batchFactorBlocks(const ModelDataset& d);

// The information of `f` in the solver's error coordinates: ModelFactor::information itself for
// the G2o convention and for factors whose error is the same in both conventions; for BetweenSE2
// and PriorSE2 in the Isam convention J^T Omega J with J = blockdiag(R(z_theta), 1) (exact); for
// BetweenSE3 and PriorSE3 in the Isam convention J^T Omega J with J the derivative of iSAM's
// error with respect to g2o's at zero error, by central differences about the measurement.
Eigen::MatrixXd solverInformation(const ModelDataset& d, const ModelFactor& f);

// The solver's inputs for a variable (its value in the kind's parameters; an SE3 quaternion is
// normalised, the solver takes unit ones) and for a factor of `d` (its measurement, and
// solverInformation), as runModelIncremental hands them over. Compiled for Slam2D, Slam3D,
// PoseSlam2D and PoseSlam3D; std::invalid_argument for a kind the model has not.
template <class Model>
ModelVariableInput<Model> modelVariableInput(const VariableKey& key, const Eigen::VectorXd& value);
template <class Model>
ModelFactorInput<Model> modelFactorInput(const ModelDataset& d, const ModelFactor& f);

// The solver options the model `d` runs on start from (lslam::defaultSolverOptions of the model
// runModelIncremental picks: Slam2D, Slam3D, PoseSlam2D or PoseSlam3D), with
// withRangeBearingObservations if a factor is RangeBearing2.
SolverOptions defaultModelOptions(const ModelDataset& d);

// Whether a factor or a vertex of `d` names a landmark.
bool hasLandmarks(const ModelDataset& d);

// Whether `d` is a 2D pose graph (only SE2 poses and BetweenSE2/PriorSE2 factors): the PoseSlam2D
// model.
bool isPoseGraph2D(const ModelDataset& d);

}  // namespace lslam::sim
