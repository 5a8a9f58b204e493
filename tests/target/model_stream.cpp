// The 3D landmark stream (data/landmarks_3d_300_stream.h, generated on the host) fed step by step
// through the generic solver StaticSmoother<Slam3D, ...> with the host runner's configuration, on
// the Cortex-M7 under QEMU. Checks the result against the host's numbers, prints the instruction
// count of every step and a summary per kind of step. The exit status is the test result.
//
// Built twice: as is (must pass), and perturbed (stream_runner.h: must fail).
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "landmarks_3d_300_stream.h"
#include "lslam/models/slam_3d.h"
#include "lslam/solver/smoother.h"
#include "lslam_target/instruction_counter.h"
#include "step_costs.h"
#include "stream_runner.h"
#include "target_checks.h"

namespace {

namespace stream = lslam::stream::landmarks_3d_300;
using lslam::Slam3D;
using lslam::target::kPerturbedBuild;
using lslam::target::Line;
using lslam::target::printValue;
using Variable = lslam::ModelVariableInput<Slam3D>;
using Measurement = lslam::ModelFactorInput<Slam3D>;

constexpr std::int32_t kPerturbedFactor = stream::kNumFactors / 2;
constexpr double kPerturbation = 0.05;  // metres on x: the generator's sigma of translations

// Capacity for this stream (300 poses, 31 landmarks, 651 measurements + the anchor prior; factor
// values 43 per SE3 between or prior, 12 per observation). The pool holds the largest live factor
// (2,247 blocks on the host) twice over, as a reordering stages a whole new factor; block values
// at the largest block (6x6).
constexpr lslam::Index kMaxBlocks = 4608;
using Solver = lslam::StaticSmoother<Slam3D, 320, 48, 704, 19456, kMaxBlocks, kMaxBlocks * 36>;

Solver g_solver(lslam::target::hostRunnerOptions<Slam3D>());  // in .bss
StepCost g_costs[stream::kNumSteps];

Variable variableInput(const lslam::stream::ModelStreamVariable& v) {
  Variable in;
  in.kind = static_cast<std::uint8_t>(v.kind == 0 ? lslam::kVariableKind<Slam3D, lslam::SE3>
                                                  : lslam::kVariableKind<Slam3D, lslam::Point3>);
  in.id = v.id;
  for (int k = 0; k < Variable::kValueSize; ++k) in.value[k] = v.value[k];
  return in;
}

// The inputs as the host built them (with the test-only corruption, if built in); the information
// mirrored from its upper triangle, column-major.
Measurement factorInput(std::int32_t factor) {
  const lslam::stream::ModelStreamFactor& f = stream::kFactors[factor];
  const bool between = f.kind == 0;
  Measurement in;
  in.kind = static_cast<std::uint8_t>(
      between ? lslam::kFactorKind<Slam3D, lslam::BetweenSE3Factor>
              : lslam::kFactorKind<Slam3D, lslam::PointObservationSE3Factor>);
  in.ids[0] = f.ids[0];
  in.ids[1] = f.ids[1];
  for (int k = 0; k < Measurement::kMeasurementSize; ++k) in.measurement[k] = f.measurement[k];
  // x of the translation: qx qy qz qw x y z for a pose, x y z for a point.
  if (kPerturbedBuild && factor == kPerturbedFactor)
    in.measurement[between ? 4 : 0] += kPerturbation;
  const int n = between ? 6 : 3;
  int u = 0;
  for (int r = 0; r < n; ++r) {
    for (int c = r; c < n; ++c, ++u) {
      in.information[c * n + r] = f.information[u];
      in.information[r * n + c] = f.information[u];
    }
  }
  return in;
}

lslam::Status runStep(std::int32_t s) {
  constexpr std::int32_t kMaxInputs = 8;
  const lslam::stream::ModelStreamStep& step = stream::kSteps[s];
  if (step.variable_count > kMaxInputs || step.factor_count > kMaxInputs) {
    return lslam::Status::InvalidArgument;
  }
  Variable variables[kMaxInputs];
  Measurement factors[kMaxInputs];
  for (std::int32_t k = 0; k < step.variable_count; ++k) {
    variables[k] = variableInput(stream::kVariables[step.first_variable + k]);
  }
  for (std::int32_t k = 0; k < step.factor_count; ++k) {
    factors[k] = factorInput(step.first_factor + k);
  }
  StepCost& cost = g_costs[s];
  const lslam::Status status =
      lslam::target::timedStep(g_solver, variables, step.variable_count, factors, step.factor_count,
                               &cost.result, &cost.instructions);
  cost.kind = stepKind(s == 0, step.loop_closure, step.landmark_observation, cost.result);
  return status;
}

struct Difference {
  double position = 0.0;  // metres (poses and landmarks)
  double angle = 0.0;     // radians (poses)
};

// Largest difference between the solver's estimate and the host's incremental estimate.
Difference maxDifference() {
  Difference d;
  for (const lslam::stream::ModelStreamValue& r : stream::kHostIncrementalValues) {
    const lslam::Vec3 t(r.p[0], r.p[1], r.p[2]);
    if (r.kind == 0) {
      lslam::SE3 x;
      if (g_solver.estimate(r.id, &x) != lslam::Status::Ok) return Difference{INFINITY, INFINITY};
      const Eigen::Quaterniond q(r.p[6], r.p[3], r.p[4], r.p[5]);
      d.position = std::fmax(d.position, (x.translation() - t).norm());
      d.angle = std::fmax(d.angle, x.rotation().quaternion().angularDistance(q));
    } else {
      lslam::Point3 l;
      if (g_solver.estimate(r.id, &l) != lslam::Status::Ok) return Difference{INFINITY, INFINITY};
      d.position = std::fmax(d.position, (l.vector() - t).norm());
    }
  }
  return d;
}

// Relinearization mostly rides on a reordering (the policy batches it), so the kinds above count
// few steps as relinearization: the steps that relinearized anything, whatever their kind.
void printRelinearizingSteps() {
  static std::uint64_t counts[stream::kNumSteps];  // no heap
  std::int32_t n = 0;
  for (const StepCost& c : g_costs) {
    if (c.result.variables_relinearized > 0) counts[n++] = c.instructions;
  }
  if (n == 0) return;
  std::sort(counts, counts + n);
  Line()
      .text("steps relinearizing any variable (any kind): ")
      .integer(n)
      .text(" min ")
      .integer(static_cast<long long>(counts[0]))
      .text(" median ")
      .integer(static_cast<long long>(counts[n / 2]))
      .text(" max ")
      .integer(static_cast<long long>(counts[n - 1]))
      .text(" instructions")
      .print();
}

// The checks and their tolerances: see firmware_lib/target/README.md.
void checkResult(lslam::target::Checks& checks) {
  const double chi2 = g_solver.chi2();
  const double host_relative =
      std::fabs(chi2 - stream::kHostIncrementalChi2) / stream::kHostIncrementalChi2;
  const double batch_relative = (chi2 - stream::kBatchChi2) / stream::kBatchChi2;
  constexpr auto kValues = static_cast<lslam::Index>(sizeof(stream::kHostIncrementalValues) /
                                                     sizeof(stream::kHostIncrementalValues[0]));
  const Difference host = maxDifference();
  printValue("chi2 target incremental  ", chi2);
  printValue("chi2 host incremental    ", stream::kHostIncrementalChi2);
  printValue("chi2 host batch optimum  ", stream::kBatchChi2);
  printValue("relative chi2 difference target vs host incremental ", host_relative);
  printValue("relative chi2 excess over the batch optimum ", batch_relative);
  printValue("max difference vs host incremental (m)   ", host.position);
  printValue("max difference vs host incremental (rad) ", host.angle);
  checks.expect(g_solver.poses() + g_solver.landmarks() == kValues,
                "every pose and landmark of the stream is in the solver");
  checks.expect(host_relative <= 1e-9, "chi2 equals the host's incremental chi2 (1e-9 relative)");
  checks.expect(host.position <= 1e-9 && host.angle <= 1e-9,
                "estimate equals the host's incremental estimate (1e-9 m, 1e-9 rad)");
  checks.expect(batch_relative >= -1e-9 && batch_relative <= 1e-4,
                "chi2 within 1e-4 relative above the batch optimum");
}

}  // namespace

