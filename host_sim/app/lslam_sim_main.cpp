// lslam-sim: runs a dataset through the firmware's incremental solver and through the independent
// batch solver, and compares them.
//
//   lslam-sim run DATASET [--order online|file] [--solve-every N] [--json] [--csv STEPS.csv]
//                         [--out ESTIMATE.g2o] [--report REPORT.json]
//   lslam-sim generate OUT.g2o [--poses N] [--seed S]
#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <iterator>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "host_sim/batch_solver.h"
#include "host_sim/chi2.h"
#include "host_sim/cli_args.h"
#include "host_sim/dataset_io.h"
#include "host_sim/incremental_run.h"
#include "host_sim/synthetic.h"

namespace {

using namespace lslam::sim;

int usage() {
  std::fprintf(stderr,
               "usage: lslam-sim run DATASET [--order online|file] [--solve-every N] [--json]\n"
               "                 [--csv STEPS.csv] [--out ESTIMATE.g2o] [--report REPORT.json]\n"
               "                 [--relinearize-threshold T] [--relinearize-skip N]\n"
               "                 [--relinearize-urgent T] [--relinearize-partial T]\n"
               "                 [--backsub-tolerance T]\n"
               "                 [--reorder-growth G] [--reorder-excess R]\n"
               "                 [--reorder-path COLUMNS] [--reorder-burst LOOP_CLOSURES]\n"
               "                 [--reorder-relinearized SHARE] [--reorder-refresh G]\n"
               "                 [--relinearize-full-cost RATIO] [--order-in-one-update]\n"
               "                 [--prepare-min-products N]\n"
               "                 [--reorder-top] [--no-row-updates] [--no-linearization-cache]\n"
               "       lslam-sim generate OUT.g2o [--poses N] [--seed S]\n");
  return 2;
}

// A usage error in an option's value (exit status 2, as usage()).
int badValue(const std::string& option, const char* value, const char* expected) {
  std::fprintf(stderr, "lslam-sim: %s: invalid value %s (expected %s)\n", option.c_str(),
               jsonString(value).c_str(), expected);
  return 2;
}

int missingValue(const std::string& option) {
  std::fprintf(stderr, "lslam-sim: %s needs a value\n", option.c_str());
  usage();
  return 2;
}

struct RunArgs {
  std::string dataset;
  StepOrder order = StepOrder::Online;
  int solve_every = 1;
  bool json = false;
  std::string csv, out, report;
  lslam::SolverOptions solver;
};

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

void writeCsv(const std::string& path, const IncrementalRun& run) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path);
  f << "step,kind,microseconds,columns_refactored,variables_solved,variables_relinearized,"
       "reordered,factor_blocks,solve_microseconds,block_products\n";
  for (const StepRecord& s : run.steps) {
    f << s.index << ',' << stepKindName(s.kind) << ',' << s.microseconds << ','
      << s.result.columns_refactored << ',' << s.result.variables_solved << ','
      << s.result.variables_relinearized << ',' << (s.result.reordered ? 1 : 0) << ','
      << s.result.factor_blocks << ',' << s.solve_microseconds << ',' << s.result.block_products
      << '\n';
  }
}

// The estimate with every measurement, the solver's anchor as the FIX (so that the file reads
// back with the same gauge).
void writeEstimate(const std::string& path, const Dataset2D& d, const IncrementalRun& run) {
  Dataset2D out;
  out.name = path;
  std::vector<std::int64_t> ids;
  for (const auto& [id, pose] : run.estimate) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  for (std::int64_t id : ids) out.vertices.push_back(Vertex2D{id, run.estimate.at(id), 0});
  out.edges = d.edges;
  if (run.anchor >= 0) out.fixed = {FixedPose{run.anchor, 0}};
  writeG2oFile(path, out);
}

