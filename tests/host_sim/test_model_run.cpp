// Tests of the host's run of any model through the firmware's Smoother (host_sim/model_run.h):
// random online-ordered 2D landmark and 3D datasets in both conventions against the independent
// batch solver, the information carried into the solver's error coordinates against the iSAM
// error functions, and rejections reported at their lines.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "host_sim/model_batch_solver.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/model_run.h"
#include "host_sim/worlds.h"
#include "model_test_support.h"

using lslam::sim::FactorKind;
using lslam::sim::ModelDataset;
using lslam::sim::ModelFactor;
using lslam::sim::ObjectiveConvention;
using lslam::sim::VariableKey;
using lslam::sim::VariableKind;
using lslam::sim::VariableRole;
using lslam::sim::Vector6d;
using lslam::sim::Vector7d;
namespace sim = lslam::sim;
using namespace lslam::sim::test;

namespace {

// A robot's run in online order: poses 0..n-1 on a random walk (2D or 3D), odometry, loop
// closures to older poses, landmarks observed from several poses (2D: as positions and as range
// and bearing). Measurements with noise `sigma`.
ModelDataset makeRun(unsigned seed, int dimension, ObjectiveConvention convention, double sigma) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  ModelDataset d;
  d.name = "random";
  d.dimension = dimension;
  d.convention = convention;
  const int n = 40 + static_cast<int>(seed % 30);
  std::vector<Eigen::Matrix4d> truth;  // 3D poses (2D: in the xy plane block)
  std::vector<Eigen::Matrix3d> truth2;
  Eigen::Matrix4d x3 = Eigen::Matrix4d::Identity();
  Eigen::Matrix3d x2 = Eigen::Matrix3d::Identity();
  for (int i = 0; i < n; ++i) {
    truth.push_back(x3);
    truth2.push_back(x2);
    Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
    step.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(0.4 * u(rng), Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(0.2 * u(rng), Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(0.2 * u(rng), Eigen::Vector3d::UnitX()))
                                     .matrix();
    step.topRightCorner<3, 1>() = Eigen::Vector3d(1.0 + 0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng));
    x3 = x3 * step;
    x2 = x2 * h2(Eigen::Vector3d(1.0 + 0.2 * u(rng), 0.2 * u(rng), 0.5 * u(rng)));
  }
  std::size_t line = 1;
  const auto between = [&](int i, int j) {
    if (dimension == 2) {
      const Eigen::VectorXd z = fromH2(truth2[i].inverse() * truth2[j]) +
                                sigma * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
      d.factors.push_back(factor(FactorKind::BetweenSE2, pose(i), pose(j), z,
                                 randomInformation(rng, Eigen::Vector3d(10, 10, 40)), line++));
    } else {
      Eigen::Matrix4d noise = Eigen::Matrix4d::Identity();
      noise.topLeftCorner<3, 3>() =
          Eigen::AngleAxisd(sigma * gauss(rng), Eigen::Vector3d(u(rng), u(rng), 1).normalized())
              .matrix();
      noise.topRightCorner<3, 1>() = sigma * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
      const Eigen::VectorXd z = fromH3(truth[i].inverse() * truth[j] * noise);
      const Eigen::VectorXd diag = (Eigen::VectorXd(6) << 10, 10, 10, 40, 40, 40).finished();
      d.factors.push_back(factor(FactorKind::BetweenSE3, pose(i), pose(j), z,
                                 randomInformation(rng, diag), line++));
    }
  };
  std::uniform_int_distribution<int> pick(0, 3);
  const int landmarks = 6;
  for (int j = 1; j < n; ++j) {
    between(j - 1, j);
    if (j > 10 && pick(rng) == 0) between(static_cast<int>(j * (0.5 + 0.3 * (u(rng) + 1) / 2)), j);
    for (int l = 0; l < landmarks; ++l) {
      // Landmark l sits near pose 6 l and is seen from the poses within 4 of it.
      if (std::abs(j - 6 * l - 1) > 4) continue;
      const int anchor = std::min(n - 1, 6 * l + 1);
      if (dimension == 2) {
        const Eigen::Vector3d pos = truth2[anchor] * Eigen::Vector3d(1.0, 2.0, 1.0);
        const Eigen::Vector2d local = (truth2[j].inverse() * pos).head<2>();
        if (l % 2 == 0) {
          d.factors.push_back(factor(FactorKind::PointXY2, pose(j), landmark(l),
                                     local + sigma * Eigen::Vector2d(gauss(rng), gauss(rng)),
                                     randomInformation(rng, Eigen::Vector2d(20, 20)), line++));
        } else {
          const Eigen::Vector2d rb(local.norm() + sigma * gauss(rng),
                                   std::atan2(local.y(), local.x()) + sigma * gauss(rng));
          d.factors.push_back(factor(FactorKind::RangeBearing2, pose(j), landmark(l), rb,
                                     randomInformation(rng, Eigen::Vector2d(20, 50)), line++));
        }
      } else {
        const Eigen::Vector4d pos = truth[anchor] * Eigen::Vector4d(1.0, 2.0, 0.5, 1.0);
        const Eigen::Vector3d local = (truth[j].inverse() * pos).head<3>();
        d.factors.push_back(
            factor(FactorKind::PointXYZ3, pose(j), landmark(l),
                   local + sigma * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)),
                   randomInformation(rng, Eigen::Vector3d(20, 20, 20)), line++));
      }
    }
  }
  return d;
}

