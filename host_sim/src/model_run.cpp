#include "host_sim/model_run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <unordered_map>

#include "host_sim/model_steps.h"
#include "host_sim/place_smoother.h"
#include "lslam/factors/merged_measurement.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"
#include "lslam/solver/compact_pose_graph.h"
#include "lslam/solver/smoother.h"

namespace lslam::sim {

namespace {

// The updates a spread reordering may take before it is given up.
constexpr Index kSpreadReorderUpdates = 256;

// ---- Values between the host's parameters and the firmware's types --------------------------

template <class V>
V toValue(const Eigen::VectorXd& p) {
  if constexpr (std::is_same_v<V, SE2>) {
    return SE2(p(0), p(1), p(2));
  } else if constexpr (std::is_same_v<V, SE3>) {
    // The solver takes unit quaternions; files print them to 6-9 digits.
    const Eigen::Quaterniond q = Eigen::Quaterniond(p(6), p(3), p(4), p(5)).normalized();
    return SE3(SO3(q), p.head<3>());
  } else {
    return V(typename V::Vector(p));
  }
}

Eigen::VectorXd toParameters(const SE2& x) {
  return Eigen::Vector3d(x.x(), x.y(), x.theta());
}
Eigen::VectorXd toParameters(const SE3& x) {
  Eigen::VectorXd p(7);
  const Eigen::Quaterniond& q = x.rotation().quaternion();
  p << x.translation(), q.x(), q.y(), q.z(), q.w();
  return p;
}
template <int N>
Eigen::VectorXd toParameters(const Point<N>& l) {
  return l.vector();
}

// ---- The host's factor kinds as the model's -------------------------------------------------

// The host's name of each firmware factor kind.
template <class F>
struct HostKind;
template <>
struct HostKind<PriorSE2Factor> : std::integral_constant<FactorKind, FactorKind::PriorSE2> {};
template <>
struct HostKind<BetweenSE2Factor> : std::integral_constant<FactorKind, FactorKind::BetweenSE2> {};
template <>
struct HostKind<PriorPoint2Factor> : std::integral_constant<FactorKind, FactorKind::PriorPoint2> {};
template <>
struct HostKind<PointObservationSE2Factor>
    : std::integral_constant<FactorKind, FactorKind::PointXY2> {};
template <>
struct HostKind<RangeBearingSE2Factor>
    : std::integral_constant<FactorKind, FactorKind::RangeBearing2> {};
template <>
struct HostKind<PriorSE3Factor> : std::integral_constant<FactorKind, FactorKind::PriorSE3> {};
template <>
struct HostKind<BetweenSE3Factor> : std::integral_constant<FactorKind, FactorKind::BetweenSE3> {};
template <>
struct HostKind<PriorPoint3Factor> : std::integral_constant<FactorKind, FactorKind::PriorPoint3> {};
template <>
struct HostKind<PointObservationSE3Factor>
    : std::integral_constant<FactorKind, FactorKind::PointXYZ3> {};

// fn(F*) for the factor kind F of the model that the host calls `kind`; std::invalid_argument if
// the model has none.
template <class Model, class Fn>
void visitHostKind(FactorKind kind, Fn&& fn) {
  bool found = false;
  for (int k = 0; k < Model::Factors::kSize; ++k) {
    visitKind<typename Model::Factors>(k, [&](auto* tag) {
      using F = std::remove_pointer_t<decltype(tag)>;
      if (HostKind<F>::value != kind) return;
      found = true;
      fn(tag);
    });
  }
  if (!found) {
    throw std::invalid_argument(std::string("a factor the model has not: ") + factorKindName(kind));
  }
}

// ---- Steps -----------------------------------------------------------------------------------

// A step is odometry when every between factor it holds links its new pose and the pose introduced
// just before (landmark observations do not change that); any other between factor makes it a loop
// closure (in file order, one between two poses seen before too).
StepKind classify(const ModelDataset& d, const ModelStep& step, std::int64_t previous_pose) {
  if (previous_pose < 0) return StepKind::First;
  for (std::size_t k : step.factors) {
    const ModelFactor& f = d.factors[k];
    if (f.kind != FactorKind::BetweenSE2 && f.kind != FactorKind::BetweenSE3) continue;
    const std::int64_t a = f.first.id, b = f.second.id;
    const std::int64_t pose = step.new_pose.id;
    if (!((a == pose && b == previous_pose) || (b == pose && a == previous_pose))) {
      return StepKind::LoopClosure;
    }
  }
  return StepKind::Odometry;
}

// The step's rejection as a DatasetError at its first factor's line (`compact`: a step of
// CompactPoseGraph, which checks more).
[[noreturn]] void rejectStep(const ModelDataset& d, const ModelStep& step, std::size_t index,
                             Status status, const std::string& note, bool compact = false) {
  constexpr std::size_t kMaxLines = 10;
  std::string reason =
      "step " + std::to_string(index) + " (pose " + std::to_string(step.new_pose.id);
  if (!step.factors.empty()) {
    reason += step.factors.size() == 1 ? ", factor at line " : ", factors at lines ";
    for (std::size_t k = 0; k < step.factors.size() && k < kMaxLines; ++k) {
      reason += (k == 0 ? "" : ", ") + std::to_string(d.factors[step.factors[k]].line);
    }
    if (step.factors.size() > kMaxLines) {
      reason += ", ... (" + std::to_string(step.factors.size()) + " factors)";
    }
  }
  reason += std::string(") rejected: ") + toString(status) + note;
  // The readers bound every field: a value past the bound was composed (an initial value from the
  // estimate and a measurement, a landmark placed from its observation).
  if (status == Status::InvalidArgument) {
    reason +=
        " (an initial value composed from the estimate and a measurement lies beyond the "
        "solver's coordinate range, |value| <= 1e9 m";
    reason += compact ? "; or a measurement's standard deviation does (an information below "
                        "about 1e-18), which the compact graph's covariances cannot carry)"
                      : ")";
  }
  // Valid on their own, these factors met a system that rounding had made singular: the cause is
  // usually in an earlier step, which the solver accepted.
  if (status == Status::NotPositiveDefinite) {
    reason +=
        " (the graph up to this step is numerically singular: an earlier measurement may constrain "
        "a variable far more weakly or strongly than its neighbours, or be grossly inconsistent)";
  }
  const std::size_t line = step.factors.empty() ? 0 : d.factors[step.factors.front()].line;
  throw DatasetError(d.name, line, reason);
}

// The incremental solver anchors step 0's pose and knows no FIX. One fixed pose only sets the
// gauge: anchoring another pose gives the same optimum moved rigidly, so a FIX of another pose is
// noted (and the batch reference anchors the same pose as the solver). Two fixed poses constrain
// the problem itself, which the solver cannot do: an error at the FIX naming the second one.
std::string checkFixed(const ModelDataset& d, const VariableKey& anchor) {
  const auto lineOf = [&](std::size_t k) {
    return k < d.fixed_lines.size() ? d.fixed_lines[k] : std::size_t{0};
  };
  std::size_t first = d.fixed.size();
  for (std::size_t k = 0; k < d.fixed.size(); ++k) {
    const VariableKey& key = d.fixed[k];
    if (key.role != VariableRole::Pose) continue;
    if (first == d.fixed.size()) {
      first = k;
    } else if (key.id != d.fixed[first].id) {
      throw DatasetError(d.name, lineOf(k),
                         "FIX " + std::to_string(key.id) + ": a second fixed pose (FIX " +
                             std::to_string(d.fixed[first].id) + " at line " +
                             std::to_string(lineOf(first)) +
                             "); the incremental solver fixes one pose, its first");
    }
  }
  if (first == d.fixed.size() || anchor.id < 0 || d.fixed[first].id == anchor.id) return {};
  return d.name + ":" + std::to_string(lineOf(first)) + ": FIX " +
         std::to_string(d.fixed[first].id) + ": the incremental solver anchors pose " +
         std::to_string(anchor.id) +
         " (its first) instead, and so does the batch reference; the optimum is the same up to a "
         "rigid motion";
}

template <class Model>
class Runner {
 public:
  using Solver = SizedSmoother<Model>;
  using Pose = TypeAtT<0, typename Model::Variables>;
  // A pose-only model's "landmark" is its pose kind, never used.
  using Landmark = TypeAtT<Model::Variables::kSize - 1, typename Model::Variables>;
  using Variable = ModelVariableInput<Model>;
  using Measurement = ModelFactorInput<Model>;

