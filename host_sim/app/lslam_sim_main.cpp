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
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
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

int generate(const GenerateArgs& args) {
  const SyntheticWorld world = generateManhattanWorld(args.options);
  writeG2oFile(args.out, world.dataset);
  std::printf("wrote %s: %zu poses, %zu measurements\n", args.out.c_str(),
              world.dataset.vertices.size(), world.dataset.edges.size());
  return 0;
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
      return run(args);
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
