#include "host_sim/model_stream_header.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <stdexcept>
#include <tuple>
#include <vector>

#include "header_text.h"
#include "host_sim/batch_solver.h"
#include "host_sim/model_batch_solver.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_run.h"
#include "host_sim/model_steps.h"
#include "lslam/models/slam_3d.h"
#include "lslam/solver/model_inputs.h"

namespace lslam::sim {
namespace {

using VariableIn = ModelVariableInput<Slam3D>;
using FactorIn = ModelFactorInput<Slam3D>;

constexpr const char* kTypes = R"(#ifndef LSLAM_MODEL_STREAM_TYPES_DEFINED
#define LSLAM_MODEL_STREAM_TYPES_DEFINED
namespace lslam::stream {

struct ModelStreamStep {
  std::int32_t first_variable;  // its variables: kVariables[first_variable, + variable_count)
  std::int32_t variable_count;
  std::int32_t first_factor;    // its measurements: kFactors[first_factor, + factor_count)
  std::int32_t factor_count;
  bool loop_closure;            // a between factor to a pose other than the previous one
  bool landmark_observation;    // a point observation
};

// A solver input: kind 0 SE3 pose, 1 Point3 landmark; value as ModelVariableInput<Slam3D>::value
// (qx qy qz qw x y z, or x y z).
struct ModelStreamVariable {
  std::uint8_t kind;
  std::int32_t id;
  double value[7];
};

// A solver input: kind 0 BetweenSE3 (ids: from, to), 1 PointObservationSE3 (ids: pose, landmark);
// measurement as ModelFactorInput<Slam3D>::measurement; the information's upper triangle, row by
// row.
struct ModelStreamFactor {
  std::uint8_t kind;
  std::int32_t ids[2];
  double measurement[7];
  double information[21];
};

// A host estimate: kind as ModelStreamVariable; x y z qx qy qz qw, or x y z.
struct ModelStreamValue {
  std::uint8_t kind;
  std::int32_t id;
  double p[7];
};

}  // namespace lslam::stream
#endif
)";

std::string number(double v) {
  return detail::doubleLiteral(v);
}

std::string numbers(const double* v, int n) {
  std::string s = "{";
  for (int k = 0; k < n; ++k) s += (k == 0 ? "" : ", ") + number(v[k]);
  return s + "}";
}

std::string id(std::int64_t v) {
  return detail::idLiteral(v, "modelStreamHeader: id");
}

void checkIdentifier(const std::string& s) {
  detail::checkIdentifier(s, "modelStreamHeader");
}

// The solver's 3D landmark model is the one runModelIncremental picks: 3D with a landmark.
void checkModel(const ModelDataset& d) {
  bool landmark = false;
  for (const ModelFactor& f : d.factors) {
    landmark = landmark || f.first.role == VariableRole::Landmark ||
               f.second.role == VariableRole::Landmark;
    if (f.kind != FactorKind::BetweenSE3 && f.kind != FactorKind::PointXYZ3) {
      throw std::invalid_argument(std::string("modelStreamHeader: factor kind ") +
                                  factorKindName(f.kind) + " not in the stream's format");
    }
  }
  if (d.dimension != 3 || !landmark) {
    throw std::invalid_argument("modelStreamHeader: not a 3D dataset with landmarks");
  }
}

std::string variableLine(const VariableKey& key, const Eigen::VectorXd& value) {
  const bool pose = key.role == VariableRole::Pose;
  const VariableIn in = modelVariableInput<Slam3D>(key, value);
  return "    {" + std::string(pose ? "0" : "1") + ", " + id(key.id) + ", " +
         numbers(in.value, pose ? 7 : 3) + "},\n";
}

// The information's upper triangle, row by row; it must be exactly symmetric (the target
// mirrors it).
template <int N>
std::string upperTriangle(const FactorIn& in) {
  const Eigen::Map<const Eigen::Matrix<double, N, N>> m(in.information);
  double upper[21] = {};
  int n = 0;
  for (int r = 0; r < N; ++r) {
    for (int c = r; c < N; ++c) {
      if (m(r, c) != m(c, r)) {
        throw std::invalid_argument("modelStreamHeader: information not exactly symmetric");
      }
      upper[n++] = m(r, c);
    }
  }
  return numbers(upper, n);
}

// The stream's kind (0: BetweenSE3, 1: PointXYZ3) and the solver's input, as runModelIncremental
// builds it.
std::string factorLine(const ModelDataset& d, const ModelFactor& f) {
  const FactorIn in = modelFactorInput<Slam3D>(d, f);
  const bool between = f.kind == FactorKind::BetweenSE3;
  return "    {" + std::string(between ? "0" : "1") + ", {" + id(f.first.id) + ", " +
         id(f.second.id) + "}, " + numbers(in.measurement, between ? 7 : 3) + ", " +
         (between ? upperTriangle<6>(in) : upperTriangle<3>(in)) + "},\n";
}

std::string stepArrays(const ModelDataset& d, const std::vector<ModelStep>& steps,
                       const ModelRun& run) {
  std::string step_lines, variable_lines, factor_lines;
  std::size_t variables = 0, factors = 0;
  for (std::size_t s = 0; s < steps.size(); ++s) {
    const ModelStep& step = steps[s];
    std::vector<VariableKey> keys;
    if (step.new_pose.id >= 0) keys.push_back(step.new_pose);
    keys.insert(keys.end(), step.new_landmarks.begin(), step.new_landmarks.end());
    bool landmark = false;
    for (std::size_t k : step.factors) landmark |= d.factors[k].kind == FactorKind::PointXYZ3;
    const bool loop = run.steps[s].kind == StepKind::LoopClosure;
    step_lines += "    {" + std::to_string(variables) + ", " + std::to_string(keys.size()) + ", " +
                  std::to_string(factors) + ", " + std::to_string(step.factors.size()) + ", " +
                  (loop ? "true" : "false") + ", " + (landmark ? "true" : "false") + "},\n";
    for (const VariableKey& key : keys) variable_lines += variableLine(key, run.initial.at(key));
    for (std::size_t k : step.factors) factor_lines += factorLine(d, d.factors[k]);
    variables += keys.size();
    factors += step.factors.size();
  }
  return "inline constexpr std::int32_t kNumSteps = " + std::to_string(steps.size()) +
         ";\ninline constexpr std::int32_t kNumVariables = " + std::to_string(variables) +
         ";\ninline constexpr std::int32_t kNumFactors = " + std::to_string(factors) +
         ";\ninline constexpr ModelStreamStep kSteps[kNumSteps] = {\n" + step_lines +
         "};\ninline constexpr ModelStreamVariable kVariables[kNumVariables] = {\n" +
         variable_lines + "};\ninline constexpr ModelStreamFactor kFactors[kNumFactors] = {\n" +
         factor_lines + "};\n";
}

// The estimate by (poses first, id).
std::string valueList(const ModelEstimate& values) {
  std::vector<std::tuple<int, std::int64_t, const Eigen::VectorXd*>> sorted;
  for (const auto& [key, value] : values) {
    sorted.emplace_back(key.role == VariableRole::Pose ? 0 : 1, key.id, &value);
  }
  std::sort(sorted.begin(), sorted.end());
  std::string out;
  for (const auto& [kind, key_id, value] : sorted) {
    out += "    {" + std::to_string(kind) + ", " + id(key_id) + ", " +
           numbers(value->data(), static_cast<int>(value->size())) + "},\n";
  }
  return out;
}

}  // namespace