  using Clock = std::chrono::steady_clock;

  Runner(const ModelDataset& d, const IncrementalOptions& options) : d_(d), options_(options) {}

  ModelEstimate estimateOf(const Solver& solver) const {
    ModelEstimate estimate;
    for (Index v = 0; v < solver.variables(); ++v) {
      const bool pose = solver.kindAt(v) == 0;
      const VariableKey key{pose ? VariableRole::Pose : VariableRole::Landmark, solver.idAt(v)};
      estimate[key] = pose ? toParameters(solver.template estimateAt<Pose>(v))
                           : toParameters(solver.template estimateAt<Landmark>(v));
    }
    return estimate;
  }

  // Calls options_.progress after step s if the interval has passed or s is the last step.
  void reportProgress(const Solver& solver, std::size_t steps, std::size_t s,
                      Clock::time_point start) {
    const auto now = Clock::now();
    const double since = std::chrono::duration<double>(now - last_report_).count();
    if (s + 1 < steps && since < options_.progress_interval_s) return;
    last_report_ = now;
    RunProgress p;
    p.steps_done = s + 1;
    p.steps_total = steps;
    p.wall_seconds = std::chrono::duration<double>(now - start).count();
    p.chi2 = solver.chi2();
    options_.progress(p);
  }

  ModelRun run() {
    const std::vector<ModelStep> steps = buildModelSteps(d_, options_.order);
    ModelRun out;
    if (!steps.empty()) out.anchor = steps.front().new_pose;
    out.gauge_note = checkFixed(d_, out.anchor);
    SolverOptions solver_options = options_.solver;
    solver_options.solve_after_update = false;  // solve() below, every N steps
    out.capacities = modelCapacities(d_, options_.order, options_.factor_blocks,
                                     solver_options.spread_reorder_products);
    const auto solver = std::make_unique<Solver>(out.capacities, solver_options);
    out.solver_bytes = solver->bytes();
    out.steps.reserve(steps.size());

    // Every step's inputs are converted before the clock starts (the robot has them in hand).
    std::vector<Measurement> factors;
    std::vector<Variable> variables;
    std::int64_t previous_pose = -1;
    const auto start = Clock::now();
    for (std::size_t s = 0; s < steps.size(); ++s) {
      const ModelStep& step = steps[s];
      variables.clear();
      introduce(*solver, step, variables, out.initial);
      factors.clear();
      for (std::size_t k : step.factors)
        factors.push_back(modelFactorInput<Model>(d_, d_.factors[k]));

      StepRecord record;
      record.index = s;
      record.kind = classify(d_, step, previous_pose);
      const bool solve_now =
          (s + 1) % static_cast<std::size_t>(options_.solve_every) == 0 || s + 1 == steps.size();
      const auto t0 = Clock::now();
      const Status status =
          solver->update(variables.data(), static_cast<Index>(variables.size()), factors.data(),
                         static_cast<Index>(factors.size()), &record.result);
      const auto t_solve = Clock::now();
      if (status == Status::Ok && solve_now) solver->solve(false, &record.result);
      const auto t1 = Clock::now();
      if (status != Status::Ok)
        rejectStep(d_, step, s, status, capacityNote(*solver, step, status));
      record.microseconds = std::chrono::duration<double, std::micro>(t1 - t0).count();
      record.solve_microseconds = std::chrono::duration<double, std::micro>(t1 - t_solve).count();
      out.total_seconds += record.microseconds * 1e-6;
      out.reorders += record.result.reordered ? 1 : 0;
      out.peak_factor_blocks = std::max(out.peak_factor_blocks, record.result.factor_blocks);
      out.steps.push_back(record);
      if (step.new_pose.id >= 0) previous_pose = step.new_pose.id;
      if (options_.progress) reportProgress(*solver, steps.size(), s, start);
    }
    out.estimate = estimateOf(*solver);
    out.poses = solver->poses();
    out.landmarks = solver->landmarks();
    out.factors = solver->factors();
    out.factor_blocks = solver->factorBlocks();
    return out;
  }

