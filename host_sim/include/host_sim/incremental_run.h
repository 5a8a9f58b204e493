#pragma once
// Feeds a dataset, step by step, to the firmware's incremental solver and records what each step
// cost. This is the host's side of the firmware: it owns the solver object (one big static-capacity
// object, allocated once before the first step) and converts between file ids and solver inputs.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "host_sim/chi2.h"
#include "host_sim/dataset.h"
#include "host_sim/steps.h"
#include "lslam/solver/pose_graph_solver_2d.h"

namespace lslam::sim {

// The capacity the host tools use: enough for every 2D dataset in ../shared/datasets.
inline constexpr Index kHostMaxPoses = 16384;
inline constexpr Index kHostMaxFactors = 32768;
inline constexpr Index kHostMaxFactorBlocks = 1 << 21;
using HostSolver2D = StaticPoseGraphSolver2D<kHostMaxPoses, kHostMaxFactors, kHostMaxFactorBlocks>;

enum class StepKind { First, Odometry, LoopClosure };
const char* stepKindName(StepKind kind);

struct StepRecord {
  std::size_t index = 0;
  StepKind kind = StepKind::Odometry;
  double microseconds = 0.0;        // the whole step: update and back-substitution
  double solve_microseconds = 0.0;  // of which the back-substitution
  UpdateResult result;
};

struct IncrementalOptions {
  StepOrder order = StepOrder::Online;
  int solve_every = 1;  // back-substitute after every N-th step (and after the last)
  SolverOptions solver;
};

struct IncrementalRun {
  Estimate2D initial;   // each pose's value when it was introduced (the batch starts from here)
  Estimate2D estimate;  // the solver's final estimate
  std::vector<StepRecord> steps;
  double total_seconds = 0.0;  // sum of the steps' time (no file reading, no batch)
  std::size_t solver_bytes = 0;
  Index factor_blocks = 0;
  Index reorders = 0;
  std::int64_t anchor = -1;  // the pose the solver anchors: step 0's pose (-1: no steps)
  std::string gauge_note;    // "file:line: FIX ..." when the file fixes another pose (else empty)
};

// The solver anchors the first step's pose with a prior (SolverOptions::anchor_information) and
// has no FIX: a FIX of one other pose only moves the gauge, and is reported in gauge_note; FIX
// lines naming two different poses throw DatasetError at the line naming the second. If the solver
// rejects a step, throws DatasetError at the line of the step's first edge (the reason names the
// step, its pose, the lines of its edges and the solver's status). Whatever buildSteps throws.
IncrementalRun runIncremental(const Dataset2D& dataset, const IncrementalOptions& options);

// The solver's inputs for one edge.
FactorInput toFactorInput(const Edge2D& edge);

}  // namespace lslam::sim
