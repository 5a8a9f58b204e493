#pragma once
// Per-step instruction counts of a target run: one line per step and a summary per kind of step.
#include <cstdint>

#include "lslam/solver/update_result.h"

// What a step did, the first that applies: the very first pose; a COLAMD reordering (with a full
// refactorization); a relinearization of some variables; a loop closure (a measurement other than
// odometry); odometry only.
enum class StepKind : std::uint8_t { First, Reorder, Relinearization, LoopClosure, Odometry };

struct StepCost {
  std::uint64_t instructions = 0;   // update() + solve(), resolution 40 instructions
  StepKind kind = StepKind::First;  // 0: an array of StepCost stays in .bss
  bool along_x = false;             // starts and ends heading along +x (|theta| < pi/4)
  lslam::UpdateResult result;
};

// Prints every step, then per kind: count, min, median, mean, max; for odometry the first, last and
// spread and trend; for loop closures the worst step and least-squares fits of the count against
// the work the solver reports (block products, columns refactored, variables solved). Returns the
// odometry trend: the fitted change from the first to the last odometry step, in percent of the
// median odometry step.
double printStepCosts(const StepCost* costs, std::int32_t count);
