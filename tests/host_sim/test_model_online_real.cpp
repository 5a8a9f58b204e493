// The firmware's Smoother on the real 3D and landmark datasets of ../shared/datasets (when
// present), in online order to the end, as `lslam-sim run` feeds it (host_sim/model_run.h): the
// final incremental estimate, with no iteration after the last update, within 0.1 % of the batch
// optimum that the independent reference solver reaches from the same initial values with the
// same pose fixed (both chi2 in the file's convention).
#include <doctest/doctest.h>

#include <string>

#include "dataset_files.h"
#include "host_sim/model_batch_solver.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/model_run.h"

using lslam::sim::test::datasetPath;
using lslam::sim::test::present;

namespace sim = lslam::sim;

namespace {

constexpr double kWithin = 1e-3;  // 0.1 %

void runOnline(const std::string& file) {
  const std::string path = datasetPath(file);
  if (!present(path)) return;
  const sim::ModelDataset d = sim::readModelDataset(path);
  sim::IncrementalOptions run_options;
  run_options.solver = sim::defaultModelOptions(d);
  const sim::ModelRun run = sim::runModelIncremental(d, run_options);
  sim::BatchOptions batch_options;
  batch_options.fixed = {run.anchor.id};
  const sim::ModelBatchResult batch = sim::solveModelBatch(d, run.initial, batch_options);
  const double chi2 = sim::chi2(d, run.estimate);
  MESSAGE(file << ": " << run.poses << " poses, " << run.landmarks << " landmarks, "
               << d.factors.size() << " factors; incremental chi2 " << chi2 << " ("
               << 100.0 * (chi2 / batch.chi2 - 1.0) << " % above the batch's " << batch.chi2
               << "), " << run.total_seconds << " s, " << run.reorders << " reorderings");
  CHECK(run.steps.size() == static_cast<std::size_t>(run.poses));
  REQUIRE(batch.converged);
  CHECK(chi2 <= batch.chi2 * (1.0 + kWithin));
  CHECK(chi2 >= batch.chi2 * (1.0 - 1e-9));
}

}  // namespace

TEST_CASE("sphere2500.g2o online") {
  runOnline("3d/sphere2500.g2o");
}
TEST_CASE("parking-garage.g2o online") {
  runOnline("3d/parking-garage.g2o");
}
TEST_CASE("smallGrid3D.g2o online") {
  // 125 poses and 297 measurements, far from linear: it converges within its updates
  // (SolverOptions::converge_below_variables), with the defaults.
  runOnline("3d/smallGrid3D.g2o");
}
TEST_CASE("tinyGrid3D.g2o and pose3example.txt online (tiny, far from linear)") {
  runOnline("3d/tinyGrid3D.g2o");
  runOnline("3d/pose3example.txt");
}
TEST_CASE("pose2example.txt online") {
  runOnline("2d/pose2example.txt");
}
TEST_CASE("victoriaPark.txt online (iSAM objective)") {
  runOnline("2d/victoriaPark.txt");
}
TEST_CASE("torus2000Points.txt online (iSAM objective)") {
  runOnline("3d/torus2000Points.txt");
}