int main() {
  lslam::target::Checks checks;
  Line()
      .text("solver object: ")
      .integer(static_cast<long long>(sizeof(Solver)))
      .text(" bytes (Slam3D: max_poses 320, max_landmarks 48, max_factors 704, max_factor_blocks ")
      .integer(kMaxBlocks)
      .text(")")
      .print();
  lslam::target::printPerturbedBuild("measurement", kPerturbedFactor, kPerturbation);
  lslam::target::startInstructionCounter();
  lslam::Index peak_blocks = 0;
  const auto step = [&peak_blocks](std::int32_t s) {
    const lslam::Status status = runStep(s);
    if (status != lslam::Status::Ok) return status;
    if (g_solver.factorBlocks() > peak_blocks) peak_blocks = g_solver.factorBlocks();
    return status;
  };
  if (!lslam::target::runSteps(0, stream::kNumSteps, step, checks)) return checks.exitStatus();
  printStepCosts(g_costs, stream::kNumSteps);
  printRelinearizingSteps();
  Line()
      .text("poses ")
      .integer(g_solver.poses())
      .text(", landmarks ")
      .integer(g_solver.landmarks())
      .text(", factors ")
      .integer(g_solver.factors())
      .text(", peak live factor blocks ")
      .integer(peak_blocks)
      .text(" of ")
      .integer(kMaxBlocks)
      .print();
  checkResult(checks);
  return checks.exitStatus();
}
