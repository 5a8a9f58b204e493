#include "host_sim/compact_stream_header.h"

#include <memory>
#include <stdexcept>
#include <vector>

#include "header_text.h"
#include "host_sim/model_batch_solver.h"
#include "host_sim/model_run.h"
#include "host_sim/model_steps.h"
#include "host_sim/sized_smoother.h"
#include "host_sim/trajectory_error.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/solver/compact_pose_graph.h"

namespace lslam::sim {
namespace {

using Graph = CompactPoseGraph<PoseSlam2D>;

struct Closure {
  std::int32_t step = 0;
  std::int32_t node = 0;
  SE2 z;
};

// The stream as the target reads it: measurements rounded to float.
struct CompactStream {
  SE2 first;
  std::vector<SE2> odometry;  // step s + 1
  std::vector<Closure> closures;
  Mat3 odometry_information = Mat3::Zero();
  Mat3 closure_information = Mat3::Zero();
};

SE2 roundedToFloat(const SE2& z) {
  return SE2(static_cast<float>(z.x()), static_cast<float>(z.y()), static_cast<float>(z.theta()));
}

void sameInformation(Mat3& kept, const Mat3& information, bool& seen, const char* what) {
  if (!seen) {
    kept = information;
    seen = true;
  } else if (kept != information) {
    throw std::invalid_argument(std::string("compactStreamHeader: the ") + what +
                                " information differs between measurements");
  }
}

CompactStream streamOf(const ModelDataset& d, const std::vector<ModelStep>& steps, int max_poses) {
  CompactStream out;
  bool odometry_seen = false;
  bool closure_seen = false;
  for (std::size_t s = 0; s < steps.size(); ++s) {
    const ModelStep& step = steps[s];
    if (step.new_pose.id != static_cast<std::int64_t>(s)) {
      throw std::invalid_argument("compactStreamHeader: poses must be 0, 1, 2, ... in order");
    }
    if (s == 0) {
      const Eigen::VectorXd first = initialValue(d, step, step.new_pose, {});
      out.first = SE2(first[0], first[1], first[2]);
      continue;
    }
    bool odometry = false;
    for (const std::size_t k : step.factors) {
      const ModelFactor& f = d.factors[k];
      const auto in = modelFactorInput<PoseSlam2D>(d, f);
      if (f.kind != FactorKind::BetweenSE2 || f.second.id != step.new_pose.id) {
        throw std::invalid_argument(
            "compactStreamHeader: every measurement must be a between "
            "factor from an earlier pose to the step's");
      }
      const SE2 z = roundedToFloat(in.measurementAs<BetweenSE2Factor>());
      const Mat3 information = in.informationAs<BetweenSE2Factor>();
      if (f.first.id == step.new_pose.id - 1 && !odometry) {
        sameInformation(out.odometry_information, information, odometry_seen, "odometry");
        out.odometry.push_back(z);
        odometry = true;
      } else if (f.first.id < max_poses) {
        sameInformation(out.closure_information, information, closure_seen, "loop closure");
        out.closures.push_back(
            Closure{static_cast<std::int32_t>(s), static_cast<std::int32_t>(f.first.id), z});
      }
    }
    if (!odometry) throw std::invalid_argument("compactStreamHeader: a step without odometry");
  }
  return out;
}

// The solver the target builds: max_poses nodes, kCompactFactorsPerNode factors each, the block
// pool of lslam-sim run --max-poses.
SmootherCapacities capacitiesOf(const ModelDataset& d, int max_poses) {
  return compactCapacities(d, max_poses, 0);
}

struct HostRun {
  double chi2 = 0.0;
  std::vector<SE2> nodes;
};

// The stream through CompactPoseGraph exactly as the target program runs it.
HostRun runStream(const CompactStream& stream, const SmootherCapacities& capacities) {
  SolverOptions options = defaultSolverOptions<PoseSlam2D>();
  options.solve_after_update = false;
  const auto solver = std::make_unique<SizedSmoother<PoseSlam2D>>(capacities, options);
  Graph graph(*solver);
  if (graph.start(stream.first) != Status::Ok) throw std::logic_error("start refused");
  std::size_t next = 0;
  std::vector<PlaceClosure<SE2>> closures;
  for (std::size_t s = 1; s <= stream.odometry.size(); ++s) {
    closures.clear();
    for (; next < stream.closures.size() && stream.closures[next].step == static_cast<int>(s);
         ++next) {
      const Closure& c = stream.closures[next];
      closures.push_back(PlaceClosure<SE2>{Place<SE2>{c.node, SE2(), Mat3::Zero()}, c.z,
                                           stream.closure_information});
    }
    CompactStepResult r;
    const Status status = graph.addStep(stream.odometry[s - 1], stream.odometry_information,
                                        closures.data(), static_cast<Index>(closures.size()), &r);
    if (status != Status::Ok) throw std::logic_error("compactStreamHeader: a step refused");
    // The stream names nodes by pose id: the first max_poses poses must all be nodes.
    if (r.node_added != (static_cast<Index>(s) < capacities.poses)) {
      throw std::logic_error("compactStreamHeader: pose " + std::to_string(s) +
                             (r.node_added ? " became" : " did not become") + " a node");
    }
    if (r.updates > 0) solver->solve(false);
  }
  HostRun out;
  out.chi2 = solver->chi2();
  for (Index v = 0; v < graph.nodes(); ++v) out.nodes.push_back(solver->estimateAt<SE2>(v));
  return out;
}

// The position RMS against the truth of the batch optimum of the first max_poses steps.
double firstBatchMapRms(const ModelDataset& d, const std::vector<ModelStep>& steps,
                        const ModelEstimate& truth, int max_poses) {
  const ModelDataset first = firstSteps(d, steps, static_cast<std::size_t>(max_poses));
  BatchOptions options;
  options.fixed = {0};
  const ModelBatchResult batch = solveModelBatch(first, initialEstimate(first), options);
  if (!batch.converged) throw std::logic_error("compactStreamHeader: the batch did not converge");
  return trajectoryError(batch.values, truth, 2, variableKinds(first)).ate_position_rmse;
}

std::string number(double v) {
  return detail::doubleLiteral(v);
}

std::string upperTriangle(const Mat3& m) {
  return "{" + number(m(0, 0)) + ", " + number(m(0, 1)) + ", " + number(m(0, 2)) + ", " +
         number(m(1, 1)) + ", " + number(m(1, 2)) + ", " + number(m(2, 2)) + "}";
}

std::string triple(const SE2& z) {
  return "{" + number(z.x()) + ", " + number(z.y()) + ", " + number(z.theta()) + "}";
}

std::string floatTriple(const SE2& z) {
  return "{" + detail::floatLiteral(z.x()) + ", " + detail::floatLiteral(z.y()) + ", " +
         detail::floatLiteral(z.theta()) + "}";
}

}  // namespace

std::string compactStreamHeader(const ModelDataset& d, const ModelEstimate& truth, int max_poses,
                                const std::string& source_name, const std::string& name_space) {
  detail::checkIdentifier(name_space, "compactStreamHeader");
  if (!isPoseGraph2D(d)) throw std::invalid_argument("compactStreamHeader: not a 2D pose graph");
  const std::vector<ModelStep> steps = buildModelSteps(d);
  if (max_poses < 2 || steps.size() <= static_cast<std::size_t>(max_poses)) {
    throw std::invalid_argument("compactStreamHeader: max_poses must be in 2..steps - 1");
  }
  const CompactStream stream = streamOf(d, steps, max_poses);
  const SmootherCapacities capacities = capacitiesOf(d, max_poses);
  const HostRun host = runStream(stream, capacities);

  std::string out = "// Generated by lslam-stream-header --compact " + std::to_string(max_poses) +
                    " from " + source_name +
                    ": do not edit.\n// See host_sim/include/host_sim/compact_stream_header.h.\n"
                    "#pragma once\n#include <cstdint>\n\nnamespace lslam::stream::" +
                    name_space + " {\n\n";
  out +=
      "struct CompactClosure {\n  std::int32_t step;\n  std::int32_t node;\n  float z[3];\n};\n\n";
  out += "inline constexpr std::int32_t kMaxPoses = " + std::to_string(capacities.poses) +
         ";\ninline constexpr std::int32_t kMaxFactors = " + std::to_string(capacities.factors) +
         ";\ninline constexpr std::int32_t kFactorBlocks = " +
         std::to_string(capacities.factor_blocks) +
         ";\ninline constexpr std::int32_t kNumSteps = " + std::to_string(steps.size()) +
         ";\ninline constexpr double kFirstPose[3] = " + triple(stream.first) +
         ";\ninline constexpr double kOdometryInformation[6] = " +
         upperTriangle(stream.odometry_information) +
         ";\ninline constexpr double kClosureInformation[6] = " +
         upperTriangle(stream.closure_information) + ";\n";
  out += "inline constexpr float kOdometry[kNumSteps - 1][3] = {\n";
  for (const SE2& z : stream.odometry) out += "    " + floatTriple(z) + ",\n";
  out +=
      "};\ninline constexpr std::int32_t kNumClosures = " + std::to_string(stream.closures.size()) +
      ";\ninline constexpr CompactClosure kClosures[kNumClosures] = {\n";
  for (const Closure& c : stream.closures) {
    out += "    {" + std::to_string(c.step) + ", " + std::to_string(c.node) + ", " +
           floatTriple(c.z) + "},\n";
  }
  out += "};\n// The host's run of this stream.\ninline constexpr double kHostChi2 = " +
         number(host.chi2) + ";\ninline constexpr double kHostNodes[kMaxPoses][3] = {\n";
  for (const SE2& x : host.nodes) out += "    " + triple(x) + ",\n";
  out += "};\ninline constexpr double kTruthNodes[kMaxPoses][2] = {\n";
  for (int v = 0; v < max_poses; ++v) {
    const auto it = truth.find(VariableKey{VariableRole::Pose, v});
    if (it == truth.end()) throw std::invalid_argument("compactStreamHeader: a node has no truth");
    out += "    {" + number(it->second[0]) + ", " + number(it->second[1]) + "},\n";
  }
  out += "};\ninline constexpr double kFirstBatchMapRms = " +
         number(firstBatchMapRms(d, steps, truth, max_poses)) + ";\n";
  return out + "\n}  // namespace lslam::stream::" + name_space + "\n";
}

}  // namespace lslam::sim