 private:
  // Which capacity a rejected step met, for its message (empty unless CapacityExhausted). The
  // graph's capacities are the run's exact counts: it is the block pool, which --factor-blocks
  // sets.
  static std::string capacityNote(const Solver& solver, const ModelStep& step, Status status) {
    if (status != Status::CapacityExhausted) return {};
    const SmootherCapacities& c = solver.capacities();
    const auto& graph = solver.graph();
    const Index landmarks = static_cast<Index>(step.new_landmarks.size());
    const bool graph_full =
        (step.new_pose.id >= 0 && graph.freeVariablesOfKind(0) < 1) ||
        (landmarks > 0 && (Model::Variables::kSize < 2 ||
                           graph.freeVariablesOfKind(Model::Variables::kSize - 1) < landmarks)) ||
        graph.freeFactors() < static_cast<Index>(step.factors.size());
    if (graph_full) {
      return " (the graph's: " + std::to_string(c.poses) + " poses, " +
             std::to_string(c.landmarks) + " landmarks, " + std::to_string(c.factors) + " factors)";
    }
    return " (the Cholesky factor's block pool, " + std::to_string(c.factor_blocks) +
           " blocks; lslam-sim run --factor-blocks N sets a larger one, e.g. --factor-blocks " +
           std::to_string(2 * static_cast<std::int64_t>(c.factor_blocks)) + ")";
  }