int run(const RunArgs& args) {
  const Dataset2D d = readDataset2D(args.dataset);
  if (d.vertices.empty() && d.edges.empty()) {
    std::fprintf(stderr, "lslam-sim: %s: no poses/edges to run\n", args.dataset.c_str());
    return 1;
  }
  IncrementalOptions options;
  options.order = args.order;
  options.solve_every = args.solve_every;
  options.solver = args.solver;
  const IncrementalRun inc = runIncremental(d, options);
  if (!inc.gauge_note.empty())
    std::fprintf(stderr, "lslam-sim: note: %s\n", inc.gauge_note.c_str());
  const double chi2_inc = chi2G2o(d, inc.estimate);
  const double chi2_initial = chi2G2o(d, inc.initial);

  // The batch holds the pose the incremental solver anchors fixed (the same gauge), whatever pose
  // the file's FIX names (runIncremental notes it; FIX of two poses it rejects).
  BatchOptions batch_options;
  if (inc.anchor >= 0) batch_options.fixed = {inc.anchor};
  const BatchResult batch = solveBatch2D(d, inc.initial, batch_options);
  double max_diff = 0.0;
  for (const auto& [id, p] : inc.estimate) {
    const Pose2D& q = batch.poses.at(id);
    max_diff = std::max(max_diff, std::hypot(p.x - q.x, p.y - q.y));
  }
  std::vector<double> ms;
  std::vector<double> ms_odometry, ms_loop;
  for (const StepRecord& s : inc.steps) {
    ms.push_back(s.microseconds * 1e-3);
    (s.kind == StepKind::LoopClosure ? ms_loop : ms_odometry).push_back(s.microseconds * 1e-3);
  }
  const double median = percentile(ms, 0.5), p99 = percentile(ms, 0.99),
               worst = percentile(ms, 1.0);

  std::ostringstream js;
  js.precision(10);
  js << "{\"dataset\": " << jsonString(args.dataset) << ", \"poses\": " << inc.estimate.size()
     << ", \"factors\": " << d.edges.size() << ", \"steps\": " << inc.steps.size()
     << ", \"order\": \"" << (args.order == StepOrder::Online ? "online" : "file") << "\""
     << ", \"solve_every\": " << args.solve_every << ", \"chi2_initial\": " << chi2_initial
     << ", \"chi2_incremental\": " << chi2_inc << ", \"chi2_batch\": " << batch.chi2
     << ", \"batch_converged\": " << (batch.converged ? "true" : "false")
     << ", \"batch_iterations\": " << batch.iterations << ", \"batch_s\": " << batch.seconds
     << ", \"batch_stop_reason\": " << jsonString(batch.stop_reason)
     << ", \"max_position_diff\": " << max_diff << ", \"total_s\": " << inc.total_seconds
     << ", \"step_ms\": {\"median\": " << median << ", \"p99\": " << p99 << ", \"max\": " << worst
     << "}, \"odometry_step_ms\": {\"median\": " << percentile(ms_odometry, 0.5)
     << ", \"max\": " << percentile(ms_odometry, 1.0)
     << "}, \"loop_step_ms\": {\"median\": " << percentile(ms_loop, 0.5)
     << ", \"max\": " << percentile(ms_loop, 1.0) << "}, \"reorders\": " << inc.reorders
     << ", \"factor_blocks\": " << inc.factor_blocks << ", \"solver_bytes\": " << inc.solver_bytes
     << ", \"peak_rss_kb\": " << peakRssKb() << "}";

  if (!args.csv.empty()) writeCsv(args.csv, inc);
  if (!args.out.empty()) writeEstimate(args.out, d, inc);
  if (!args.report.empty()) {
    std::ofstream f(args.report);
    if (!f) throw std::runtime_error("cannot write " + args.report);
    f << js.str() << '\n';
  }
  if (args.json) {
    std::cout << js.str() << std::endl;
    return 0;
  }
  const double rel = batch.chi2 > 0 ? 100.0 * (chi2_inc / batch.chi2 - 1.0) : 0.0;
  std::printf("dataset            %s (%s order, solve every %d)\n", args.dataset.c_str(),
              args.order == StepOrder::Online ? "online" : "file", args.solve_every);
  std::printf("poses / measurements  %zu / %zu in %zu steps\n", inc.estimate.size(), d.edges.size(),
              inc.steps.size());
  std::printf("chi2 initial       %.6g\n", chi2_initial);
  std::printf("chi2 incremental   %.6f  (%+.4f%% vs batch)\n", chi2_inc, rel);
  std::printf("chi2 batch         %.6f  (%s, %d iterations, %.3f s: %s)\n", batch.chi2,
              batch.converged ? "converged" : "NOT CONVERGED", batch.iterations, batch.seconds,
              batch.stop_reason.c_str());
  std::printf("max position diff  %.3g m (incremental vs batch)\n", max_diff);
  std::printf("incremental total  %.4f s, per step median %.4f ms, p99 %.4f ms, max %.4f ms\n",
              inc.total_seconds, median, p99, worst);
  std::printf("                   odometry steps max %.4f ms, loop-closure steps max %.4f ms\n",
              percentile(ms_odometry, 1.0), percentile(ms_loop, 1.0));
  std::printf("reorders           %d, factor blocks %d, solver object %zu bytes, peak RSS %ld kB\n",
              static_cast<int>(inc.reorders), static_cast<int>(inc.factor_blocks), inc.solver_bytes,
              peakRssKb());
  return 0;
}

int generate(int argc, char** argv) {
  if (argc < 3) return usage();
  SyntheticOptions options;
  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--poses" || a == "--seed") {
      if (i + 1 >= argc) return missingValue(a);
      const char* v = argv[++i];
      if (a == "--poses") {
        const auto n = parseIntegerArg(v, 1, std::numeric_limits<int>::max());
        if (!n) return badValue(a, v, "an integer >= 1");
        options.poses = static_cast<int>(*n);
      } else {
        const auto n = parseIntegerArg(v, 0, std::numeric_limits<std::uint32_t>::max());
        if (!n) return badValue(a, v, "an integer in 0..4294967295");
        options.seed = static_cast<std::uint32_t>(*n);
      }
    } else {
      std::fprintf(stderr, "lslam-sim: unknown option %s\n", jsonString(a).c_str());
      return usage();
    }
  }
  const SyntheticWorld world = generateManhattanWorld(options);
  writeG2oFile(argv[2], world.dataset);
  std::printf("wrote %s: %zu poses, %zu measurements\n", argv[2], world.dataset.vertices.size(),
              world.dataset.edges.size());
  return 0;
}

