#include "host_sim/incremental_run.h"

#include <chrono>
#include <cstring>
#include <new>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace lslam::sim {

const char* stepKindName(StepKind kind) {
  switch (kind) {
    case StepKind::First:
      return "first";
    case StepKind::Odometry:
      return "odometry";
    case StepKind::LoopClosure:
      return "loop";
  }
  return "?";
}

FactorInput toFactorInput(const Edge2D& edge) {
  FactorInput f;
  f.kind = FactorKind::BetweenSE2;
  f.from = edge.from;
  f.to = edge.to;
  f.measurement = SE2(edge.measurement.x, edge.measurement.y, edge.measurement.theta);
  f.information = edge.information;
  return f;
}

namespace {

Pose2D toPose2D(const SE2& p) {
  return Pose2D{p.x(), p.y(), p.theta()};
}

// A step is odometry when its only edge links the new pose to the pose introduced just before.
StepKind classify(const Dataset2D& d, const Step& step, std::int64_t previous_pose) {
  if (step.edges.empty()) return StepKind::First;
  for (std::size_t e : step.edges) {
    const Edge2D& edge = d.edges[e];
    const bool odometry = (edge.from == previous_pose && edge.to == step.new_pose) ||
                          (edge.to == previous_pose && edge.from == step.new_pose);
    if (!odometry) return StepKind::LoopClosure;
  }
  return StepKind::Odometry;
}

// On the robot the solver lives in .bss, which the startup code zeroes (and so pages in) before
// main(). The host does the same: the solver is built in memory zeroed beforehand, so the timed
// steps do not pay the kernel's first-touch page faults as the block pool's tail advances into
// the ~170 MB object.
struct ZeroedSolverDeleter {
  void operator()(HostSolver2D* solver) const {
    solver->~HostSolver2D();
    ::operator delete (static_cast<void*>(solver), std::align_val_t{alignof(HostSolver2D)});
  }
};
using ZeroedSolver = std::unique_ptr<HostSolver2D, ZeroedSolverDeleter>;

ZeroedSolver makeZeroedSolver(const SolverOptions& options) {
  void* memory = ::operator new (sizeof(HostSolver2D), std::align_val_t{alignof(HostSolver2D)});
  std::memset(memory, 0, sizeof(HostSolver2D));
  return ZeroedSolver(new (memory) HostSolver2D(options));
}

// The incremental solver anchors step 0's pose and knows no FIX. One fixed pose only sets the
// gauge: anchoring another pose gives the same optimum moved rigidly, so a FIX of another pose is
// noted (and the batch reference anchors the same pose as the solver). Two fixed poses constrain
// the problem itself, which the solver cannot do: an error at the FIX naming the second one.
std::string checkFixed(const Dataset2D& d, std::int64_t anchor) {
  if (d.fixed.empty()) return {};
  const FixedPose& first = d.fixed.front();
  for (const FixedPose& f : d.fixed) {
    if (f.id == first.id) continue;
    throw DatasetError(d.name, f.line,
                       "FIX " + std::to_string(f.id) + ": a second fixed pose (FIX " +
                           std::to_string(first.id) + " at line " + std::to_string(first.line) +
                           "); the incremental solver fixes one pose, its first");
  }
  if (first.id == anchor || anchor < 0) return {};
  return d.name + ":" + std::to_string(first.line) + ": FIX " + std::to_string(first.id) +
         ": the incremental solver anchors pose " + std::to_string(anchor) +
         " (its first) instead, and so does the batch reference; the optimum is the same up to a "
         "rigid motion";
}

// "step 4 (pose 4, edges at lines 9, 12) rejected: <status>", at the first edge's line.
[[noreturn]] void rejectStep(const Dataset2D& d, const Step& step, std::size_t index,
                             Status status) {
  constexpr std::size_t kMaxLines = 10;
  std::string lines;
  for (std::size_t k = 0; k < step.edges.size() && k < kMaxLines; ++k) {
    lines += (k == 0 ? "" : ", ") + std::to_string(d.edges[step.edges[k]].line);
  }
  if (step.edges.size() > kMaxLines) {
    lines += ", ... (" + std::to_string(step.edges.size()) + " edges)";
  }
  std::string reason = "step " + std::to_string(index) + " (pose " + std::to_string(step.new_pose);
  if (!step.edges.empty()) {
    reason += step.edges.size() == 1 ? ", edge at line " : ", edges at lines ";
    reason += lines;
  }
  reason += std::string(") rejected: ") + toString(status);
  const std::size_t line = step.edges.empty() ? 0 : d.edges[step.edges.front()].line;
  throw DatasetError(d.name, line, reason);
}

}  // namespace