  // The variables the step introduces, with their initial values from the solver's current
  // estimate of the variables their first factors name (model_steps.h, INITIAL VALUES).
  void introduce(const Solver& solver, const ModelStep& step, std::vector<Variable>& variables,
                 ModelEstimate& initial) {
    ModelEstimate current;
    for (std::size_t k : step.factors) {
      const ModelFactor& f = d_.factors[k];
      for (const VariableKey& key : {f.first, f.second}) {
        if (arity(f.kind) == 1 && key != f.first) continue;
        if (current.count(key) != 0) continue;
        if (key.role == VariableRole::Pose) {
          Pose x;
          if (solver.template estimate<Pose>(key.id, &x) == Status::Ok) {
            current[key] = toParameters(x);
          }
        } else {
          Landmark l;
          if (solver.template estimate<Landmark>(key.id, &l) == Status::Ok) {
            current[key] = toParameters(l);
          }
        }
      }
    }
    if (step.new_pose.id >= 0) {
      const Eigen::VectorXd value = initialValue(d_, step, step.new_pose, current);
      current[step.new_pose] = value;
      initial[step.new_pose] = value;
      variables.push_back(modelVariableInput<Model>(step.new_pose, value));
    }
    for (const VariableKey& key : step.new_landmarks) {
      const Eigen::VectorXd value = initialValue(d_, step, key, current);
      initial[key] = value;
      variables.push_back(modelVariableInput<Model>(key, value));
    }
  }

  const ModelDataset& d_;
  IncrementalOptions options_;
  Clock::time_point last_report_{};
};

// The compact run (--max-poses, lslam/solver/compact_pose_graph.h): a pose graph of at most
// max_poses nodes, every pose of the file a place on them. Each step is its pose's odometry from
// the previous pose and its loop closures to earlier poses, in the file's measurements.
template <class Model>
class CompactRunner {
 public:
  using Solver = SizedSmoother<Model>;
  using Pose = TypeAtT<0, typename Model::Variables>;
  using Between = typename Model::PoseBetween;
  using Matrix = Eigen::Matrix<double, Pose::kDof, Pose::kDof>;
  using Graph = CompactPoseGraph<Model>;
  using Landmark = typename Graph::Landmark;
  using Observation = typename Graph::Observation;
  using Clock = std::chrono::steady_clock;

  CompactRunner(const ModelDataset& d, const IncrementalOptions& options)
      : d_(d), options_(options) {}

