// Mapping forever in fixed memory on the Cortex-M7 under QEMU: a 20,000-step grid2d stream
// (data/grid2d_20000_compact.h, generated on the host) through CompactPoseGraph<PoseSlam2D> on a
// StaticSmoother of 100 poses. Prints the worst step's instruction count of every 1,000 steps and
// the program's RAM, and checks: every step accepted, the node count at its capacity, the worst
// step of the second half no more than 1.2 times that of steps 1,000-10,000, the RAM (.data +
// .bss + stack) within 512 KB, the result equal to the host's run of the same stream, and the map
// no worse against the truth than the independent batch optimum of the first 100 steps.
//
// Built twice: as is (must pass), and perturbed (stream_runner.h: one loop closure moved; must
// fail).
#include <cmath>
#include <cstdint>

#include "grid2d_20000_compact.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/solver/compact_pose_graph.h"
#include "lslam/solver/smoother.h"
#include "lslam_target/instruction_counter.h"
#include "stream_runner.h"
#include "target_checks.h"

// The linker script's symbols, declared as startup.cpp declares them (LTO merges the two).
extern "C" {
void __stack_top();
extern std::uint32_t __data_start[];
extern std::uint32_t __bss_end[];
extern std::uint32_t __stack_limit[];
}

namespace {

namespace stream = lslam::stream::grid2d_20000_compact;
using lslam::PoseSlam2D;
using lslam::SE2;
using lslam::target::kPerturbedBuild;
using lslam::target::Line;
using Closure = lslam::PlaceClosure<SE2>;

constexpr std::int32_t kPerturbedClosure = stream::kNumClosures / 2;
constexpr double kPerturbation = 0.05;  // metres on x: grid2d's sigma of translations

constexpr std::int32_t kBlock = 1000;  // steps per line of the report
constexpr std::int32_t kBlocks = (stream::kNumSteps + kBlock - 1) / kBlock;
constexpr double kRamLimit = 512.0 * 1024.0;

using Solver = lslam::StaticSmoother<PoseSlam2D, stream::kMaxPoses, 0, stream::kMaxFactors,
                                     stream::kMaxFactors * 12, stream::kFactorBlocks, 0>;

Solver g_solver(lslam::target::hostRunnerOptions<PoseSlam2D>());  // in .bss
lslam::CompactPoseGraph<PoseSlam2D> g_graph(g_solver);
std::uint64_t g_worst[kBlocks];

lslam::Mat3 information(const double* upper) {
  lslam::Mat3 m;
  m << upper[0], upper[1], upper[2], upper[1], upper[3], upper[4], upper[2], upper[4], upper[5];
  return m;
}

SE2 pose(const float* z) {
  return SE2(z[0], z[1], z[2]);
}

// One step: its odometry and loop closures to nodes, timed with the solve.
lslam::Status runStep(std::int32_t s, std::int32_t& next_closure, std::uint64_t& cost) {
  static const lslam::Mat3 odometry_information = information(stream::kOdometryInformation);
  static const lslam::Mat3 closure_information = information(stream::kClosureInformation);
  Closure closures[4];
  std::int32_t count = 0;
  for (; next_closure < stream::kNumClosures && stream::kClosures[next_closure].step == s;
       ++next_closure) {
    if (count == 4) return lslam::Status::InvalidArgument;
    const stream::CompactClosure& c = stream::kClosures[next_closure];
    SE2 z = pose(c.z);
    if (kPerturbedBuild && next_closure == kPerturbedClosure)
      z = SE2(z.x() + kPerturbation, z.y(), z.theta());
    closures[count++] =
        Closure{lslam::Place<SE2>{c.node, SE2(), lslam::Mat3::Zero()}, z, closure_information};
  }
  lslam::CompactStepResult r;
  const std::uint64_t t0 = lslam::target::instructions();
  const lslam::Status status =
      g_graph.addStep(pose(stream::kOdometry[s - 1]), odometry_information, closures, count, &r);
  if (status == lslam::Status::Ok && r.updates > 0) g_solver.solve(false);
  cost = lslam::target::instructions() - t0;
  return status;
}

// Position RMS of the nodes against the truth after the best rigid motion (2D closed form).
double mapRms() {
  constexpr std::int32_t n = stream::kMaxPoses;
  double ex = 0, ey = 0, tx = 0, ty = 0;
  for (std::int32_t v = 0; v < n; ++v) {
    const SE2 p = g_solver.estimateAt<SE2>(v);
    ex += p.x() / n;
    ey += p.y() / n;
    tx += stream::kTruthNodes[v][0] / n;
    ty += stream::kTruthNodes[v][1] / n;
  }
  double c = 0, s = 0;
  for (std::int32_t v = 0; v < n; ++v) {
    const SE2 p = g_solver.estimateAt<SE2>(v);
    const double x = p.x() - ex, y = p.y() - ey;
    const double u = stream::kTruthNodes[v][0] - tx, w = stream::kTruthNodes[v][1] - ty;
    c += x * u + y * w;
    s += x * w - y * u;
  }
  const double angle = std::atan2(s, c);
  const double ca = std::cos(angle), sa = std::sin(angle);
  double sum = 0;
  for (std::int32_t v = 0; v < n; ++v) {
    const SE2 p = g_solver.estimateAt<SE2>(v);
    const double x = p.x() - ex, y = p.y() - ey;
    const double dx = ca * x - sa * y - (stream::kTruthNodes[v][0] - tx);
    const double dy = sa * x + ca * y - (stream::kTruthNodes[v][1] - ty);
    sum += dx * dx + dy * dy;
  }
  return std::sqrt(sum / n);
}

double maxNodeDifference() {
  double d = 0;
  for (std::int32_t v = 0; v < stream::kMaxPoses; ++v) {
    const SE2 p = g_solver.estimateAt<SE2>(v);
    d = std::fmax(d,
                  std::hypot(p.x() - stream::kHostNodes[v][0], p.y() - stream::kHostNodes[v][1]));
    d = std::fmax(d, std::fabs(lslam::wrapAngle(p.theta() - stream::kHostNodes[v][2])));
  }
  return d;
}

}  // namespace

