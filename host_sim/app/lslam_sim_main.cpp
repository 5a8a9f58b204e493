// lslam-sim: runs a dataset through the firmware's incremental solver and through the independent
// batch solver, and compares them.
//
//   lslam-sim run DATASET [--order online|file] [--solve-every N] [--json] [--csv STEPS.csv]
//                         [--out ESTIMATE.g2o] [--report REPORT.json] [--factor-blocks N]
//   lslam-sim simulate WORLD OUT.g2o [--steps N] [--seed S] [parameters]
//   lslam-sim generate OUT.g2o [--poses N] [--seed S]
//   lslam-sim --help | simulate --help
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_set>
#include <vector>

#include "host_sim/chi2.h"
#include "host_sim/cli_args.h"
#include "host_sim/dataset_io.h"
#include "host_sim/map_plot.h"
#include "host_sim/model_batch_solver.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/model_run.h"
#include "host_sim/synthetic.h"
#include "host_sim/trajectory_error.h"
#include "host_sim/worlds.h"

namespace {

// A reordering dearer than this many block products is spread over several updates
// (SolverOptions::spread_reorder_products), on files whose batch factorization is dearer: their
// worst step against a second factor's memory. Per dimension, as a 6 x 6 block product costs about
// ten 3 x 3 ones: 2D about 30 ms here; 3D about 15 ms, which spreads the last reorderings of a
// 2,500-pose sphere (about 20 ms each) at about the same total time.
constexpr std::int64_t kSpreadReorderProducts2D = 12'000'000;
constexpr std::int64_t kSpreadReorderProducts3D = 600'000;

using namespace lslam::sim;

constexpr const char* kUsage =
    "usage: lslam-sim run DATASET [--order online|file] [--solve-every N] [--json]\n"
    "                 [--csv STEPS.csv] [--out ESTIMATE.g2o] [--report REPORT.json]\n"
    "                 [--truth TRUTH] [--plot MAP.svg]\n"
    "                 [--relinearize-threshold T] [--relinearize-skip N]\n"
    "                 [--relinearize-landmark-threshold T (landmark files)]\n"
    "                 [--relinearize-urgent T] [--relinearize-partial T]\n"
    "                 [--urgent-iterations N]\n"
    "                 [--backsub-tolerance T]\n"
    "                 [--reorder-growth G] [--reorder-excess R]\n"
    "                 [--reorder-path COLUMNS] [--reorder-burst LOOP_CLOSURES]\n"
    "                 [--reorder-relinearized SHARE] [--reorder-refresh G]\n"
    "                 [--relinearize-full-cost RATIO] [--order-in-one-update]\n"
    "                 [--prepare-min-products N]\n"
    "                 [--relinearize-defer PRODUCTS] [--relinearize-defer-updates N]\n"
    "                 [--spread-reorder PRODUCTS]\n"
    "                 [--reorder-top] [--no-row-updates]\n"
    "                 [--factor-blocks N] [--max-poses N] [--no-batch]\n"
    "       lslam-sim simulate WORLD OUT.g2o [--steps N] [--seed S] [parameters]\n"
    "                 (WORLD: grid2d, sphere3d, garage3d, points3d; lslam-sim simulate --help)\n"
    "       lslam-sim generate OUT.g2o [--poses N] [--seed S]\n"
    "                 (the measurements of simulate grid2d --landmarks 0 --steps N, no truth)\n";

int usage() {
  std::fputs(kUsage, stderr);
  return 2;
}

// A usage error: its message, then the usage (exit status 2).
int usageError(const std::string& message) {
  std::fprintf(stderr, "lslam-sim: %s\n", message.c_str());
  return usage();
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t i = static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1;
  return v[std::min(i, v.size() - 1)];
}

long peakRssKb() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_maxrss;
}