  ModelRun run() {
    const std::vector<ModelStep> steps = buildModelSteps(d_, StepOrder::Online);
    ModelRun out;
    if (steps.empty()) return out;
    out.anchor = steps.front().new_pose;
    out.gauge_note = checkFixed(d_, out.anchor);
    SolverOptions solver_options = options_.solver;
    solver_options.solve_after_update = false;  // solve() below, once per step
    out.capacities = compactCapacities(d_, options_.max_poses, options_.factor_blocks);
    const auto solver = std::make_unique<Solver>(out.capacities, solver_options);
    CompactPoseGraph<Model> graph(*solver);
    out.solver_bytes = solver->bytes();
    out.steps.reserve(steps.size());
    CompactStats stats;

    std::unordered_map<std::int64_t, Place<Pose>> places;
    // What the robot logs for the trajectory's estimate at the end (place_smoother.h): every
    // step's place, odometry, loop closures and observations; the log's index of each pose id.
    std::vector<std::int64_t> ids;
    std::vector<Place<Pose>> trajectory;
    std::vector<LoggedPose<Pose>> log;
    std::vector<std::vector<Observation>> logged_observations;
    std::unordered_map<std::int64_t, std::size_t> log_index;
    std::vector<PlaceClosure<Pose>> closures;
    std::vector<Observation> observations;
    std::int64_t previous = -1;
    for (std::size_t s = 0; s < steps.size(); ++s) {
      const ModelStep& step = steps[s];
      StepRecord record;
      record.index = s;
      record.kind = classify(d_, step, previous);
      if (step.new_pose.id < 0) {
        throw std::invalid_argument(d_.name +
                                    ": --max-poses runs streams whose every step "
                                    "adds a pose");
      }
      Status status = Status::Ok;
      LoggedPose<Pose> logged;
      Pose odometry;
      Matrix information = Matrix::Zero();
      closures.clear();
      observations.clear();
      if (s == 0) {
        for (const std::size_t k : step.factors) {
          const ModelFactor& f = d_.factors[k];
          const ModelFactorInput<Model> in = modelFactorInput<Model>(d_, f);
          if (observation(in, f, step, observations)) continue;
          refuseUnsupported(in, f);
          throw DatasetError(d_.name, f.line, "--max-poses: the first pose has a between factor");
        }
        const Pose first = toValue<Pose>(initialValue(d_, step, step.new_pose, {}));
        const auto t0 = Clock::now();
        status = graph.start(first, &record.result);
        CompactStepResult c;
        if (status == Status::Ok && !observations.empty()) {
          status = graph.addObservations(observations.data(),
                                         static_cast<Index>(observations.size()), &c);
          if (status == Status::Ok && c.updates > 0) solver->solve(false);
        }
        record.microseconds = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
      } else {
        bool have_odometry = false;
        for (const std::size_t k : step.factors) {
          const ModelFactor& f = d_.factors[k];
          const ModelFactorInput<Model> in = modelFactorInput<Model>(d_, f);
          if (observation(in, f, step, observations)) continue;
          refuseUnsupported(in, f);
          // Every measurement as the new pose seen from the other one.
          Pose z = in.template measurementAs<Between>();
          Matrix info = in.template informationAs<Between>();
          const bool forward = f.second.id == step.new_pose.id;
          const std::int64_t other = forward ? f.first.id : f.second.id;
          if (!forward) {
            info = reversedBetweenInformation(z, info);
            z = z.inverse();
          }
          if (other == previous && !have_odometry) {
            odometry = z;
            information = info;
            have_odometry = true;
          } else {
            closures.push_back(PlaceClosure<Pose>{places.at(other), z, info});
            logged.closures.push_back(
                {log_index.at(other), z, betweenTangentCovariance<Pose>(info)});
          }
        }
        if (!have_odometry) {
          throw DatasetError(d_.name, d_.factors[step.factors.front()].line,
                             "--max-poses: pose " + std::to_string(step.new_pose.id) +
                                 " has no odometry from pose " + std::to_string(previous));
        }
        logged.odometry = odometry;
        logged.odometry_covariance = betweenTangentCovariance<Pose>(information);
        // The pose's value when introduced: the current place's estimate and the odometry.
        out.initial[step.new_pose] =
            toParameters(graph.estimate(graph.current()).compose(odometry));
        CompactStepResult c;
        const auto t0 = Clock::now();
        status = graph.addStep(odometry, information, closures.data(),
                               static_cast<Index>(closures.size()), observations.data(),
                               static_cast<Index>(observations.size()), &c);
        const auto t_solve = Clock::now();
        if (status == Status::Ok && c.updates > 0) solver->solve(false, &record.result);
        const auto t1 = Clock::now();
        record.microseconds = std::chrono::duration<double, std::micro>(t1 - t0).count();
        record.solve_microseconds = std::chrono::duration<double, std::micro>(t1 - t_solve).count();
        record.result.block_products += c.block_products;
        record.result.reordered = c.reordered;
        stats.folded += c.folded;
        stats.dropped += c.dropped;
        stats.relocalized += c.relocalized ? 1 : 0;
      }
      if (status != Status::Ok) rejectStep(d_, step, s, status, "", true);
      record.result.factor_blocks = solver->factorBlocks();
      out.total_seconds += record.microseconds * 1e-6;
      out.reorders += record.result.reordered ? 1 : 0;
      out.peak_factor_blocks = std::max(out.peak_factor_blocks, record.result.factor_blocks);
      out.steps.push_back(record);
      places[step.new_pose.id] = graph.current();
      log_index[step.new_pose.id] = log.size();
      ids.push_back(step.new_pose.id);
      trajectory.push_back(graph.current());
      log.push_back(std::move(logged));
      logged_observations.push_back(observations);
      if (s == 0) out.initial[step.new_pose] = toParameters(graph.estimate(graph.current()));
      introduceLandmarks(graph, step, observations, out.initial);
      previous = step.new_pose.id;
    }
    // Each pose: a node's estimate, or filtered again against the final map and smoothed.
    for (std::size_t k = 0; k < trajectory.size(); ++k) {
      log[k].known = trajectory[k].atNode();
      log[k].estimate = graph.estimate(trajectory[k]);
    }
    const std::vector<Pose> smoothed =
        smoothTrajectory(log, [&](std::size_t k, Pose& x, Matrix& p) {
          correctOnLandmarks(*solver, logged_observations[k], x, p);
        });
    for (std::size_t k = 0; k < ids.size(); ++k) {
      out.estimate[VariableKey{VariableRole::Pose, ids[k]}] = toParameters(smoothed[k]);
    }
    // Landmarks: the solver's estimate; one it had no room for stays at its first sighting.
    for (const auto& [key, value] : out.initial) {
      if (key.role != VariableRole::Landmark) continue;
      const Index l = solver->template indexOf<Landmark>(key.id);
      out.estimate[key] =
          l == kNoIndex ? value : toParameters(solver->template estimateAt<Landmark>(l));
      out.landmarks += l == kNoIndex ? 0 : 1;
    }
    out.poses = static_cast<Index>(places.size());
    out.factors = solver->factors();
    out.factor_blocks = solver->factorBlocks();
    stats.nodes = graph.nodes();
    out.compact = stats;
    return out;
  }

 private:
  // Takes the model's point observation of the step's pose into `observations` (true), or leaves
  // any other factor (false).
  bool observation([[maybe_unused]] const ModelFactorInput<Model>& in,
                   [[maybe_unused]] const ModelFactor& f, [[maybe_unused]] const ModelStep& step,
                   [[maybe_unused]] std::vector<Observation>& observations) const {
    if constexpr (Graph::kLandmarks) {
      using Observed = typename Model::PointObservation;
      if (in.kind != kFactorKind<Model, Observed>) return false;
      if (f.first.id != step.new_pose.id) {
        throw DatasetError(d_.name, f.line, "--max-poses: an observation from an earlier pose");
      }
      observations.push_back(Observation{f.second.id, in.template measurementAs<Observed>(),
                                         in.template informationAs<Observed>()});
      return true;
    }
    return false;
  }