// The run's final estimate against the batch optimum from the run's initial values, pose `anchor`
// fixed: chi2 within 0.1 % (the bar real datasets are held to) and every position within 1e-3
// (the estimate lags the optimum where linearization points wait for relinearization, threshold
// 0.01: well below the measurements' noise).
void checkAgainstBatch(const ModelDataset& d, const sim::ModelRun& run, std::int64_t anchor) {
  sim::BatchOptions batch_options;
  batch_options.fixed.push_back(anchor);
  const sim::ModelBatchResult batch = sim::solveModelBatch(d, run.initial, batch_options);
  REQUIRE(batch.converged);
  const double chi2 = sim::chi2(d, run.estimate);
  CAPTURE(chi2);
  CAPTURE(batch.chi2);
  CHECK(chi2 <= batch.chi2 * (1.0 + 1e-3));
  double worst = 0.0;
  for (const auto& [key, value] : run.estimate) {
    const Eigen::VectorXd& other = batch.values.at(key);
    worst =
        std::max(worst, (value.head(d.dimension) - other.head(d.dimension)).cwiseAbs().maxCoeff());
  }
  CHECK(worst < 1e-3);
}

}  // namespace

TEST_CASE("random 2D landmark and 3D runs agree with the batch solver, both conventions") {
  for (unsigned seed = 1; seed <= 6; ++seed) {
    for (const int dimension : {2, 3}) {
      for (const ObjectiveConvention convention :
           {ObjectiveConvention::G2o, ObjectiveConvention::Isam}) {
        const ModelDataset d = makeRun(seed, dimension, convention, 1e-3);
        CAPTURE(seed);
        CAPTURE(dimension);
        CAPTURE(std::string(convention == ObjectiveConvention::G2o ? "g2o" : "isam"));
        // The exact back-substitution: the partial one may lag by its tolerance (1e-4). These
        // graphs are small enough that each update converges by default; with that off (0), the
        // updates take the large graphs' path: one step each, relinearization when due.
        for (const lslam::Index converge_below :
             {lslam::SolverOptions{}.converge_below_variables, lslam::Index{0}}) {
          CAPTURE(converge_below);
          sim::IncrementalOptions options;
          options.solver.backsubstitution_tolerance = 0.0;
          options.solver.converge_below_variables = converge_below;
          const sim::ModelRun run = sim::runModelIncremental(d, options);
          REQUIRE(run.anchor == pose(0));
          CHECK(run.poses == static_cast<lslam::Index>(run.steps.size()));
          CHECK(run.landmarks == 6);
          REQUIRE(run.estimate.size() == run.initial.size());

          checkAgainstBatch(d, run, 0);
        }
      }
    }
  }
}