// A spread reordering's part in a step: started, its block products spent, swapped in or
// abandoned (empty: none).
std::string spreadColumn(const lslam::UpdateResult& r) {
  if (r.spread_started) return "started";
  if (r.spread_abandoned) return "abandoned";
  if (r.spread_swapped) return "swapped:" + std::to_string(r.spread_products);
  if (r.spread_products > 0) return std::to_string(r.spread_products);
  return "";
}

void writeCsv(const std::string& path, const std::vector<StepRecord>& steps) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path);
  f << "step,kind,microseconds,columns_refactored,variables_solved,variables_relinearized,"
       "reordered,factor_blocks,solve_microseconds,block_products,spread\n";
  for (const StepRecord& s : steps) {
    f << s.index << ',' << stepKindName(s.kind) << ',' << s.microseconds << ','
      << s.result.columns_refactored << ',' << s.result.variables_solved << ','
      << s.result.variables_relinearized << ',' << (s.result.reordered ? 1 : 0) << ','
      << s.result.factor_blocks << ',' << s.solve_microseconds << ',' << s.result.block_products
      << ',' << spreadColumn(s.result) << '\n';
  }
}

// What `run` reports: the JSON keys and the summary lines.
struct RunSummary {
  const char* order = "online";
  std::size_t poses = 0, landmarks = 0, factors = 0, steps = 0;
  double chi2_initial = 0, chi2_incremental = 0;
  double chi2_batch = 0, batch_seconds = 0;
  bool batch_converged = false;
  int batch_iterations = 0;
  std::string batch_stop_reason;
  double max_position_diff = 0, total_seconds = 0;
  double median = 0, p99 = 0, worst = 0, odometry_median = 0, odometry_max = 0, loop_median = 0,
         loop_max = 0;
  lslam::Index reorders = 0, factor_blocks = 0, peak_factor_blocks = 0, factor_block_capacity = 0;
  std::size_t solver_bytes = 0;
  std::optional<TrajectoryError> truth;  // with --truth
  std::optional<CompactStats> compact;   // with --max-poses
};

void setStepTimes(const std::vector<StepRecord>& steps, RunSummary& out) {
  std::vector<double> ms, ms_odometry, ms_loop;
  for (const StepRecord& s : steps) {
    ms.push_back(s.microseconds * 1e-3);
    (s.kind == StepKind::LoopClosure ? ms_loop : ms_odometry).push_back(s.microseconds * 1e-3);
  }
  out.median = percentile(ms, 0.5);
  out.p99 = percentile(ms, 0.99);
  out.worst = percentile(ms, 1.0);
  out.odometry_median = percentile(ms_odometry, 0.5);
  out.odometry_max = percentile(ms_odometry, 1.0);
  out.loop_median = percentile(ms_loop, 0.5);
  out.loop_max = percentile(ms_loop, 1.0);
}