std::string modelStreamHeader(const ModelDataset& d, const std::string& source_name,
                              const std::string& name_space) {
  checkIdentifier(name_space);
  checkModel(d);
  const std::vector<ModelStep> steps = buildModelSteps(d);
  IncrementalOptions options;
  options.solver = defaultModelOptions(d);
  const ModelRun run = runModelIncremental(d, options);
  if (run.steps.size() != steps.size()) {
    throw std::logic_error("modelStreamHeader: the run's steps differ from buildModelSteps");
  }
  BatchOptions batch_options;
  if (run.anchor.id >= 0) batch_options.fixed = {run.anchor.id};
  const ModelBatchResult batch = solveModelBatch(d, run.initial, batch_options);

  std::string out =
      "// Generated by lslam-stream-header from " + source_name +
      ": do not edit.\n"
      "// tests/host_sim/test_model_stream_header.cpp fails when it differs from what the host\n"
      "// computes now. The online step stream of the dataset as the host's solver inputs, and "
      "the\n"
      "// host's results on it; see host_sim/include/host_sim/model_stream_header.h.\n"
      "#pragma once\n#include <cstdint>\n\n" +
      std::string(kTypes) + "\nnamespace lslam::stream::" + name_space + " {\n\n";
  out += stepArrays(d, steps, run);
  out +=
      "// The host's incremental run (defaultSolverOptions<Slam3D>(), solve after every step).\n";
  out += "inline constexpr double kHostIncrementalChi2 = " + number(chi2(d, run.estimate)) +
         ";\ninline constexpr ModelStreamValue kHostIncrementalValues[] = {\n" +
         valueList(run.estimate) + "};\n";
  out += "// The batch optimum from the run's initial values, pose " + id(run.anchor.id) +
         " fixed (" + (batch.converged ? "converged" : "NOT converged") + ", " +
         std::to_string(batch.iterations) + " iterations).\n";
  out += "inline constexpr double kBatchChi2 = " + number(batch.chi2) + ";\n";
  return out + "\n}  // namespace lslam::stream::" + name_space + "\n";
}

}  // namespace lslam::sim