IncrementalRun runIncremental(const Dataset2D& d, const IncrementalOptions& options) {
  const std::vector<Step> steps = buildSteps(d, options.order);
  const std::int64_t anchor = steps.empty() ? -1 : steps.front().new_pose;
  const std::string gauge_note = checkFixed(d, anchor);
  const Estimate2D vertices = estimateFromVertices(d);
  SolverOptions solver_options = options.solver;
  solver_options.solve_after_update = false;  // solve() below, every N steps
  ZeroedSolver solver = makeZeroedSolver(solver_options);

  IncrementalRun run;
  run.anchor = anchor;
  run.gauge_note = gauge_note;
  run.solver_bytes = sizeof(HostSolver2D);
  run.steps.reserve(steps.size());
  std::vector<FactorInput> factors;
  std::int64_t previous_pose = -1;
  using Clock = std::chrono::steady_clock;
  for (std::size_t s = 0; s < steps.size(); ++s) {
    const Step& step = steps[s];
    // Inputs are prepared before the clock starts: the robot has them in hand when it calls.
    PoseInput pose;
    const bool has_pose = step.new_pose >= 0;
    if (has_pose) {
      pose.id = step.new_pose;
      Pose2D initial{};
      if (!step.edges.empty()) {
        const Edge2D& first = d.edges[step.edges.front()];
        const std::int64_t known = first.from == step.new_pose ? first.to : first.from;
        SE2 known_estimate;
        if (solver->estimate(known, &known_estimate) != Status::Ok) {
          throw std::runtime_error("step " + std::to_string(s) + ": pose " + std::to_string(known) +
                                   " unknown to the solver");
        }
        initial = initialPoseFromEdge(first, step.new_pose, toPose2D(known_estimate));
      } else if (auto it = vertices.find(step.new_pose); it != vertices.end()) {
        initial = it->second;
      }
      pose.initial = SE2(initial.x, initial.y, initial.theta);
      run.initial[pose.id] = Pose2D{pose.initial.x(), pose.initial.y(), pose.initial.theta()};
    }
    factors.clear();
    for (std::size_t e : step.edges) factors.push_back(toFactorInput(d.edges[e]));

    StepRecord record;
    record.index = s;
    record.kind = classify(d, step, previous_pose);
    const bool solve_now =
        (s + 1) % static_cast<std::size_t>(options.solve_every) == 0 || s + 1 == steps.size();
    const auto t0 = Clock::now();
    const Status status =
        solver->update(has_pose ? &pose : nullptr, has_pose ? 1 : 0, factors.data(),
                       static_cast<Index>(factors.size()), &record.result);
    const auto t_solve = Clock::now();
    if (status == Status::Ok && solve_now) solver->solve(false, &record.result);
    const auto t1 = Clock::now();
    if (status != Status::Ok) rejectStep(d, step, s, status);
    record.microseconds = std::chrono::duration<double, std::micro>(t1 - t0).count();
    record.solve_microseconds = std::chrono::duration<double, std::micro>(t1 - t_solve).count();
    run.total_seconds += record.microseconds * 1e-6;
    run.reorders += record.result.reordered ? 1 : 0;
    run.steps.push_back(record);
    if (has_pose) previous_pose = step.new_pose;
  }
  for (Index v = 0; v < solver->poses(); ++v) {
    run.estimate[solver->idAt(v)] = toPose2D(solver->estimateAt(v));
  }
  run.factor_blocks = solver->factorBlocks();
  return run;
}

}  // namespace lslam::sim