std::string toJson(const RunArgs& args, const RunSummary& r) {
  std::ostringstream js;
  js.precision(10);
  js << "{\"dataset\": " << jsonString(args.dataset) << ", \"poses\": " << r.poses
     << ", \"landmarks\": " << r.landmarks << ", \"factors\": " << r.factors
     << ", \"steps\": " << r.steps << ", \"order\": \"" << r.order << "\""
     << ", \"solve_every\": " << args.solve_every << ", \"chi2_initial\": " << r.chi2_initial
     << ", \"chi2_incremental\": " << r.chi2_incremental;
  // Without the batch (--no-batch) its figures are null, not zeros.
  const auto batchValue = [&](auto value) {
    std::ostringstream v;
    v.precision(10);
    if (args.batch) {
      v << value;
    } else {
      v << "null";
    }
    return v.str();
  };
  js << ", \"chi2_batch\": " << batchValue(r.chi2_batch)
     << ", \"batch_converged\": " << (args.batch ? (r.batch_converged ? "true" : "false") : "null")
     << ", \"batch_iterations\": " << batchValue(r.batch_iterations)
     << ", \"batch_s\": " << batchValue(r.batch_seconds)
     << ", \"batch_stop_reason\": " << jsonString(r.batch_stop_reason)
     << ", \"max_position_diff\": " << batchValue(r.max_position_diff)
     << ", \"total_s\": " << r.total_seconds << ", \"step_ms\": {\"median\": " << r.median
     << ", \"p99\": " << r.p99 << ", \"max\": " << r.worst
     << "}, \"odometry_step_ms\": {\"median\": " << r.odometry_median
     << ", \"max\": " << r.odometry_max << "}, \"loop_step_ms\": {\"median\": " << r.loop_median
     << ", \"max\": " << r.loop_max << "}, \"reorders\": " << r.reorders
     << ", \"factor_blocks\": " << r.factor_blocks
     << ", \"factor_blocks_peak\": " << r.peak_factor_blocks
     << ", \"factor_block_capacity\": " << r.factor_block_capacity
     << ", \"solver_bytes\": " << r.solver_bytes << ", \"peak_rss_kb\": " << peakRssKb();
  if (r.compact) {
    js << ", \"max_poses\": " << args.max_poses << ", \"nodes\": " << r.compact->nodes
       << ", \"loop_closures_folded\": " << r.compact->folded
       << ", \"loop_closures_dropped\": " << r.compact->dropped
       << ", \"relocalized_steps\": " << r.compact->relocalized;
  }
  if (r.truth) {
    js << ", \"truth\": " << jsonString(args.truth) << ", \"truth_poses\": " << r.truth->poses
       << ", \"truth_landmarks\": " << r.truth->landmarks
       << ", \"ate_position_rmse\": " << r.truth->ate_position_rmse
       << ", \"ate_rotation_rmse_deg\": " << r.truth->ate_rotation_rmse_deg
       << ", \"landmark_rmse\": ";
    // No landmark scored is no score, not a perfect one.
    if (r.truth->landmarks > 0) {
      js << r.truth->landmark_rmse;
    } else {
      js << "null";
    }
  }
  js << "}";
  return js.str();
}

// A chi2 for the summary: six decimals, or an exponent form for one too large for them to read.
std::string chi2Text(double chi2) {
  char buf[64];
  std::snprintf(buf, sizeof buf, std::fabs(chi2) < 1e12 ? "%.6f" : "%.6e", chi2);
  return buf;
}

void printSummary(const RunArgs& args, const RunSummary& r) {
  const double rel = r.chi2_batch > 0 ? 100.0 * (r.chi2_incremental / r.chi2_batch - 1.0) : 0.0;
  std::printf("dataset            %s (%s order, solve every %d)\n", args.dataset.c_str(), r.order,
              args.solve_every);
  std::printf("poses / landmarks / measurements  %zu / %zu / %zu in %zu steps\n", r.poses,
              r.landmarks, r.factors, r.steps);
  std::printf("chi2 initial       %.6g\n", r.chi2_initial);
  if (args.batch) {
    std::printf("chi2 incremental   %s  (%+.4f%% vs batch)\n", chi2Text(r.chi2_incremental).c_str(),
                rel);
    std::printf("chi2 batch         %s  (%s, %d iterations, %.3f s: %s)\n",
                chi2Text(r.chi2_batch).c_str(), r.batch_converged ? "converged" : "NOT CONVERGED",
                r.batch_iterations, r.batch_seconds, r.batch_stop_reason.c_str());
    std::printf("max position diff  %.3g m (incremental vs batch)\n", r.max_position_diff);
  } else {
    std::printf("chi2 incremental   %s  (batch not run: --no-batch)\n",
                chi2Text(r.chi2_incremental).c_str());
  }
  std::printf("incremental total  %.4f s, per step median %.4f ms, p99 %.4f ms, max %.4f ms\n",
              r.total_seconds, r.median, r.p99, r.worst);
  std::printf("                   odometry steps max %.4f ms, loop-closure steps max %.4f ms\n",
              r.odometry_max, r.loop_max);
  std::printf("reorders           %d, factor blocks %d, solver object %zu bytes, peak RSS %ld kB\n",
              static_cast<int>(r.reorders), static_cast<int>(r.factor_blocks), r.solver_bytes,
              peakRssKb());
  if (r.compact) {
    std::printf(
        "compact graph      %d nodes (--max-poses %d), loop closures folded %d, dropped "
        "%d, relocalized steps %d\n",
        static_cast<int>(r.compact->nodes), static_cast<int>(args.max_poses),
        static_cast<int>(r.compact->folded), static_cast<int>(r.compact->dropped),
        static_cast<int>(r.compact->relocalized));
  }
  if (r.truth) {
    std::printf(
        "ATE                position %.4g m, rotation %.4g deg (%zu poses, rigid alignment)\n",
        r.truth->ate_position_rmse, r.truth->ate_rotation_rmse_deg, r.truth->poses);
    if (r.truth->landmarks > 0) {
      std::printf("landmark RMSE      %.4g m (%zu landmarks, same alignment)\n",
                  r.truth->landmark_rmse, r.truth->landmarks);
    }
  }
}

