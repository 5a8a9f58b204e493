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
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "host_sim/batch_solver.h"
#include "host_sim/chi2.h"
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

std::string jsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
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

void writeEstimate(const std::string& path, const Dataset2D& d, const IncrementalRun& run) {
  Dataset2D out;
  out.name = path;
  std::vector<std::int64_t> ids;
  for (const auto& [id, pose] : run.estimate) ids.push_back(id);
  std::sort(ids.begin(), ids.end());
  for (std::int64_t id : ids) out.vertices.push_back(Vertex2D{id, run.estimate.at(id), 0});
  out.edges = d.edges;
  out.fixed = {ids.empty() ? 0 : ids.front()};
  writeG2oFile(path, out);
}

int run(const RunArgs& args) {
  const Dataset2D d = readDataset2D(args.dataset);
  IncrementalOptions options;
  options.order = args.order;
  options.solve_every = args.solve_every;
  options.solver = args.solver;
  const IncrementalRun inc = runIncremental(d, options);
  const double chi2_inc = chi2G2o(d, inc.estimate);
  const double chi2_initial = chi2G2o(d, inc.initial);

  BatchOptions batch_options;
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
    if (a == "--poses" && i + 1 < argc) {
      options.poses = std::atoi(argv[++i]);
    } else if (a == "--seed" && i + 1 < argc) {
      options.seed = static_cast<std::uint32_t>(std::strtoul(argv[++i], nullptr, 10));
    } else {
      return usage();
    }
  }
  const SyntheticWorld world = generateManhattanWorld(options);
  writeG2oFile(argv[2], world.dataset);
  std::printf("wrote %s: %zu poses, %zu measurements\n", argv[2], world.dataset.vertices.size(),
              world.dataset.edges.size());
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
    for (int i = 3; i < argc; ++i) {
      const std::string a = argv[i];
      const bool has_value = i + 1 < argc;
      if (a == "--json") {
        args.json = true;
      } else if (a == "--order" && has_value) {
        const std::string v = argv[++i];
        if (v == "online")
          args.order = StepOrder::Online;
        else if (v == "file")
          args.order = StepOrder::File;
        else
          return usage();
      } else if (a == "--solve-every" && has_value) {
        args.solve_every = std::atoi(argv[++i]);
        if (args.solve_every < 1) return usage();
      } else if (a == "--csv" && has_value) {
        args.csv = argv[++i];
      } else if (a == "--out" && has_value) {
        args.out = argv[++i];
      } else if (a == "--report" && has_value) {
        args.report = argv[++i];
      } else if (a == "--relinearize-threshold" && has_value) {
        args.solver.relinearize_threshold = std::atof(argv[++i]);
      } else if (a == "--relinearize-urgent" && has_value) {
        args.solver.relinearize_urgent_threshold = std::atof(argv[++i]);
      } else if (a == "--relinearize-partial" && has_value) {
        args.solver.relinearize_partial_threshold = std::atof(argv[++i]);
      } else if (a == "--relinearize-skip" && has_value) {
        args.solver.relinearize_skip = static_cast<lslam::Index>(std::atol(argv[++i]));
      } else if (a == "--backsub-tolerance" && has_value) {
        args.solver.backsubstitution_tolerance = std::atof(argv[++i]);
      } else if (a == "--reorder-growth" && has_value) {
        args.solver.reorder_growth = std::atof(argv[++i]);
      } else if (a == "--reorder-excess" && has_value) {
        args.solver.reorder_excess_ratio = std::atof(argv[++i]);
      } else if (a == "--reorder-top") {
        args.solver.reorder_affected_top = true;
      } else if (a == "--no-row-updates") {
        args.solver.row_updates = false;
      } else if (a == "--no-linearization-cache") {
        args.solver.cache_linearizations = false;
      } else if (a == "--reorder-relinearized" && has_value) {
        args.solver.reorder_relinearized_share = std::atof(argv[++i]);
      } else if (a == "--reorder-refresh" && has_value) {
        args.solver.reorder_refresh_growth = std::atof(argv[++i]);
      } else if (a == "--relinearize-full-cost" && has_value) {
        args.solver.relinearize_full_cost_ratio = std::atof(argv[++i]);
      } else if (a == "--prepare-min-products" && has_value) {
        args.solver.prepare_ordering_min_products = std::atoll(argv[++i]);
      } else if (a == "--order-in-one-update") {
        args.solver.prepare_ordering_ahead = false;
      } else if (a == "--reorder-path" && has_value) {
        args.solver.reorder_path_columns = std::atoi(argv[++i]);
      } else if (a == "--reorder-burst" && has_value) {
        args.solver.reorder_burst_loop_closures = std::atoi(argv[++i]);
      } else {
        return usage();
      }
    }
    return run(args);
  } catch (const DatasetError& e) {
    std::fprintf(stderr, "lslam-sim: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lslam-sim: %s\n", e.what());
    return 1;
  }
}