  // Stops at a factor that is neither a between factor nor a point observation (a prior, a
  // range-bearing observation): the compact graph has no place for it.
  void refuseUnsupported(const ModelFactorInput<Model>& in, const ModelFactor& f) const {
    if (in.kind != kFactorKind<Model, Between>) {
      throw DatasetError(d_.name, f.line,
                         "--max-poses takes between factors and point observations");
    }
  }

  // x and its covariance p corrected by the observations of mapped landmarks (their final
  // estimates taken as exact; correctionByObservedPoint, as CompactPoseGraph corrects its place).
  static void correctOnLandmarks([[maybe_unused]] const Solver& solver,
                                 [[maybe_unused]] const std::vector<Observation>& observations,
                                 [[maybe_unused]] Pose& x, [[maybe_unused]] Matrix& p) {
    if constexpr (Graph::kLandmarks) {
      for (const Observation& o : observations) {
        const Index l = solver.template indexOf<Landmark>(o.landmark);
        if (l == kNoIndex) continue;
        const PoseCorrection<Pose> c = correctionByObservedPoint<typename Model::PointObservation>(
            x, p, solver.template estimateAt<Landmark>(l), o.position, o.information);
        if (!c.valid) continue;  // numerically singular: x stays, as the robot's place did
        x = x.retract(c.step);
        p = c.covariance;
      }
    }
  }

  // The initial value of each landmark the step introduces: its first sighting from the step's
  // place.
  void introduceLandmarks([[maybe_unused]] const Graph& graph,
                          [[maybe_unused]] const ModelStep& step,
                          [[maybe_unused]] const std::vector<Observation>& observations,
                          [[maybe_unused]] ModelEstimate& initial) const {
    if constexpr (Graph::kLandmarks) {
      using Observed = typename Model::PointObservation;
      for (const VariableKey& key : step.new_landmarks) {
        for (const Observation& o : observations) {
          if (o.landmark != key.id) continue;
          initial[key] =
              toParameters(Observed::initialize(graph.estimate(graph.current()), o.position));
          break;
        }
      }
    }
  }