TEST_CASE("pose graphs in file order, out of time order, agree with the batch solver") {
  for (unsigned seed = 1; seed <= 4; ++seed) {
    for (const int dimension : {2, 3}) {
      // The run's pose graph as a stream: the odometry chain backwards from its newest pose, then
      // the loop closures. Each odometry factor introduces an older pose.
      const ModelDataset run_d = makeRun(seed, dimension, ObjectiveConvention::G2o, 1e-3);
      ModelDataset d = run_d;
      d.factors.clear();
      std::vector<ModelFactor> loops;
      for (const ModelFactor& f : run_d.factors) {
        if (f.second.role == VariableRole::Landmark) continue;
        (f.second.id == f.first.id + 1 ? d.factors : loops).push_back(f);
      }
      std::reverse(d.factors.begin(), d.factors.end());
      d.factors.insert(d.factors.end(), loops.begin(), loops.end());
      CAPTURE(seed);
      CAPTURE(dimension);
      sim::IncrementalOptions options;
      options.order = sim::StepOrder::File;
      options.solver.backsubstitution_tolerance = 0.0;
      // Every loop closure arrives in the last step, and the chi2 of these runs is ~1e-4: one
      // linear step from dead reckoning leaves a visible share of it. The last update iterates
      // (urgent_iterations) until no variable moves past 1e-6 from its linearization point.
      options.solver.relinearize_threshold = 1e-6;
      options.solver.relinearize_urgent_threshold = 1e-6;
      options.solver.urgent_iterations = 10;
      const sim::ModelRun run = sim::runModelIncremental(d, options);
      const std::int64_t newest = d.factors.front().second.id;
      REQUIRE(run.anchor == pose(newest - 1));
      CHECK(run.landmarks == 0);
      CHECK(run.steps.size() == static_cast<std::size_t>(newest + 1));
      // Step 1 adds the newest pose, step 2 the one before the anchor (not next to step 1's pose:
      // a loop closure); from there each step adds the pose before the previous one by odometry.
      // The last also holds every loop closure, between poses seen before.
      CHECK(run.steps[0].kind == sim::StepKind::First);
      CHECK(run.steps[1].kind == sim::StepKind::Odometry);
      CHECK(run.steps[2].kind == sim::StepKind::LoopClosure);
      for (std::size_t k = 3; k + 1 < run.steps.size(); ++k) {
        CHECK(run.steps[k].kind == sim::StepKind::Odometry);
      }
      CHECK(run.steps.back().kind == sim::StepKind::LoopClosure);

      checkAgainstBatch(d, run, newest - 1);
    }
  }
}

TEST_CASE("landmark runs in file order, every observation in the last step, agree with batch") {
  // The random runs with their landmark observations moved after every pose factor: in file order
  // the last step then brings every landmark, each entering at its first observation there.
  for (unsigned seed = 1; seed <= 4; ++seed) {
    for (const int dimension : {2, 3}) {
      CAPTURE(seed);
      CAPTURE(dimension);
      ModelDataset d = makeRun(seed, dimension, ObjectiveConvention::G2o, 1e-3);
      std::stable_partition(d.factors.begin(), d.factors.end(), [](const ModelFactor& f) {
        return f.second.role != VariableRole::Landmark;
      });
      sim::IncrementalOptions options;
      options.order = sim::StepOrder::File;
      options.solver.backsubstitution_tolerance = 0.0;
      const sim::ModelRun run = sim::runModelIncremental(d, options);
      CHECK(run.landmarks == 6);
      REQUIRE(run.estimate.size() == run.initial.size());
      checkAgainstBatch(d, run, run.anchor.id);
    }
  }
}

