// The firmware proof: the 500-pose Manhattan stream (data/manhattan_world_500_stream.h, generated
// on the host) fed step by step through StaticSmoother<PoseSlam2D, ...> with the host's
// configuration, on
// the Cortex-M7 under QEMU. Checks the result against the host's numbers, prints the instruction
// count of every step and a summary per kind of step. The exit status is the test result.
//
// Built twice: as is (must pass), and perturbed (stream_runner.h: must fail).
#include <cmath>
#include <cstdint>

#include "lslam/factors/se2_factors.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/solver/smoother.h"
#include "lslam_target/instruction_counter.h"
#include "manhattan_world_500_stream.h"
#include "step_costs.h"
#include "stream_runner.h"
#include "target_checks.h"

namespace {

namespace stream = lslam::stream::manhattan_world_500;
using lslam::PoseSlam2D;
using lslam::target::hostRunnerOptions;
using lslam::target::kPerturbedBuild;
using lslam::target::Line;
using lslam::target::printValue;
using Variable = lslam::ModelVariableInput<PoseSlam2D>;
using Measurement = lslam::ModelFactorInput<PoseSlam2D>;

constexpr std::int32_t kPerturbedFactor = stream::kNumFactors / 2;
constexpr double kPerturbation = 0.05;  // metres on x: the generator's sigma_x

// Capacity for this stream (500 poses, 971 measurements + the anchor prior; 12 factor values per
// SE2 between or prior). The pool holds the largest live factor (about 6100 blocks) twice over, as
// a reordering stages a whole new factor (one block size: its blocks hold their values).
template <lslam::Index P, lslam::Index F, lslam::Index B>
using SolverOf = lslam::StaticSmoother<PoseSlam2D, P, 0, F, F * 12, B, 0>;
using Solver = SolverOf<512, 1024, 16384>;

// RAM per unit of capacity, from the sizes of the storage classes: the difference of two solver
// sizes that differ in one capacity only, divided by that difference (averages the id map's
// power-of-two table and the padding).
template <lslam::Index P, lslam::Index F, lslam::Index B>
constexpr double kBytes = static_cast<double>(sizeof(SolverOf<P, F, B>));
constexpr double kBytesPerPose = (kBytes<1024, 1024, 16384> - kBytes<512, 1024, 16384>) / 512;
constexpr double kBytesPerFactor = (kBytes<512, 2048, 16384> - kBytes<512, 1024, 16384>) / 1024;
constexpr double kBytesPerBlock = (kBytes<512, 1024, 32768> - kBytes<512, 1024, 16384>) / 16384;
constexpr double kFixedBytes = kBytes<512, 1024, 16384> - 512 * kBytesPerPose -
                               1024 * kBytesPerFactor - 16384 * kBytesPerBlock;

// In .bss: 1.7 MB of the board's 4 MB of RAM.
Solver g_solver(hostRunnerOptions<PoseSlam2D>());
StepCost g_costs[stream::kNumSteps];

// The measurement as the solver sees it (with the test-only corruption, if built in).
lslam::SE2 measurement(std::int32_t factor) {
  const lslam::stream::StreamFactor& f = stream::kFactors[factor];
  const double bias = kPerturbedBuild && factor == kPerturbedFactor ? kPerturbation : 0.0;
  return lslam::SE2(f.x + bias, f.y, f.theta);
}

lslam::Mat3 information(const lslam::stream::StreamFactor& f) {
  const double* i = f.information;
  lslam::Mat3 m;
  m << i[0], i[1], i[2], i[1], i[3], i[4], i[2], i[4], i[5];
  return m;
}

Measurement factorInput(std::int32_t factor) {
  const lslam::stream::StreamFactor& f = stream::kFactors[factor];
  return Measurement::make<lslam::BetweenSE2Factor>(f.from, f.to, measurement(factor),
                                                    information(f));
}

// The pose a step adds: the stream's first pose, or the current estimate of the other end of the
// step's first measurement composed with that measurement (as host_sim's initialValue).
bool initialPose(const lslam::stream::StreamStep& step, Variable* pose) {
  lslam::SE2 initial(stream::kFirstPose.x, stream::kFirstPose.y, stream::kFirstPose.theta);
  if (step.factor_count > 0) {
    const lslam::stream::StreamFactor& first = stream::kFactors[step.first_factor];
    const std::int32_t known = first.from == step.new_pose ? first.to : first.from;
    lslam::SE2 estimate;
    if (g_solver.estimate(known, &estimate) != lslam::Status::Ok) return false;
    const lslam::SE2 z = measurement(step.first_factor);
    initial = estimate.compose(step.new_pose == first.to ? z : z.inverse());
  }
  *pose = Variable::make(step.new_pose, initial);
  return true;
}

lslam::Status runStep(std::int32_t s) {
  const lslam::stream::StreamStep& step = stream::kSteps[s];
  Variable pose;
  if (!initialPose(step, &pose)) return lslam::Status::UnknownVariable;
  Measurement factors[8];
  if (step.factor_count > 8) return lslam::Status::InvalidArgument;
  for (std::int32_t k = 0; k < step.factor_count; ++k) {
    factors[k] = factorInput(step.first_factor + k);
  }
  StepCost& cost = g_costs[s];
  const lslam::Status status = lslam::target::timedStep(
      g_solver, &pose, 1, factors, step.factor_count, &cost.result, &cost.instructions);
  cost.kind = stepKind(step.factor_count == 0, step.loop_closure, /*landmark_observation=*/false,
                       cost.result);
  return status;
}

// g2o chi2 of the solver's estimate over the stream's measurements (the anchor prior excluded),
// the quantity the host computes with host_sim's chi2.
double chi2G2o() {
  double chi2 = 0.0;
  for (std::int32_t k = 0; k < stream::kNumFactors; ++k) {
    const lslam::stream::StreamFactor& f = stream::kFactors[k];
    lslam::SE2 xi, xj;
    if (g_solver.estimate(f.from, &xi) != lslam::Status::Ok ||
        g_solver.estimate(f.to, &xj) != lslam::Status::Ok) {
      return NAN;
    }
    const lslam::Vec3 e = lslam::betweenErrorSE2(xi, xj, measurement(k));
    chi2 += e.dot(information(f) * e);
  }
  return chi2;
}

struct PoseDifference {
  double position = 0.0;  // metres
  double angle = 0.0;     // radians
};

// Largest difference between the solver's estimate and `reference` over every pose.
PoseDifference maxDifference(const lslam::stream::StreamPose* reference, std::int32_t count) {
  PoseDifference d;
  for (std::int32_t k = 0; k < count; ++k) {
    const lslam::stream::StreamPose& r = reference[k];
    lslam::SE2 p;
    if (g_solver.estimate(r.id, &p) != lslam::Status::Ok) return PoseDifference{INFINITY, INFINITY};
    d.position = std::fmax(d.position, std::hypot(p.x() - r.x, p.y() - r.y));
    d.angle = std::fmax(d.angle, std::fabs(lslam::wrapAngle(p.theta() - r.theta)));
  }
  return d;
}

// The checks, tolerances and why: see firmware_lib/target/README.md, Tests.
void checkResult(lslam::target::Checks& checks) {
  const double chi2 = chi2G2o();
  const double host_relative =
      std::fabs(chi2 - stream::kHostIncrementalChi2) / stream::kHostIncrementalChi2;
  const double batch_relative = (chi2 - stream::kBatchChi2) / stream::kBatchChi2;
  constexpr std::int32_t kPoses = sizeof(stream::kBatchPoses) / sizeof(stream::kBatchPoses[0]);
  const PoseDifference host = maxDifference(stream::kHostIncrementalPoses, kPoses);
  const PoseDifference batch = maxDifference(stream::kBatchPoses, kPoses);
  printValue("chi2 target incremental  ", chi2);
  printValue("chi2 host incremental    ", stream::kHostIncrementalChi2);
  printValue("chi2 host batch optimum  ", stream::kBatchChi2);
  printValue("chi2 target solver (its own chi2()) ", g_solver.chi2());
  printValue("relative chi2 difference target vs host incremental ", host_relative);
  printValue("relative chi2 excess over the batch optimum ", batch_relative);
  printValue("max pose difference vs host incremental (m)   ", host.position);
  printValue("max pose difference vs host incremental (rad) ", host.angle);
  printValue("max pose difference vs batch optimum (m)   ", batch.position);
  printValue("max pose difference vs batch optimum (rad) ", batch.angle);
  checks.expect(g_solver.poses() == kPoses, "every pose of the stream is in the solver");
  checks.expect(host_relative <= 1e-9, "chi2 equals the host's incremental chi2 (1e-9 relative)");
  checks.expect(host.position <= 1e-9 && host.angle <= 1e-9,
                "estimate equals the host's incremental estimate (1e-9 m, 1e-9 rad)");
  checks.expect(batch_relative >= -1e-9 && batch_relative <= 1e-5,
                "chi2 within 1e-5 relative above the batch optimum");
  checks.expect(batch.position <= 1e-3 && batch.angle <= 1e-3,
                "estimate within 1e-3 m and 1e-3 rad of the batch optimum");
}

}  // namespace

