// The public 2D pose graphs, run incrementally to the end in online order as `lslam-sim run` feeds
// them (host_sim/model_run.h, Smoother<PoseSlam2D>): the incremental estimate after the last step
// (no extra iterations) must be within 0.1% of the batch optimum's chi2, and the batch optimum
// must agree with the MANIFEST's reference chi2 to 3 digits. Files that are absent are skipped with
// a message. M3500 also runs in file order, where its loop closures come in one burst.
#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "dataset_files.h"
#include "host_sim/model_batch_solver.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/model_run.h"

using lslam::sim::test::datasetPath;
using lslam::sim::test::present;

using namespace lslam::sim;

namespace {

struct Case {
  const char* file;
  double reference_chi2;  // ../shared/datasets/MANIFEST.md, section 2 (LM column)
};

// The dataset at 2d/`file`, or nothing (with a SKIP message) when it is absent.
bool readIfPresent(const std::string& file, ModelDataset* d) {
  const std::string path = datasetPath("2d/" + file);
  if (!present(path)) return false;
  *d = readModelDataset(path);
  return true;
}

ModelRun run(const ModelDataset& d, StepOrder order) {
  IncrementalOptions options;
  options.order = order;
  options.solver = defaultModelOptions(d);
  return runModelIncremental(d, options);
}

void runCase(const Case& c) {
  const std::string name = c.file;
  CAPTURE(name);
  ModelDataset d;
  if (!readIfPresent(name, &d)) return;
  REQUIRE(isPoseGraph2D(d));
  const ModelRun online = run(d, StepOrder::Online);
  const double chi2_incremental = chi2(d, online.estimate);
  BatchOptions batch_options;
  batch_options.fixed.push_back(online.anchor.id);
  const ModelBatchResult batch = solveModelBatch(d, online.initial, batch_options);
  MESSAGE(name << ": incremental chi2 " << chi2_incremental << " in " << online.total_seconds
               << " s; batch chi2 " << batch.chi2 << " (" << batch.stop_reason << ")");
  REQUIRE(batch.converged);
  CHECK(std::abs(batch.chi2 - c.reference_chi2) <= 5e-4 * c.reference_chi2);
  CHECK(chi2_incremental <= batch.chi2 * 1.001);
  CHECK(chi2_incremental >= batch.chi2 * (1.0 - 1e-9));
}

}  // namespace

TEST_CASE("M3500.g2o in file order: its 1,954 loop closures all in the last step") {
  // The file lists its loop closures after every pose. In the chain's order their fill overflows
  // any pool sized for the graph; the solver must take them in a fresh ordering (at once, as a
  // burst) and still hold a factor of the online run's size.
  ModelDataset d;
  if (!readIfPresent("M3500.g2o", &d)) return;
  const ModelRun file_order = run(d, StepOrder::File);
  const ModelRun online = run(d, StepOrder::Online);
  REQUIRE(!file_order.steps.empty());
  const StepRecord& last = file_order.steps.back();
  CHECK(last.result.factors_added > 1900);
  CHECK(last.result.reordered);
  CHECK(!last.result.reordered_for_room);
  MESSAGE("M3500 file order: last step " << last.microseconds << " us, " << file_order.factor_blocks
                                         << " blocks (online " << online.factor_blocks << ")");
  CHECK(file_order.factor_blocks < 2 * online.factor_blocks);
}

TEST_CASE("intel.g2o") {
  runCase({"intel.g2o", 546.46});
}
TEST_CASE("manhattanOlson3500.g2o") {
  runCase({"manhattanOlson3500.g2o", 146.08});
}
TEST_CASE("M3500.g2o") {
  runCase({"M3500.g2o", 137.91});
}
TEST_CASE("city10000.g2o") {
  runCase({"city10000.g2o", 511.99});
}