TEST_CASE("solverInformation: iSAM's information in g2o's error coordinates") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  ModelDataset isam;
  isam.convention = ObjectiveConvention::Isam;
  ModelDataset g2o;
  g2o.convention = ObjectiveConvention::G2o;
  for (int trial = 0; trial < 50; ++trial) {
    // SE2: iSAM's error is g2o's with the translation rotated by the measurement's angle: the same
    // quadratic form exactly, for errors of any size.
    const Eigen::Vector3d z2(3 * u(rng), 3 * u(rng), 3 * u(rng));
    const ModelFactor f2 = factor(FactorKind::BetweenSE2, pose(0), pose(1), z2,
                                  randomInformation(rng, Eigen::Vector3d(5, 5, 5)), 1);
    CHECK(sim::solverInformation(g2o, f2) == f2.information);
    const Eigen::Matrix3d info2 = sim::solverInformation(isam, f2);
    const Eigen::Vector3d xi(u(rng), u(rng), u(rng));
    const Eigen::Vector3d xj(3 * u(rng), 3 * u(rng), 3 * u(rng));
    const Eigen::Vector3d e_isam = sim::errorBetweenSE2Isam(xi, xj, z2);
    const Eigen::Vector3d e_g2o = sim::errorBetweenSE2G2o(xi, xj, z2);
    const Eigen::Matrix3d omega2 = f2.information;
    CHECK(e_g2o.dot(info2 * e_g2o) == doctest::Approx(e_isam.dot(omega2 * e_isam)).epsilon(1e-12));

    // SE3: the same quadratic form to first order in the error (Euler angles against the
    // quaternion's vector part): relative difference of the order of the error.
    Vector7d z3;
    const Eigen::Quaterniond qz = Eigen::Quaterniond::UnitRandom();
    z3 << 3 * u(rng), 3 * u(rng), 3 * u(rng), qz.x(), qz.y(), qz.z(), qz.w();
    const Eigen::VectorXd diag = (Eigen::VectorXd(6) << 5, 5, 5, 5, 5, 5).finished();
    const ModelFactor f3 =
        factor(FactorKind::BetweenSE3, pose(0), pose(1), z3, randomInformation(rng, diag), 1);
    const Eigen::MatrixXd info3 = sim::solverInformation(isam, f3);
    CHECK((info3 - info3.transpose()).norm() == 0.0);
    for (const double size : {1e-3, 1e-4}) {
      Eigen::Matrix4d residual = Eigen::Matrix4d::Identity();
      residual.topLeftCorner<3, 3>() =
          Eigen::AngleAxisd(size, Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()).matrix();
      residual.topRightCorner<3, 1>() = size * Eigen::Vector3d(u(rng), u(rng), u(rng));
      const Eigen::VectorXd identity = (Vector7d() << 0, 0, 0, 0, 0, 0, 1).finished();
      const Eigen::VectorXd xj3 = fromH3(h3(z3) * residual);
      const Vector6d e3_isam = sim::errorBetweenSE3Isam(identity, xj3, z3);
      const Vector6d e3_g2o = sim::errorBetweenSE3G2o(identity, xj3, z3);
      const double q_isam = e3_isam.dot(f3.information * e3_isam);
      const double q_g2o = e3_g2o.dot(info3 * e3_g2o);
      CAPTURE(size);
      CHECK(std::abs(q_g2o - q_isam) <= 20 * size * q_isam);
    }
  }
}

TEST_CASE("a step the solver rejects is reported at its first factor's line") {
  ModelDataset d = makeRun(3, 3, ObjectiveConvention::G2o, 1e-3);
  ModelFactor& bad = d.factors[20];
  bad.measurement[0] = std::numeric_limits<double>::quiet_NaN();
  const std::size_t first_line = [&] {
    // The step of the pose `bad` introduces starts with its odometry factor.
    const std::int64_t newer = std::max(bad.first.id, bad.second.id);
    for (const ModelFactor& f : d.factors) {
      if (std::max(f.first.id, f.second.id) == newer && f.kind == FactorKind::BetweenSE3) {
        return f.line;
      }
    }
    return std::size_t{0};
  }();
  try {
    (void)sim::runModelIncremental(d, sim::IncrementalOptions{});
    FAIL("no error");
  } catch (const sim::DatasetError& e) {
    CAPTURE(e.what());
    CHECK(e.line() == first_line);
    CHECK(e.reason().find("rejected: ") != std::string::npos);
    CHECK(e.reason().find(std::to_string(bad.line)) != std::string::npos);
  }
}