// The options of `run` after DATASET into args: 0, or the exit status of a usage error (which names
// the option). Values are parsed strictly: the whole token, reals finite and >= 0.
int parseRunArgs(int argc, char** argv, RunArgs& args) {
  lslam::SolverOptions& so = args.solver;
  struct Flag {
    const char* name;
    bool* target;
    bool value;
  };
  const Flag flags[] = {{"--json", &args.json, true},
                        {"--reorder-top", &so.reorder_affected_top, true},
                        {"--no-row-updates", &so.row_updates, false},
                        {"--no-linearization-cache", &so.cache_linearizations, false},
                        {"--order-in-one-update", &so.prepare_ordering_ahead, false}};
  // Each option with a value: what to do with it (0, or the status of a bad value).
  using Apply = std::function<int(const std::string& option, const char* value)>;
  std::vector<std::pair<std::string, Apply>> value_options = {
      {"--order",
       [&](const std::string& a, const char* v) {
         const std::string order = v;
         if (order != "online" && order != "file") return badValue(a, v, "online or file");
         args.order = order == "online" ? StepOrder::Online : StepOrder::File;
         return 0;
       }},
      {"--solve-every",
       [&](const std::string& a, const char* v) {
         const auto n = parseIntegerArg(v, 1, std::numeric_limits<int>::max());
         if (!n) return badValue(a, v, "an integer >= 1");
         args.solve_every = static_cast<int>(*n);
         return 0;
       }},
      {"--csv", [&](const std::string&, const char* v) { return args.csv = v, 0; }},
      {"--out", [&](const std::string&, const char* v) { return args.out = v, 0; }},
      {"--report", [&](const std::string&, const char* v) { return args.report = v, 0; }},
      {"--prepare-min-products",
       [&](const std::string& a, const char* v) {
         const auto n = parseIntegerArg(v, 0, std::numeric_limits<std::int64_t>::max());
         if (!n) return badValue(a, v, "an integer >= 0");
         so.prepare_ordering_min_products = *n;
         return 0;
       }},
  };
  const std::pair<const char*, double*> reals[] = {
      {"--relinearize-threshold", &so.relinearize_threshold},
      {"--relinearize-urgent", &so.relinearize_urgent_threshold},
      {"--relinearize-partial", &so.relinearize_partial_threshold},
      {"--backsub-tolerance", &so.backsubstitution_tolerance},
      {"--reorder-growth", &so.reorder_growth},
      {"--reorder-excess", &so.reorder_excess_ratio},
      {"--reorder-relinearized", &so.reorder_relinearized_share},
      {"--reorder-refresh", &so.reorder_refresh_growth},
      {"--relinearize-full-cost", &so.relinearize_full_cost_ratio},
  };
  for (const auto& [name, value] : reals) {
    value_options.emplace_back(name, [value = value](const std::string& a, const char* v) {
      const auto x = parseRealArg(v, 0.0, std::numeric_limits<double>::max());
      if (!x) return badValue(a, v, "a finite number >= 0");
      *value = *x;
      return 0;
    });
  }
  const std::pair<const char*, lslam::Index*> indices[] = {
      {"--relinearize-skip", &so.relinearize_skip},
      {"--reorder-path", &so.reorder_path_columns},
      {"--reorder-burst", &so.reorder_burst_loop_closures},
  };
  for (const auto& [name, value] : indices) {
    value_options.emplace_back(name, [value = value](const std::string& a, const char* v) {
      const auto n = parseIntegerArg(v, 0, std::numeric_limits<lslam::Index>::max());
      if (!n) return badValue(a, v, "an integer in 0..2147483647");
      *value = static_cast<lslam::Index>(*n);
      return 0;
    });
  }

  for (int i = 3; i < argc; ++i) {
    const std::string a = argv[i];
    const auto flag = std::find_if(std::begin(flags), std::end(flags),
                                   [&](const Flag& f) { return a == f.name; });
    if (flag != std::end(flags)) {
      *flag->target = flag->value;
      continue;
    }
    const auto option = std::find_if(value_options.begin(), value_options.end(),
                                     [&](const auto& o) { return o.first == a; });
    if (option == value_options.end()) {
      std::fprintf(stderr, "lslam-sim: unknown option %s\n", jsonString(a).c_str());
      return usage();
    }
    if (i + 1 >= argc) return missingValue(a);
    const int status = option->second(a, argv[++i]);
    if (status != 0) return status;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) return usage();
  try {
    if (std::strcmp(argv[1], "generate") == 0) return generate(argc, argv);
    if (std::strcmp(argv[1], "run") != 0 || argc < 3) return usage();
    RunArgs args;
    args.dataset = argv[2];
    const int status = parseRunArgs(argc, argv, args);
    if (status != 0) return status;
    return run(args);
  } catch (const DatasetError& e) {
    std::fprintf(stderr, "lslam-sim: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lslam-sim: %s\n", e.what());
    return 1;
  }
}