// The report (file, JSON on stdout or the summary) once the run's own outputs are written.
int report(const RunArgs& args, const RunSummary& summary) {
  const std::string json = toJson(args, summary);
  if (!args.report.empty()) {
    std::ofstream f(args.report);
    if (!f) throw std::runtime_error("cannot write " + args.report);
    f << json << '\n';
  }
  if (args.json) {
    std::cout << json << std::endl;
  } else {
    printSummary(args, summary);
  }
  return 0;
}

// The batch reference's figures.
void setBatch(const ModelBatchResult& batch, RunSummary& r) {
  r.chi2_batch = batch.chi2;
  r.batch_converged = batch.converged;
  r.batch_iterations = batch.iterations;
  r.batch_seconds = batch.seconds;
  r.batch_stop_reason = batch.stop_reason;
}

// The incremental run's figures.
void setRun(const ModelRun& inc, RunSummary& r) {
  r.steps = inc.steps.size();
  r.total_seconds = inc.total_seconds;
  setStepTimes(inc.steps, r);
  r.reorders = inc.reorders;
  r.factor_blocks = inc.factor_blocks;
  r.peak_factor_blocks = inc.peak_factor_blocks;
  r.factor_block_capacity = inc.capacities.factor_blocks;
  r.solver_bytes = inc.solver_bytes;
  r.compact = inc.compact;
}

// One line on stderr, rewritten in place: steps done, steps per second, chi2 so far.
void printProgress(const RunProgress& p) {
  const double rate = p.wall_seconds > 0 ? static_cast<double>(p.steps_done) / p.wall_seconds : 0;
  std::fprintf(stderr, "\rlslam-sim: step %zu/%zu, %.0f steps/s, chi2 %.6g\033[K", p.steps_done,
               p.steps_total, rate, p.chi2);
  if (p.steps_done == p.steps_total) std::fputc('\n', stderr);
}

IncrementalOptions incrementalOptions(const RunArgs& args) {
  IncrementalOptions options;
  options.order = args.order;
  options.solve_every = args.solve_every;
  options.factor_blocks = args.factor_blocks;
  options.max_poses = args.max_poses;
  options.solver = args.solver;
  // Progress only for a person watching: never into a redirected stderr.
  if (isatty(fileno(stderr)) != 0) options.progress = printProgress;
  return options;
}

// What to add to every landmark id in a g2o file: 0 where no landmark id is also a pose id, else
// one past the largest pose id (iSAM files number poses and points apart; g2o has one id space).
std::int64_t landmarkIdOffset(const std::vector<VariableKey>& keys) {
  std::unordered_set<std::int64_t> pose_ids;
  std::int64_t max_pose_id = -1;
  for (const VariableKey& key : keys) {
    if (key.role != VariableRole::Pose) continue;
    pose_ids.insert(key.id);
    max_pose_id = std::max(max_pose_id, key.id);
  }
  for (const VariableKey& key : keys) {
    if (key.role == VariableRole::Landmark && pose_ids.count(key.id) != 0) return max_pose_id + 1;
  }
  return 0;
}