TEST_CASE("a FIX of another pose than the anchor is noted, of two poses an error, at its line") {
  const std::string graph =
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n"
      "EDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";
  // Online order anchors the smallest id (0); file order the first edge's smaller end (1).
  sim::IncrementalOptions file_order;
  file_order.order = sim::StepOrder::File;
  const auto runError = [](const std::string& text, const sim::IncrementalOptions& o) {
    std::istringstream in(text);
    try {
      const sim::ModelRun run = sim::runModelIncremental(sim::parseModelDataset(in, "a.g2o"), o);
      return "ok anchor " + std::to_string(run.anchor.id) +
             (run.gauge_note.empty() ? "" : ", note " + run.gauge_note);
    } catch (const sim::DatasetError& e) {
      return std::string(e.what());
    }
  };
  const sim::IncrementalOptions online;
  CHECK(runError(graph, online) == "ok anchor 0");
  CHECK(runError(graph, file_order) == "ok anchor 1");
  CHECK(runError(graph + "FIX 0\n", online) == "ok anchor 0");
  CHECK(runError(graph + "FIX 1\n", file_order) == "ok anchor 1");
  CHECK(runError(graph + "FIX 0 0\nFIX 0\n", online) == "ok anchor 0");
  CHECK(runError(graph + "FIX 2\n", online) ==
        "ok anchor 0, note a.g2o:6: FIX 2: the incremental solver anchors pose 0 (its first) "
        "instead, and so does the batch reference; the optimum is the same up to a rigid motion");
  CHECK(runError("FIX 0\n" + graph, file_order) ==
        "ok anchor 1, note a.g2o:1: FIX 0: the incremental solver anchors pose 1 (its first) "
        "instead, and so does the batch reference; the optimum is the same up to a rigid motion");
  CHECK(runError(graph + "FIX 0\nFIX 0 1\n", online) ==
        "a.g2o:7: FIX 1: a second fixed pose (FIX 0 at line 6); the incremental solver fixes one "
        "pose, its first");
}

