#pragma once
// The frame the stream programs share: the test-only perturbation switch, the host runner's
// options, the timed online step of a solver, the step loop that stops at the first rejected step,
// and the value lines of their reports.
#include <cstdint>

#include "lslam/solver/smoother.h"
#include "lslam/solver/update_result.h"
#include "lslam/status.h"
#include "lslam_target/instruction_counter.h"
#include "lslam_target/semihosting.h"
#include "target_checks.h"

namespace lslam::target {

// Built with LSLAM_TARGET_PERTURB_MEASUREMENT, a program moves one measurement by one standard
// deviation of its noise and must fail: the proof that its checks can fail. The define covers
// every file of a program (tests/target/CMakeLists.txt), so this header means one thing in it.
#ifdef LSLAM_TARGET_PERTURB_MEASUREMENT
inline constexpr bool kPerturbedBuild = true;
#else
inline constexpr bool kPerturbedBuild = false;
#endif

// Says so at the top of the report of a perturbed build (nothing otherwise).
inline void printPerturbedBuild(const char* measurement, std::int32_t index, double metres) {
  if (!kPerturbedBuild) return;
  Line()
      .text("TEST-ONLY BUILD: ")
      .text(measurement)
      .text(" ")
      .integer(index)
      .text(" moved by ")
      .fixed(metres, 2)
      .text(" m on x")
      .print();
}

// The host runner's configuration (host_sim/src/model_run.cpp, compact_stream_header.cpp): the
// model's default options, with the back-substitution called after each update rather than inside
// it.
template <class Model>
SolverOptions hostRunnerOptions() {
  SolverOptions options = defaultSolverOptions<Model>();
  options.solve_after_update = false;
  return options;
}

// One online step, timed as the host times it: update() and, if it was accepted, solve(); the
// inputs are prepared before. Returns update()'s status.
template <class Solver, class Variable, class Factor>
Status timedStep(Solver& solver, const Variable* variables, Index num_variables,
                 const Factor* factors, Index num_factors, UpdateResult* result,
                 std::uint64_t* instruction_count) {
  const std::uint64_t t0 = instructions();
  const Status status = solver.update(variables, num_variables, factors, num_factors, result);
  if (status == Status::Ok) solver.solve(false, result);
  *instruction_count = instructions() - t0;
  return status;
}

// Runs run_step(s) for s = first .. end - 1. At the first step whose status is not Ok, prints it,
// fails the check that every step is accepted (by the program's inputs and by the solver) and
// returns false.
template <class RunStep>
bool runSteps(std::int32_t first, std::int32_t end, RunStep run_step, Checks& checks) {
  for (std::int32_t s = first; s < end; ++s) {
    const Status status = run_step(s);
    if (status != Status::Ok) {
      Line().text("step ").integer(s).text(": ").text(toString(status)).print();
      checks.expect(false, "every step accepted");
      return false;
    }
  }
  return true;
}

// One line of a report: a name and a value to 15 significant digits.
inline void printValue(const char* name, double value) {
  Line().text(name).real(value, 15).print();
}

}  // namespace lslam::target