// The model estimate with every measurement, in g2o records, the anchor as the FIX.
void writeModelEstimate(const std::string& path, const ModelDataset& d, const ModelRun& run) {
  ModelDataset out;
  out.name = path;
  out.dimension = d.dimension;
  const auto kinds = variableKinds(d);
  std::vector<VariableKey> keys;
  for (const auto& [key, value] : run.estimate) keys.push_back(key);
  std::sort(keys.begin(), keys.end(), [](const VariableKey& a, const VariableKey& b) {
    return a.role != b.role ? a.role == VariableRole::Pose : a.id < b.id;
  });
  const std::int64_t offset = landmarkIdOffset(keys);
  if (offset != 0) {
    std::fprintf(stderr,
                 "lslam-sim: %s: poses and landmarks share ids; landmark ids written + %lld\n",
                 path.c_str(), static_cast<long long>(offset));
  }
  const auto g2oKey = [offset](VariableKey key) {
    if (key.role == VariableRole::Landmark) key.id += offset;
    return key;
  };
  for (const VariableKey& key : keys) {
    out.vertices.push_back(ModelVertex{g2oKey(key), kinds.at(key), run.estimate.at(key), 0});
  }
  // g2o records: an iSAM file's information goes over as the solver took it, in g2o's error
  // coordinates (solverInformation), so that the file reads back as the problem solved.
  out.factors = d.factors;
  for (ModelFactor& f : out.factors) {
    f.information = solverInformation(d, f);
    f.first = g2oKey(f.first);
    f.second = g2oKey(f.second);
  }
  if (run.anchor.id >= 0) out.fixed = {g2oKey(run.anchor)};
  writeModelG2oFile(path, out);
}

// Any dataset, through Smoother<Model> of its model.
int runModel(const RunArgs& args, const ModelDataset& d) {
  if (d.vertices.empty() && d.factors.empty()) {
    std::fprintf(stderr, "lslam-sim: %s: no poses/edges to run\n", args.dataset.c_str());
    return 1;
  }
  // The truth is read before the run, so that a bad file stops it at once.
  const ModelEstimate truth = args.truth.empty() ? ModelEstimate{} : readGroundTruth(args.truth);
  const ModelRun inc = runModelIncremental(d, incrementalOptions(args));
  if (!inc.gauge_note.empty())
    std::fprintf(stderr, "lslam-sim: note: %s\n", inc.gauge_note.c_str());
  RunSummary r;
  r.order = args.order == StepOrder::Online ? "online" : "file";
  r.poses = static_cast<std::size_t>(inc.poses);
  r.landmarks = static_cast<std::size_t>(inc.landmarks);
  r.factors = d.factors.size();
  r.chi2_incremental = chi2(d, inc.estimate);
  r.chi2_initial = chi2(d, inc.initial);
  // The batch holds the solver's anchor fixed (the same gauge) and starts where the solver did.
  BatchOptions batch_options;
  if (inc.anchor.id >= 0) batch_options.fixed = {inc.anchor.id};
  if (args.batch) {
    const ModelBatchResult batch = solveModelBatch(d, inc.initial, batch_options);
    setBatch(batch, r);
    for (const auto& [key, value] : inc.estimate) {
      const Eigen::VectorXd& other = batch.values.at(key);
      const int n = d.dimension;  // every kind's parameters start with its position
      r.max_position_diff = std::max(r.max_position_diff, (value.head(n) - other.head(n)).norm());
    }
  } else {
    r.batch_stop_reason = "not run (--no-batch)";
  }
  setRun(inc, r);
  if (!args.truth.empty()) {
    r.truth = trajectoryError(inc.estimate, truth, d.dimension, variableKinds(d));
  }
  if (!args.csv.empty()) writeCsv(args.csv, inc.steps);
  if (!args.out.empty()) writeModelEstimate(args.out, d, inc);
  if (!args.plot.empty()) {
    const ModelEstimate aligned = r.truth ? inEstimateFrame(truth, r.truth->alignment) : truth;
    writeMapSvg(args.plot,
                MapPlotInput{&d, &inc.estimate, r.truth ? &aligned : nullptr, args.dataset});
  }
  return report(args, r);
}