int main() {
  lslam::target::Checks checks;
  Line()
      .text("solver object: ")
      .integer(static_cast<long long>(sizeof(Solver)))
      .text(" bytes (max_poses 512, max_factors 1024, max_factor_blocks 16384)")
      .print();
  Line()
      .text("RAM per pose ")
      .fixed(kBytesPerPose, 2)
      .text(" B, per factor ")
      .fixed(kBytesPerFactor, 2)
      .text(" B, per factor block ")
      .fixed(kBytesPerBlock, 2)
      .text(" B, fixed ")
      .fixed(kFixedBytes, 0)
      .text(" B")
      .print();
  lslam::target::printPerturbedBuild("measurement", kPerturbedFactor, kPerturbation);
  lslam::target::startInstructionCounter();
  if (!lslam::target::runSteps(0, stream::kNumSteps, runStep, checks)) return checks.exitStatus();
  const OdometryFigures odometry = printStepCosts(g_costs, stream::kNumSteps);
  checkResult(checks);
  // An odometry step does the same work wherever it falls in the stream (2 columns, 1 block
  // product, 2 or 3 variables solved), and its trigonometry costs the same at every heading
  // (lslam::sinCos), so its count must neither grow with the graph nor wander.
  checks.expect(std::fabs(odometry.first_to_last) <= 5.0,
                "odometry: last step within 5 % of the first");
  checks.expect(odometry.spread <= 5.0,
                "odometry: every step of the same work within 5 % of the cheapest");
  return checks.exitStatus();
}