  const ModelDataset& d_;
  IncrementalOptions options_;
};

// A 6-vector error of g2o's SE3 convention as the residual pose it measures, (t, q) with the
// quaternion's vector part v and w = sqrt(1 - |v|^2).
Vector7d residualPoseSE3(const Vector6d& e) {
  Vector7d p;
  const double w = std::sqrt(std::max(0.0, 1.0 - e.tail<3>().squaredNorm()));
  p << e.head<3>(), e.tail<3>(), w;
  return p;
}

Vector7d composeSE3(const Vector7d& a, const Vector7d& b) {
  const Eigen::Quaterniond qa(a(6), a(3), a(4), a(5)), qb(b(6), b(3), b(4), b(5));
  const Eigen::Quaterniond q = qa * qb;
  Vector7d c;
  c << a.head<3>() + qa * b.head<3>(), q.x(), q.y(), q.z(), q.w();
  return c;
}

}  // namespace

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

template <class Model>
ModelVariableInput<Model> modelVariableInput(const VariableKey& key, const Eigen::VectorXd& value) {
  using Pose = TypeAtT<0, typename Model::Variables>;
  using Landmark = TypeAtT<Model::Variables::kSize - 1, typename Model::Variables>;
  if (key.role == VariableRole::Pose) {
    return ModelVariableInput<Model>::template make<Pose>(key.id, toValue<Pose>(value));
  }
  if constexpr (Model::Variables::kSize == 1) {
    throw std::invalid_argument("a landmark in a model without landmarks");
  } else {
    return ModelVariableInput<Model>::template make<Landmark>(key.id, toValue<Landmark>(value));
  }
}

template <class Model>
ModelFactorInput<Model> modelFactorInput(const ModelDataset& d, const ModelFactor& f) {
  ModelFactorInput<Model> in;
  visitHostKind<Model>(f.kind, [&](auto* tag) {
    using F = std::remove_pointer_t<decltype(tag)>;
    using M = typename F::Measurement;
    constexpr int kE = F::kErrorDim;
    M z;
    if constexpr (std::is_same_v<M, Vec2> || std::is_same_v<M, Vec3>) {
      z = f.measurement;  // a position in the robot frame, or (range, bearing)
    } else {
      z = toValue<M>(f.measurement);
    }
    const Eigen::Matrix<double, kE, kE> info = solverInformation(d, f);
    in = ModelFactorInput<Model>::template make<F>(f.first.id, f.second.id, z, info);
  });
  return in;
}

template ModelVariableInput<Slam2D> modelVariableInput<Slam2D>(const VariableKey&,
                                                               const Eigen::VectorXd&);
template ModelVariableInput<Slam3D> modelVariableInput<Slam3D>(const VariableKey&,
                                                               const Eigen::VectorXd&);
template ModelVariableInput<PoseSlam2D> modelVariableInput<PoseSlam2D>(const VariableKey&,
                                                                       const Eigen::VectorXd&);
template ModelVariableInput<PoseSlam3D> modelVariableInput<PoseSlam3D>(const VariableKey&,
                                                                       const Eigen::VectorXd&);
template ModelFactorInput<Slam2D> modelFactorInput<Slam2D>(const ModelDataset&, const ModelFactor&);
template ModelFactorInput<Slam3D> modelFactorInput<Slam3D>(const ModelDataset&, const ModelFactor&);
template ModelFactorInput<PoseSlam2D> modelFactorInput<PoseSlam2D>(const ModelDataset&,
                                                                   const ModelFactor&);
template ModelFactorInput<PoseSlam3D> modelFactorInput<PoseSlam3D>(const ModelDataset&,
                                                                   const ModelFactor&);

bool hasLandmarks(const ModelDataset& d) {
  for (const ModelFactor& f : d.factors) {
    if (f.first.role == VariableRole::Landmark || f.second.role == VariableRole::Landmark) {
      return true;
    }
  }
  for (const ModelVertex& v : d.vertices) {
    if (v.key.role == VariableRole::Landmark) return true;
  }
  return false;
}

bool isPoseGraph2D(const ModelDataset& d) {
  if (d.dimension != 2) return false;
  for (const ModelVertex& v : d.vertices) {
    if (v.kind != VariableKind::SE2) return false;
  }
  for (const ModelFactor& f : d.factors) {
    if (f.kind != FactorKind::BetweenSE2 && f.kind != FactorKind::PriorSE2) return false;
  }
  return true;
}

Eigen::MatrixXd solverInformation(const ModelDataset& d, const ModelFactor& f) {
  if (d.convention == ObjectiveConvention::G2o) return f.information;
  switch (f.kind) {
    case FactorKind::BetweenSE2:
    case FactorKind::PriorSE2: {
      // iSAM's translation error is R(z_theta) times g2o's; the angle is the same.
      Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
      J.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(f.measurement(2)).toRotationMatrix();
      return J.transpose() * f.information * J;
    }
    case FactorKind::BetweenSE3:
    case FactorKind::PriorSE3: {
      // iSAM's error of the residual pose z * D(e) (zero at e = 0) as a function of g2o's error e.
      const Vector7d z = f.measurement;
      const Vector7d identity = (Vector7d() << 0, 0, 0, 0, 0, 0, 1).finished();
      auto isamError = [&](const Vector6d& e) -> Vector6d {
        const Vector7d x = composeSE3(z, residualPoseSE3(e));
        return f.kind == FactorKind::BetweenSE3 ? errorBetweenSE3Isam(identity, x, z)
                                                : errorPriorSE3Isam(x, z);
      };
      // Central differences: the error is smooth about zero (angles far from their wraps).
      constexpr double kStep = 1e-6;
      Eigen::Matrix<double, 6, 6> J;
      for (int k = 0; k < 6; ++k) {
        Vector6d plus = Vector6d::Zero(), minus = Vector6d::Zero();
        plus(k) = kStep;
        minus(k) = -kStep;
        J.col(k) = (isamError(plus) - isamError(minus)) / (2.0 * kStep);
      }
      const Eigen::MatrixXd info = J.transpose() * f.information * J;
      return 0.5 * (info + info.transpose());
    }
    default:
      return f.information;  // landmark errors are the same in both conventions
  }
}

namespace {

// fn(Model*) for the model of `d`: a dataset without landmarks runs on the one-size PoseSlam2D or
// PoseSlam3D, whose kernels are the fastest.
template <class Fn>
auto withModelOf(const ModelDataset& d, Fn&& fn) {
  const bool landmarks = hasLandmarks(d);
  if (d.dimension == 3) {
    if (landmarks) return fn(static_cast<Slam3D*>(nullptr));
    return fn(static_cast<PoseSlam3D*>(nullptr));
  }
  if (landmarks) return fn(static_cast<Slam2D*>(nullptr));
  return fn(static_cast<PoseSlam2D*>(nullptr));
}

// The block pool: kBlockMargin times the batch factor's fill (batchFactorBlocks). The incremental
// factor's most live blocks over a run, against that fill: 1.02-1.08 on manhattan_world_500 and
// the generate grids (seed 3, 1000/2000/5000 poses), 1.12-1.42 on ../shared/datasets (intel 1.42,
// parking-garage 1.32, sphere2500 1.30, city10000 1.29) and 1.11-1.36 on the simulate worlds'
// defaults. A full refactorization stages a new factor beside the live one, so the pool needs
// about twice the peak: 2 x 1.42, and 40 % headroom over the worst case seen, is 4.
constexpr double kBlockMargin = 4.0;

Index blockPool(std::int64_t batch_blocks, Index variables) {
  const double pool = std::ceil(kBlockMargin * static_cast<double>(batch_blocks));
  const double most = static_cast<double>(std::numeric_limits<Index>::max());
  return std::max(variables, static_cast<Index>(std::min(pool, most)));
}

template <class Model>
SmootherCapacities capacitiesOf(const ModelDataset& d, StepOrder order, Index factor_blocks,
                                std::int64_t spread_above_products) {
  SmootherCapacities c;
  // The anchor prior, then every step's variables and factors.
  c.factors = 1;
  c.factor_values = kFactorValues<typename Model::PosePrior>;
  for (const ModelStep& step : buildModelSteps(d, order)) {
    if (step.new_pose.id >= 0) ++c.poses;
    c.landmarks += static_cast<Index>(step.new_landmarks.size());
    for (const std::size_t k : step.factors) {
      ++c.factors;
      visitHostKind<Model>(d.factors[k].kind, [&](auto* tag) {
        c.factor_values += kFactorValues<std::remove_pointer_t<decltype(tag)>>;
      });
    }
  }
  const BatchFill fill = batchFactorFill(d);
  c.factor_blocks =
      factor_blocks > 0 ? factor_blocks : blockPool(fill.blocks, c.poses + c.landmarks);
  if (spread_above_products > 0 && fill.products > spread_above_products) {
    c.spread_factor_blocks = c.factor_blocks;
    c.spread_updates = kSpreadReorderUpdates;
  }
  // Mixed block sizes: every block at the largest size, as MaxFactorBlocks * kMax^2 suffices.
  using Sizes = ModelBlockSizes<Model>;
  c.factor_block_values = Sizes::kUniform ? 0 : c.factor_blocks * Sizes::kMax * Sizes::kMax;
  return c;
}

}  // namespace

ModelRun runModelIncremental(const ModelDataset& d, const IncrementalOptions& options) {
  if (options.max_poses > 0) {
    if (hasLandmarks(d)) {
      if (d.dimension == 2) return CompactRunner<Slam2D>(d, options).run();
      return CompactRunner<Slam3D>(d, options).run();
    }
    if (isPoseGraph2D(d)) return CompactRunner<PoseSlam2D>(d, options).run();
    return CompactRunner<PoseSlam3D>(d, options).run();
  }
  return withModelOf(d, [&](auto* model) {
    return Runner<std::remove_pointer_t<decltype(model)>>(d, options).run();
  });
}

SmootherCapacities modelCapacities(const ModelDataset& d, StepOrder order, Index factor_blocks,
                                   std::int64_t spread_above_products) {
  return withModelOf(d, [&](auto* model) {
    return capacitiesOf<std::remove_pointer_t<decltype(model)>>(d, order, factor_blocks,
                                                                spread_above_products);
  });
}

SmootherCapacities compactCapacities(const ModelDataset& d, Index max_poses, Index factor_blocks) {
  const std::vector<ModelStep> steps = buildModelSteps(d, StepOrder::Online);
  SmootherCapacities c;
  c.poses = std::min(max_poses, static_cast<Index>(steps.size()));
  for (const ModelStep& step : steps) c.landmarks += static_cast<Index>(step.new_landmarks.size());
  c.factors = 1 + kCompactFactorsPerNode * (c.poses + c.landmarks);
  // Every factor at the largest kind's size (a between factor's).
  const bool planar = d.dimension == 2;
  const Index largest = planar ? kFactorValues<BetweenSE2Factor> : kFactorValues<BetweenSE3Factor>;
  c.factor_values = c.factors * largest;
  if (factor_blocks > 0) {
    c.factor_blocks = factor_blocks;
  } else {
    c.factor_blocks = blockPool(
        batchFactorBlocks(firstSteps(d, steps, static_cast<std::size_t>(c.poses))), c.poses);
  }
  // Mixed block sizes: every block at the largest size.
  const Index largest_block = planar ? 9 : 36;
  c.factor_block_values = c.landmarks > 0 ? c.factor_blocks * largest_block : 0;
  return c;
}

SolverOptions defaultModelOptions(const ModelDataset& d) {
  const SolverOptions options = withModelOf(d, [](auto* model) {
    return defaultSolverOptions<std::remove_pointer_t<decltype(model)>>();
  });
  const bool range_bearing =
      std::any_of(d.factors.begin(), d.factors.end(),
                  [](const ModelFactor& f) { return f.kind == FactorKind::RangeBearing2; });
  return range_bearing ? withRangeBearingObservations(options) : options;
}

}  // namespace lslam::sim
