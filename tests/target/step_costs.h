#pragma once
// Per-step instruction counts of a target run: one line per step and a summary per kind of step.
#include <cstdint>

#include "lslam/solver/update_result.h"

// What a step did, the first that applies: the very first pose; a COLAMD reordering (with a full
// refactorization); a relinearization of some variables; a loop closure (a measurement other than
// odometry); a landmark observation (a point observation, no loop closure); odometry only.
// A step that prepared an ordering, or laid the factor out after a full refactorization, is
// counted apart: that maintenance comes on top of whatever else the step did.
enum class StepKind : std::uint8_t {
  First,
  Reorder,
  PrepareOrdering,
  Relinearization,
  Layout,
  LoopClosure,
  LandmarkObservation,
  Odometry
};

struct StepCost {
  std::uint64_t instructions = 0;   // update() + solve(), resolution kInstructionsPerTick
  StepKind kind = StepKind::First;  // 0: an array of StepCost stays in .bss
  lslam::UpdateResult result;
};

// The kind of an online step, from what the stream says it measures and what the solver reports.
StepKind stepKind(bool first, bool loop_closure, bool landmark_observation,
                  const lslam::UpdateResult& result);

// How constant the odometry steps are, in percent.
struct OdometryFigures {
  double first_to_last = 0.0;  // (last - first) / first
  double spread = 0.0;         // (max - min) / min over the odometry steps of the same work
  double trend = 0.0;          // least-squares line, first to last step, over the median
};

// Prints every step, then per kind: count, min, median, mean, max; for odometry the first, last,
// spread and trend; for loop closures the worst step and least-squares fits of the count against
// the work the solver reports (block products, columns refactored, variables solved).
OdometryFigures printStepCosts(const StepCost* costs, std::int32_t count);