int main() {
  lslam::target::Checks checks;
  const auto address = [](const void* p) { return reinterpret_cast<std::uintptr_t>(p); };
  const double data_bss = static_cast<double>(address(__bss_end) - address(__data_start));
  const double stack =
      static_cast<double>(reinterpret_cast<std::uintptr_t>(&__stack_top) - address(__stack_limit));
  Line()
      .text("solver object: ")
      .integer(static_cast<long long>(sizeof(Solver)))
      .text(" bytes (")
      .integer(stream::kMaxPoses)
      .text(" poses, ")
      .integer(stream::kMaxFactors)
      .text(" factors, ")
      .integer(stream::kFactorBlocks)
      .text(" factor blocks); RAM: .data + .bss ")
      .integer(static_cast<long long>(data_bss))
      .text(" B + stack ")
      .integer(static_cast<long long>(stack))
      .text(" B")
      .print();
  lslam::target::printPerturbedBuild("loop closure", kPerturbedClosure, kPerturbation);
  lslam::target::startInstructionCounter();
  {
    const std::uint64_t t0 = lslam::target::instructions();
    const SE2 first(stream::kFirstPose[0], stream::kFirstPose[1], stream::kFirstPose[2]);
    if (!checks.expect(g_graph.start(first) == lslam::Status::Ok, "the first pose accepted")) {
      return checks.exitStatus();
    }
    g_worst[0] = lslam::target::instructions() - t0;
  }
  std::int32_t next_closure = 0;
  const auto step = [&next_closure](std::int32_t s) {
    std::uint64_t cost = 0;
    const lslam::Status status = runStep(s, next_closure, cost);
    if (status != lslam::Status::Ok) return status;
    std::uint64_t& worst = g_worst[s / kBlock];
    if (cost > worst) worst = cost;
    return status;
  };
  if (!lslam::target::runSteps(1, stream::kNumSteps, step, checks)) return checks.exitStatus();
  std::uint64_t early = 0;
  std::uint64_t late = 0;
  for (std::int32_t b = 0; b < kBlocks; ++b) {
    Line()
        .text("steps ")
        .integer(b * kBlock)
        .text("-")
        .integer((b + 1) * kBlock - 1)
        .text(": worst step ")
        .integer(static_cast<long long>(g_worst[b]))
        .text(" instructions")
        .print();
    if (b >= 1 && b < kBlocks / 2) early = g_worst[b] > early ? g_worst[b] : early;
    if (b >= kBlocks / 2) late = g_worst[b] > late ? g_worst[b] : late;
  }
  const double rms = mapRms();
  const double chi2 = g_solver.chi2();
  const double host_relative = std::fabs(chi2 - stream::kHostChi2) / stream::kHostChi2;
  const double node_difference = maxNodeDifference();
  Line().text("chi2 target ").real(chi2, 15).text(", host ").real(stream::kHostChi2, 15).print();
  Line().text("max node difference vs host ").real(node_difference, 3).print();
  Line()
      .text("map RMS against the truth ")
      .real(rms, 6)
      .text(" m; batch of the first ")
      .integer(stream::kMaxPoses)
      .text(" steps ")
      .real(stream::kFirstBatchMapRms, 6)
      .text(" m")
      .print();
  checks.expect(g_graph.nodes() == stream::kMaxPoses, "the map holds its capacity of poses");
  checks.expect(static_cast<double>(late) <= 1.2 * static_cast<double>(early),
                "worst step of steps 10,000-19,999 within 1.2x that of steps 1,000-9,999");
  checks.expect(data_bss + stack <= kRamLimit, "RAM (.data + .bss + stack) within 512 KB");
  checks.expect(host_relative <= 1e-9, "chi2 equals the host's run of the stream (1e-9 relative)");
  checks.expect(node_difference <= 1e-9, "the nodes equal the host's (1e-9 m, 1e-9 rad)");
  checks.expect(rms <= stream::kFirstBatchMapRms,
                "the map no worse against the truth than the batch of its first steps");
  return checks.exitStatus();
}
