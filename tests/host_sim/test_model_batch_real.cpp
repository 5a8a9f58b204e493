// The batch reference solver for every model (host_sim/model_batch_solver.h) on the real datasets
// of ../shared/datasets (when present): the batch optimum matches the MANIFEST's values (section
// 2), each within 0.05 %. The MANIFEST values are printed to 5-6 significant digits and come from
// a quick numeric-Jacobian LM run (parking-garage: "slow tail"), so the check allows rounding
// (<= 5e-5 relative) plus a possibly early stop of that run, while any other local optimum or a
// wrong objective (e.g. victoriaPark's g2o-style odometry error: 6188.29 vs 6183.93, 0.07 %) fails.
//
// Starts: initialEstimate (the file's vertices; for edge-only files every variable initialised
// when first seen from the first factor reaching it, i.e. dead reckoning). From that start
// victoriaPark's batch ends in a far local minimum (chi2 ~6.5e5, printed, not checked: the
// landmarks are placed by ~300 m of drifted odometry); its MANIFEST value is checked from the
// initial values an online (incremental) solver would use: each variable initialised when first
// seen from the *current estimate*, here re-estimated every kOnlineChunk factors (onlineStart).
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <sstream>
#include <string>

#include "dataset_files.h"
#include "host_sim/model_batch_solver.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset_io.h"

using lslam::sim::test::datasetPath;
using lslam::sim::test::present;

namespace sim = lslam::sim;

namespace {

constexpr double kTolerance = 5e-4;  // 0.05 %
constexpr std::size_t kOnlineChunk = 500;
constexpr int kOnlineIterations = 3;

std::string describe(const std::string& what, const sim::ModelBatchResult& r, double reference) {
  std::ostringstream msg;
  msg.precision(10);
  msg << what << ": chi2 " << r.chi2_initial << " -> " << r.chi2 << " (MANIFEST "
      << (reference > 0.0 ? std::to_string(reference) : std::string("none")) << ") in "
      << r.iterations << " iterations, " << r.seconds << " s, converged " << r.converged << " ("
      << r.stop_reason << ")";
  return msg.str();
}

// The online initial values of an incremental run, emulated: the factors in file order,
// kOnlineChunk at a time; each new variable initialised from the current estimate (initialEstimate
// of the prefix with the current values as vertices), then kOnlineIterations LM iterations on the
// prefix.
sim::ModelEstimate onlineStart(const sim::ModelDataset& d, double* seconds) {
  const auto start = std::chrono::steady_clock::now();
  const auto kinds = sim::variableKinds(d);
  sim::BatchOptions o;
  o.max_iterations = kOnlineIterations;
  sim::ModelEstimate current;
  for (std::size_t end = kOnlineChunk;; end += kOnlineChunk) {
    sim::ModelDataset prefix = d;
    prefix.factors.resize(std::min(end, d.factors.size()));
    prefix.vertices.clear();
    for (const auto& [key, value] : current) {
      sim::ModelVertex v;
      v.key = key;
      v.kind = kinds.at(key);
      v.value = value;
      prefix.vertices.push_back(v);
    }
    current = sim::solveModelBatch(prefix, sim::initialEstimate(prefix), o).values;
    if (end >= d.factors.size()) break;
  }
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return current;
}

// Solves `file` (relative to the datasets folder) from initialEstimate (or, with `online`, from
// onlineStart); checks the MANIFEST value unless reference <= 0.
void solveFile(const std::string& file, double reference, bool online = false) {
  const std::string path = datasetPath(file);
  if (!present(path)) return;
  const sim::ModelDataset d = sim::readModelDataset(path);
  const sim::ModelEstimate init = sim::initialEstimate(d);
  std::ostringstream head;
  head << file << " (" << d.factors.size() << " factors, " << init.size() << " variables)";
  if (online) {
    const sim::ModelBatchResult dead = sim::solveModelBatch(d, init);
    MESSAGE(describe(head.str() + " from first-seen (dead-reckoning) values", dead, reference));
    double seconds = 0.0;
    const sim::ModelEstimate start = onlineStart(d, &seconds);
    const sim::ModelBatchResult r = sim::solveModelBatch(d, start);
    MESSAGE(
        describe(head.str() + " from online values (built in " + std::to_string(seconds) + " s)", r,
                 reference));
    CHECK(r.converged);
    CHECK(r.chi2 == doctest::Approx(reference).epsilon(kTolerance));
    return;
  }
  const sim::ModelBatchResult r = sim::solveModelBatch(d, init);
  MESSAGE(describe(head.str(), r, reference));
  CHECK(r.converged);
  if (reference > 0.0) CHECK(r.chi2 == doctest::Approx(reference).epsilon(kTolerance));
}

}  // namespace

TEST_CASE("sphere2500.g2o") {
  solveFile("3d/sphere2500.g2o", 727.15);
}
TEST_CASE("parking-garage.g2o (slow tail)") {
  solveFile("3d/parking-garage.g2o", 1.2387);
}
TEST_CASE("smallGrid3D.g2o") {
  solveFile("3d/smallGrid3D.g2o", 458.15);
}
TEST_CASE("tinyGrid3D.g2o") {
  solveFile("3d/tinyGrid3D.g2o", 6.7279);
}
TEST_CASE("pose3example.txt") {
  solveFile("3d/pose3example.txt", 17781.8);
}
TEST_CASE("victoriaPark.txt (iSAM objective; online initial values)") {
  solveFile("2d/victoriaPark.txt", 6183.93, true);
}
TEST_CASE("torus2000Points.txt (no reference: printed)") {
  solveFile("3d/torus2000Points.txt", 0.0);
}