TEST_CASE("a step that overflows the factorization is reported at its factor's line") {
  // Finite, positive definite on paper, but 1e308 overflows the factorization.
  std::istringstream in(
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n# c\nEDGE_SE2 0 1 1 0 0 1e308 0 0 1e308 0 1e308\n");
  const ModelDataset d = sim::parseModelDataset(in, "big.g2o");
  bool threw = false;
  try {
    (void)sim::runModelIncremental(d, sim::IncrementalOptions{});
  } catch (const sim::DatasetError& e) {
    threw = true;
    CHECK(e.line() == 4);
    CHECK(e.reason().find("step 1 (pose 1, factor at line 4) rejected: ") == 0);
    CHECK(e.reason().find("positive definite") != std::string::npos);
    CHECK(e.reason().find("numerically singular") != std::string::npos);
  }
  CHECK(threw);
}

TEST_CASE("a step refused for an earlier step's information says where to look") {
  // Line 3's information (1e-300) passes as positive definite and its step is accepted, but pose 1
  // is then so loosely held that the next step's Schur complement rounds to nothing: that step
  // (line 4, valid) is refused, and the message points back.
  std::istringstream in(
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1e-300 0 0 1e-300 0 1e-300\n"
      "VERTEX_SE2 2 2 0 0\nEDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n");
  const ModelDataset d = sim::parseModelDataset(in, "weak.g2o");
  bool threw = false;
  try {
    (void)sim::runModelIncremental(d, sim::IncrementalOptions{});
  } catch (const sim::DatasetError& e) {
    threw = true;
    CHECK(e.line() == 5);
    CHECK(e.reason().find("step 2 (pose 2, factor at line 5) rejected: ") == 0);
    CHECK(e.reason().find("earlier measurement") != std::string::npos);
  }
  CHECK(threw);
}

TEST_CASE("isPoseGraph2D: SE2 poses with SE2 factors only") {
  ModelDataset d = makeRun(2, 2, ObjectiveConvention::G2o, 1e-3);
  CHECK_FALSE(sim::isPoseGraph2D(d));
  std::vector<ModelFactor> poses_only;
  for (const ModelFactor& f : d.factors) {
    if (f.kind == FactorKind::BetweenSE2) poses_only.push_back(f);
  }
  d.factors = poses_only;
  CHECK(sim::isPoseGraph2D(d));
  CHECK_FALSE(sim::isPoseGraph2D(makeRun(2, 3, ObjectiveConvention::G2o, 1e-3)));
}

TEST_CASE("progress: steps in order, and the last report's chi2 is that of the final estimate") {
  sim::WorldOptions o = sim::defaultWorldOptions(sim::WorldKind::Points3D);
  o.steps = 120;
  const ModelDataset d = sim::simulateWorld(sim::WorldKind::Points3D, o).dataset;
  std::vector<sim::RunProgress> reports;
  sim::IncrementalOptions options;
  options.solver = sim::defaultModelOptions(d);
  options.progress = [&](const sim::RunProgress& p) { reports.push_back(p); };
  options.progress_interval_s = 0.0;  // after every step
  const sim::ModelRun run = sim::runModelIncremental(d, options);
  REQUIRE(reports.size() == run.steps.size());
  for (std::size_t i = 0; i < reports.size(); ++i) {
    CHECK(reports[i].steps_done == i + 1);
    CHECK(reports[i].steps_total == run.steps.size());
    CHECK(reports[i].chi2 >= 0.0);
    if (i > 0) CHECK(reports[i].wall_seconds >= reports[i - 1].wall_seconds);
  }
  CHECK(reports.back().chi2 == doctest::Approx(sim::chi2(d, run.estimate)).epsilon(1e-12));
  // A long interval still reports the last step.
  reports.clear();
  options.progress_interval_s = 1e9;
  (void)sim::runModelIncremental(d, options);
  REQUIRE(!reports.empty());
  CHECK(reports.back().steps_done == run.steps.size());
}

TEST_CASE("a compact run stays finite where an observation's information swamps its place's") {
  // Past the capacity (10 nodes) an observation of a mapped landmark corrects the place, and each
  // pose's trajectory estimate is corrected again on the final map (place_smoother.h), through
  // the same Kalman update (correctionByObservedPoint). An information that dwarfs the place's
  // past double precision makes that update singular: the pose keeps its estimate without it,
  // not NaN. One below about 1e-18 is refused at its line.
  sim::WorldOptions o = sim::defaultWorldOptions(sim::WorldKind::Grid2D);
  o.steps = 40;
  const ModelDataset world = sim::simulateWorld(sim::WorldKind::Grid2D, o).dataset;
  sim::IncrementalOptions options;
  options.solver = sim::defaultModelOptions(world);
  options.max_poses = 10;
  int pushed = 0;
  for (std::size_t k = 0; k < world.factors.size() && pushed < 6; ++k) {
    const ModelFactor& f = world.factors[k];
    if (f.kind != FactorKind::PointXY2 || f.first.id < 10) continue;
    for (const double extreme : {4e302, 1e307}) {
      CAPTURE(k);
      CAPTURE(extreme);
      ModelDataset d = world;
      d.factors[k].information(1, 1) = extreme;
      const sim::ModelRun run = sim::runModelIncremental(d, options);
      for (const auto& [key, value] : run.estimate) REQUIRE(value.allFinite());
    }
    ++pushed;
  }
  CHECK(pushed == 6);
  for (std::size_t k = 0; k < world.factors.size(); ++k) {
    const ModelFactor& f = world.factors[k];
    if (f.kind != FactorKind::BetweenSE2 || f.first.id < 12 || f.second.id != f.first.id + 1) {
      continue;
    }
    ModelDataset d = world;
    d.factors[k].information *= 1e-23;  // standard deviations of 1.6e10 m and 3e9 rad
    d.factors[k].line = 77;
    try {
      (void)sim::runModelIncremental(d, options);
      FAIL("an odometry of standard deviations beyond 1e9 was accepted");
    } catch (const sim::DatasetError& e) {
      CHECK(e.line() == 77);
      CHECK(std::string(e.what()).find("a measurement's standard deviation does") !=
            std::string::npos);
    }
    break;
  }
}

TEST_CASE("a compact run's trajectory stays near the truth past an odometry of unknown heading") {
  // An odometry whose heading is all but unknown (a rotation information of 1e-16 against 1e4)
  // past the capacity: the trajectory smoothed again from the log (place_smoother.h) meets
  // covariances with variances 1e16 times their distance squared next to 1e-4, whose smoothing
  // gains are mostly rounding; carried back from pose to pose they threw poses a million
  // kilometres away. Every pose must stay within 100 m of the truth (noise 0.05 m, 150 steps).
  sim::WorldOptions o = sim::defaultWorldOptions(sim::WorldKind::Garage3D);
  o.steps = 150;
  const sim::SimulatedWorld world = sim::simulateWorld(sim::WorldKind::Garage3D, o);
  ModelDataset d = world.dataset;
  bool weakened = false;
  for (ModelFactor& f : d.factors) {
    if (f.kind == FactorKind::BetweenSE3 && f.first.id == 69 && f.second.id == 70) {
      f.information(4, 4) = 1e-16;  // the rotation vector's y, in g2o's error coordinates
      weakened = true;
    }
  }
  REQUIRE(weakened);
  sim::IncrementalOptions options;
  options.solver = sim::defaultModelOptions(d);
  options.max_poses = 60;
  const sim::ModelRun run = sim::runModelIncremental(d, options);
  std::size_t checked = 0;
  for (const sim::ModelVertex& v : world.truth.vertices) {
    if (v.key.role != VariableRole::Pose) continue;
    CAPTURE(v.key.id);
    const Eigen::VectorXd& estimate = run.estimate.at(v.key);
    CHECK((estimate.head<3>() - v.value.head<3>()).norm() < 100.0);
    ++checked;
  }
  CHECK(checked == 150);
}

TEST_CASE("a compact run refuses a factor it has no place for at its line, saying what it takes") {
  // The compact graph keeps between factors and point observations. A range-bearing observation,
  // from the first pose or from a later one, stops the run at its line with that message.
  sim::WorldOptions o = sim::defaultWorldOptions(sim::WorldKind::Grid2D);
  o.steps = 40;
  o.landmark_measurement = sim::LandmarkMeasurement::RangeBearing;
  ModelDataset world = sim::simulateWorld(sim::WorldKind::Grid2D, o).dataset;
  for (std::size_t k = 0; k < world.factors.size(); ++k) world.factors[k].line = 100 + k;
  sim::IncrementalOptions options;
  options.solver = sim::defaultModelOptions(world);
  options.max_poses = 10;
  const auto refusal = [&](const ModelDataset& d) {
    try {
      (void)sim::runModelIncremental(d, options);
    } catch (const sim::DatasetError& e) {
      return std::make_pair(e.line(), std::string(e.what()));
    }
    return std::make_pair(std::size_t{0}, std::string("accepted"));
  };
  const auto firstOf = [](const ModelDataset& d, FactorKind kind, bool from_first_pose) {
    for (const ModelFactor& f : d.factors) {
      if (f.kind == kind && (f.first.id == 0) == from_first_pose) return f.line;
    }
    return std::size_t{0};
  };
  ModelDataset later = world;  // no observation from the first pose
  later.factors.erase(std::remove_if(later.factors.begin(), later.factors.end(),
                                     [](const ModelFactor& f) {
                                       return f.kind == FactorKind::RangeBearing2 &&
                                              f.first.id == 0;
                                     }),
                      later.factors.end());
  const std::size_t from_first = firstOf(world, FactorKind::RangeBearing2, true);
  const std::size_t from_later = firstOf(later, FactorKind::RangeBearing2, false);
  REQUIRE(from_first > 0);
  REQUIRE(from_later > 0);
  for (const auto& [d, expected_line] :
       {std::make_pair(&world, from_first), std::make_pair(&later, from_later)}) {
    const auto [line, message] = refusal(*d);
    CHECK(line == expected_line);
    CHECK(message.find("--max-poses takes between factors and point observations") !=
          std::string::npos);
  }
}