int run(const std::vector<std::string>& argv, const RunArgs& args) {
  // Every format reads as a model dataset and runs on Smoother<Model>, whose options start from
  // the model's defaults (the command line, already checked, parsed again over them).
  const ModelDataset model = readModelDataset(args.dataset);
  RunArgs model_args;
  model_args.solver = defaultModelOptions(model);
  model_args.solver.spread_reorder_products =
      model.dimension == 3 ? kSpreadReorderProducts3D : kSpreadReorderProducts2D;
  if (const auto error = parseRunArgs(argv, model_args)) return usageError(*error);
  return runModel(model_args, model);
}

int generate(const GenerateArgs& args) {
  const SyntheticWorld world = generateManhattanWorld(args.options);
  writeG2oFile(args.out, world.dataset);
  std::printf("wrote %s: %zu poses, %zu measurements\n", args.out.c_str(),
              world.dataset.vertices.size(), world.dataset.edges.size());
  return 0;
}

// OUT.g2o -> OUT.truth.g2o (any other name: NAME.truth.g2o).
std::string truthPath(const std::string& out) {
  const std::string ext = ".g2o";
  const bool g2o =
      out.size() > ext.size() && out.compare(out.size() - ext.size(), ext.size(), ext) == 0;
  return (g2o ? out.substr(0, out.size() - ext.size()) : out) + ".truth.g2o";
}

int simulate(const SimulateArgs& args) {
  const SimulatedWorld world = simulateWorld(args.world, args.options);
  const std::string truth = truthPath(args.out);
  writeModelG2oFile(args.out, world.dataset);
  writeModelG2oFile(truth, world.truth);
  std::size_t loops = 0;
  std::size_t observations = 0;
  for (const ModelFactor& f : world.dataset.factors) {
    if (f.second.role == VariableRole::Landmark) {
      ++observations;
    } else if (f.second.id != f.first.id + 1) {
      ++loops;
    }
  }
  const std::size_t landmarks =
      world.truth.vertices.size() - static_cast<std::size_t>(args.options.steps);
  std::printf(
      "wrote %s: %s, %d poses, %zu landmarks, %zu measurements (%zu loop closures, %zu of "
      "them wrong; %zu landmark observations)\n",
      args.out.c_str(), worldKindName(args.world), args.options.steps, landmarks,
      world.dataset.factors.size(), loops, world.outliers.size(), observations);
  std::printf("wrote %s: the ground truth\n", truth.c_str());
  return 0;
}

bool isHelp(const std::string& a) {
  return a == "--help" || a == "-h" || a == "help";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  try {
    const std::string command = argv[1];
    const std::vector<std::string> rest(argv + 2, argv + argc);
    if (command == "run") {
      RunArgs args;
      if (const auto error = parseRunArgs(rest, args)) return usageError(*error);
      return run(rest, args);
    }
    if (isHelp(command)) {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (command == "simulate") {
      if (!rest.empty() && isHelp(rest.front())) {
        std::fputs(simulateHelp(), stdout);
        return 0;
      }
      SimulateArgs args;
      if (const auto error = parseSimulateArgs(rest, args)) return usageError(*error);
      return simulate(args);
    }
    if (command == "generate") {
      GenerateArgs args;
      if (const auto error = parseGenerateArgs(rest, args)) return usageError(*error);
      return generate(args);
    }
    return usageError("unknown command " + jsonString(command));
  } catch (const DatasetError& e) {
    std::fprintf(stderr, "lslam-sim: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lslam-sim: %s\n", e.what());
    return 1;
  }
}
