// The simulator's worlds (host_sim/worlds.h), checked against their own truth by independent
// means: the measurements' errors at the true values (factorError, the chi2 code of the readers),
// the chi-square law of chi2 at the truth and at the batch optimum, the incremental solver against
// the batch solver, and the optimum's error against the covariance the information implies
// (numerical Jacobians at the truth, a dense inverse).
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <Eigen/SparseCholesky>
#include <cmath>
#include <map>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "host_sim/model_batch_solver.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/model_run.h"
#include "host_sim/synthetic.h"
#include "host_sim/trajectory_error.h"
#include "host_sim/worlds.h"

namespace {

using namespace lslam::sim;

ModelEstimate valuesOf(const ModelDataset& d) {
  ModelEstimate values;
  for (const ModelVertex& v : d.vertices) values[v.key] = v.value;
  return values;
}

std::size_t residualDimension(const ModelDataset& d) {
  std::size_t m = 0;
  for (const ModelFactor& f : d.factors) m += static_cast<std::size_t>(errorDimension(f.kind));
  return m;
}

// The whitened error L^T e (Omega = L L^T) of f at the values of its variables (`second` unused
// for a factor of one variable).
Eigen::VectorXd whitenedError(const ModelDataset& d, const ModelFactor& f,
                              const Eigen::VectorXd& first, const Eigen::VectorXd& second) {
  const Eigen::MatrixXd l = Eigen::LLT<Eigen::MatrixXd>(f.information).matrixL();
  return l.transpose() * factorError(d.convention, f, first, second);
}

// The same at `values`.
Eigen::VectorXd whitenedError(const ModelDataset& d, const ModelFactor& f,
                              const ModelEstimate& values) {
  const Eigen::MatrixXd l = Eigen::LLT<Eigen::MatrixXd>(f.information).matrixL();
  return l.transpose() * factorError(d.convention, f, values);
}

// The covariance the information implies at the truth, pose 0 held fixed (the solver's gauge):
// (J^T J)^-1 with J the whitened errors' Jacobian by central differences on the tangent spaces.
// Only its block of the poses' positions is kept (all the test uses): the rows of (J^T J)^-1 S at
// the position rows, S the columns of the identity there (J^T J sparse, by a sparse Cholesky).
struct TruthCovariance {
  Eigen::MatrixXd position_covariance;  // over the poses' positions (pose 0 excluded)
  int variables_dimension = 0;          // n, the rows of J^T J
  int poses = 0;                        // poses with a position in position_covariance
};

TruthCovariance covarianceAtTruth(const ModelDataset& d, const ModelDataset& truth) {
  std::unordered_map<VariableKey, int, VariableKeyHash> offset;
  TruthCovariance out;
  std::vector<int> position_rows;
  int n = 0;
  for (const ModelVertex& v : truth.vertices) {
    if (v.key == VariableKey{VariableRole::Pose, 0}) continue;
    offset[v.key] = n;
    if (v.key.role == VariableRole::Pose) {
      for (int k = 0; k < d.dimension; ++k) position_rows.push_back(n + k);
      ++out.poses;
    }
    n += tangentDimension(v.kind);
  }
  const ModelEstimate values = valuesOf(truth);
  const auto kinds = variableKinds(truth);
  std::vector<Eigen::Triplet<double>> lambda;  // J^T J, summed by setFromTriplets
  const double h = 1e-6;
  for (const ModelFactor& f : d.factors) {
    std::vector<VariableKey> keys = {f.first};
    if (arity(f.kind) == 2) keys.push_back(f.second);
    // The factor's variables' values, perturbed one tangent component at a time.
    std::vector<Eigen::VectorXd> at(2);
    for (std::size_t i = 0; i < keys.size(); ++i) at[i] = values.at(keys[i]);
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(errorDimension(f.kind), n);
    std::vector<int> columns;
    for (std::size_t i = 0; i < keys.size(); ++i) {
      const auto column = offset.find(keys[i]);
      if (column == offset.end()) continue;
      const VariableKind kind = kinds.at(keys[i]);
      for (int k = 0; k < tangentDimension(kind); ++k) {
        Eigen::VectorXd delta = Eigen::VectorXd::Zero(tangentDimension(kind));
        std::vector<Eigen::VectorXd> plus = at;
        std::vector<Eigen::VectorXd> minus = at;
        delta[k] = h;
        plus[i] = retractModel(kind, at[i], delta);
        minus[i] = retractModel(kind, at[i], -delta);
        j.col(column->second + k) =
            (whitenedError(d, f, plus[0], plus[1]) - whitenedError(d, f, minus[0], minus[1])) /
            (2.0 * h);
        columns.push_back(column->second + k);
      }
    }
    for (const int a : columns) {
      for (const int b : columns) lambda.emplace_back(a, b, j.col(a).dot(j.col(b)));
    }
  }
  Eigen::SparseMatrix<double> information(n, n);
  information.setFromTriplets(lambda.begin(), lambda.end());
  const Eigen::SimplicialLLT<Eigen::SparseMatrix<double>> llt(information);
  REQUIRE(llt.info() == Eigen::Success);
  const int k = static_cast<int>(position_rows.size());
  Eigen::MatrixXd selection = Eigen::MatrixXd::Zero(n, k);
  for (int c = 0; c < k; ++c) selection(position_rows[static_cast<std::size_t>(c)], c) = 1.0;
  const Eigen::MatrixXd columns = llt.solve(selection);  // (J^T J)^-1 S
  out.position_covariance.resize(k, k);
  for (int r = 0; r < k; ++r) {
    out.position_covariance.row(r) = columns.row(position_rows[static_cast<std::size_t>(r)]);
  }
  out.variables_dimension = n;
  return out;
}

double meanSquaredPositionError(const ModelDataset& truth, const ModelEstimate& estimate, int dim) {
  double sum = 0.0;
  int count = 0;
  for (const ModelVertex& v : truth.vertices) {
    if (v.key.role != VariableRole::Pose || v.key.id == 0) continue;
    sum += (estimate.at(v.key).head(dim) - v.value.head(dim)).squaredNorm();
    ++count;
  }
  return sum / count;
}

// |x - mean| within `sigmas` standard deviations of a chi-square law with `dof` degrees.
void checkChiSquare(double x, double dof, const char* what) {
  const double sigmas = 5.0;
  INFO(what << ": chi2 " << x << ", degrees of freedom " << dof);
  CHECK(std::abs(x - dof) <= sigmas * std::sqrt(2.0 * dof));
}

struct Case {
  WorldKind kind;
  WorldOptions options;
  const char* name;
};

std::vector<Case> smallWorlds() {
  std::vector<Case> cases;
  for (const std::uint32_t seed : {1u, 2u, 3u}) {
    WorldOptions grid = defaultWorldOptions(WorldKind::Grid2D);
    grid.steps = 150;
    grid.grid_size = 5;
    grid.landmarks = 40;
    grid.seed = seed;
    cases.push_back({WorldKind::Grid2D, grid, "grid2d"});
    grid.landmark_measurement = LandmarkMeasurement::RangeBearing;
    cases.push_back({WorldKind::Grid2D, grid, "grid2d range-bearing"});
    WorldOptions sphere = defaultWorldOptions(WorldKind::Sphere3D);
    sphere.steps = 144;
    sphere.seed = seed;
    cases.push_back({WorldKind::Sphere3D, sphere, "sphere3d"});
    WorldOptions garage = defaultWorldOptions(WorldKind::Garage3D);
    garage.steps = 200;
    garage.floors = 2;
    garage.seed = seed;
    cases.push_back({WorldKind::Garage3D, garage, "garage3d"});
    WorldOptions points = defaultWorldOptions(WorldKind::Points3D);
    points.steps = 200;
    points.landmarks = 30;
    points.seed = seed;
    cases.push_back({WorldKind::Points3D, points, "points3d"});
  }
  return cases;
}

}  // namespace

TEST_CASE("worlds: measurements match the truth; chi2 follows the chi-square law") {
  for (const Case& c : smallWorlds()) {
    INFO(std::string(c.name) << " seed " << c.options.seed);
    const SimulatedWorld w = simulateWorld(c.kind, c.options);
    REQUIRE(w.dataset.vertices.size() == w.truth.vertices.size());
    REQUIRE(w.truth.vertices.size() >= static_cast<std::size_t>(c.options.steps));
    const double m = static_cast<double>(residualDimension(w.dataset));
    checkChiSquare(chi2(w.dataset, valuesOf(w.truth)), m, "at the truth");

    // Almost noise-free, every error at the truth vanishes (the measurement is the true one).
    WorldOptions quiet = c.options;
    quiet.sigma_translation = quiet.sigma_rotation = quiet.sigma_landmark = 1e-9;
    quiet.sigma_range = quiet.sigma_bearing = 1e-9;
    const SimulatedWorld q = simulateWorld(c.kind, quiet);
    const ModelEstimate truth = valuesOf(q.truth);
    double worst = 0.0;
    for (const ModelFactor& f : q.dataset.factors) {
      worst = std::max(worst, factorError(q.dataset.convention, f, truth).cwiseAbs().maxCoeff());
    }
    CHECK(worst < 1e-7);
  }
}

TEST_CASE("worlds: whitened errors at the truth are standard normal, component by component") {
  std::vector<Case> cases;
  for (const WorldKind kind :
       {WorldKind::Grid2D, WorldKind::Sphere3D, WorldKind::Garage3D, WorldKind::Points3D}) {
    WorldOptions o = defaultWorldOptions(kind);
    o.steps = 3000;
    o.seed = 11;
    cases.push_back({kind, o, worldKindName(kind)});
  }
  cases.push_back(cases.front());
  cases.back().options.landmark_measurement = LandmarkMeasurement::RangeBearing;
  cases.back().name = "grid2d range-bearing";
  for (const Case& c : cases) {
    const SimulatedWorld w = simulateWorld(c.kind, c.options);
    const ModelEstimate truth = valuesOf(w.truth);
    // Per factor kind and error component: count, sum and sum of squares.
    std::map<std::pair<FactorKind, int>, Eigen::Vector3d> moments;
    for (const ModelFactor& f : w.dataset.factors) {
      const Eigen::VectorXd r = whitenedError(w.dataset, f, truth);
      for (int k = 0; k < r.size(); ++k) {
        // Eigen leaves a default-constructed vector uninitialised: start each sum at zero.
        auto& m = moments.try_emplace({f.kind, k}, Eigen::Vector3d::Zero()).first->second;
        m += Eigen::Vector3d(1.0, r[k], r[k] * r[k]);
      }
    }
    for (const auto& entry : moments) {
      // Named references, not a structured binding: INFO captures them in a lambda (C++17).
      const std::pair<FactorKind, int>& which = entry.first;
      const Eigen::Vector3d& m = entry.second;
      INFO(std::string(c.name) << " " << std::string(factorKindName(which.first)) << " component "
                               << which.second << ": " << m[0] << " samples, mean " << m[1] / m[0]
                               << ", mean square " << m[2] / m[0]);
      CHECK(m[0] >= 1000.0);
      CHECK(std::abs(m[1] / m[0]) <= 5.0 / std::sqrt(m[0]));
      CHECK(std::abs(m[2] / m[0] - 1.0) <= 5.0 * std::sqrt(2.0 / m[0]));
    }
  }
}

TEST_CASE("worlds: incremental within 0.1 % of batch; batch chi2 and error consistent with noise") {
  for (const Case& c : smallWorlds()) {
    INFO(std::string(c.name) << " seed " << c.options.seed);
    const SimulatedWorld w = simulateWorld(c.kind, c.options);
    IncrementalOptions options;
    options.solver = defaultModelOptions(w.dataset);
    const ModelRun run = runModelIncremental(w.dataset, options);
    REQUIRE(run.anchor.id == 0);
    BatchOptions batch_options;
    batch_options.fixed = {0};
    const ModelBatchResult batch = solveModelBatch(w.dataset, run.initial, batch_options);
    REQUIRE(batch.converged);
    const double incremental = chi2(w.dataset, run.estimate);
    CHECK(incremental <= batch.chi2 * 1.001);
    CHECK(incremental >= batch.chi2 * (1.0 - 1e-9));

    // At the optimum: chi-square with m - n degrees (n: the variables' dimensions, pose 0 fixed).
    const TruthCovariance cov = covarianceAtTruth(w.dataset, w.truth);
    const double dof = static_cast<double>(residualDimension(w.dataset)) -
                       static_cast<double>(cov.variables_dimension);
    checkChiSquare(batch.chi2, dof, "at the batch optimum");

    // The optimum's position error e = x^ - x ~ N(0, Sigma) to first order (pose 0 is the
    // gauge, at its true value): the mean squared position error has mean tr(Sigma_pp) / n and
    // variance 2 tr(Sigma_pp^2) / n^2. Bound: mean + 6 standard deviations.
    const Eigen::MatrixXd& pp = cov.position_covariance;
    const double n = cov.poses;
    const double mean = pp.trace() / n;
    const double sd = std::sqrt(2.0 * (pp * pp).trace()) / n;
    const double error = meanSquaredPositionError(w.truth, batch.values, w.dataset.dimension);
    INFO("mean squared position error " << error << ", expected " << mean << " +- " << sd);
    CHECK(error > 0.0);
    CHECK(error >= mean - 6.0 * sd);
    CHECK(error <= mean + 6.0 * sd);
    // The ATE aligns the estimate onto the truth with the rigid motion of least squared error:
    // its square is at most this error (the identity is one such motion, pose 0 adds nothing).
    const TrajectoryError ate = trajectoryError(batch.values, valuesOf(w.truth),
                                                w.dataset.dimension, variableKinds(w.dataset));
    CHECK(ate.poses == static_cast<std::size_t>(c.options.steps));
    CHECK(ate.ate_position_rmse > 0.0);
    CHECK(ate.ate_position_rmse * ate.ate_position_rmse <= error * (n / (n + 1.0)) + 1e-15);
    // Optimising beats dead reckoning.
    CHECK(error < meanSquaredPositionError(w.truth, run.initial, w.dataset.dimension));
  }
}

static bool sameDataset(const ModelDataset& a, const ModelDataset& b) {
  if (a.factors.size() != b.factors.size() || a.vertices.size() != b.vertices.size()) return false;
  for (std::size_t i = 0; i < a.factors.size(); ++i) {
    const ModelFactor& f = a.factors[i];
    const ModelFactor& g = b.factors[i];
    if (f.kind != g.kind || f.first != g.first || f.second != g.second ||
        f.measurement != g.measurement || f.information != g.information) {
      return false;
    }
  }
  for (std::size_t i = 0; i < a.vertices.size(); ++i) {
    if (a.vertices[i].key != b.vertices[i].key || a.vertices[i].value != b.vertices[i].value) {
      return false;
    }
  }
  return true;
}

TEST_CASE("worlds: deterministic for a seed, different for another") {
  for (const Case& c : smallWorlds()) {
    INFO(std::string(c.name) << " seed " << c.options.seed);
    const SimulatedWorld a = simulateWorld(c.kind, c.options);
    WorldOptions next = c.options;
    next.seed += 100;
    CHECK(sameDataset(a.dataset, simulateWorld(c.kind, c.options).dataset));
    CHECK(sameDataset(a.truth, simulateWorld(c.kind, c.options).truth));
    CHECK_FALSE(sameDataset(a.dataset, simulateWorld(c.kind, next).dataset));
  }
}

TEST_CASE("worlds: the dataset and the truth read back from their files as written") {
  for (const Case& c : smallWorlds()) {
    INFO(std::string(c.name) << " seed " << c.options.seed);
    const SimulatedWorld w = simulateWorld(c.kind, c.options);
    std::stringstream truth_file, data_file;
    writeModelG2o(truth_file, w.truth);
    writeModelG2o(data_file, w.dataset);
    const ModelDataset truth = parseModelDataset(truth_file, "truth.g2o");
    const ModelDataset data = parseModelDataset(data_file, "data.g2o");
    CHECK(truth.dimension == w.truth.dimension);
    CHECK(truth.factors.empty());
    CHECK(sameDataset(truth, w.truth));
    CHECK(sameDataset(data, w.dataset));
    for (std::size_t i = 0; i < truth.vertices.size(); ++i) {
      CHECK(truth.vertices[i].kind == w.truth.vertices[i].kind);
    }
  }
}

TEST_CASE("worlds: wrong loop closures join far poses, and leave the other factors as they were") {
  for (const WorldKind kind :
       {WorldKind::Grid2D, WorldKind::Sphere3D, WorldKind::Garage3D, WorldKind::Points3D}) {
    INFO(worldKindName(kind));
    WorldOptions o = defaultWorldOptions(kind);
    o.steps = 400;
    const SimulatedWorld clean = simulateWorld(kind, o);
    o.outlier_rate = 0.2;
    const SimulatedWorld dirty = simulateWorld(kind, o);
    const ModelEstimate truth = valuesOf(dirty.truth);
    const int dim = dirty.dataset.dimension;
    const double far = wrongLoopClosureDistance(o);
    const auto distance = [&](std::int64_t a, std::int64_t b) {
      return (truth.at({VariableRole::Pose, a}).head(dim) -
              truth.at({VariableRole::Pose, b}).head(dim))
          .norm();
    };
    // Eligible poses: those with an earlier pose, min_loop_separation back, farther than `far`.
    // Each gets a wrong loop closure with probability outlier_rate: a binomial count.
    double eligible = 0.0;
    for (int i = o.min_loop_separation; i < o.steps; ++i) {
      for (int j = 0; j + o.min_loop_separation <= i; ++j) {
        if (distance(i, j) > far) {
          ++eligible;
          break;
        }
      }
    }
    const double expected = eligible * o.outlier_rate;
    INFO(dirty.outliers.size() << " wrong loop closures, expected " << expected);
    CHECK(eligible >= 0.8 * (o.steps - o.min_loop_separation));
    CHECK(std::abs(static_cast<double>(dirty.outliers.size()) - expected) <=
          5.0 * std::sqrt(expected * (1.0 - o.outlier_rate)));
    std::vector<ModelFactor> kept;
    const auto odometry = std::find_if(
        dirty.dataset.factors.begin(), dirty.dataset.factors.end(), [](const ModelFactor& f) {
          return f.kind == FactorKind::BetweenSE2 || f.kind == FactorKind::BetweenSE3;
        });
    for (std::size_t i = 0, k = 0; i < dirty.dataset.factors.size(); ++i) {
      const ModelFactor& f = dirty.dataset.factors[i];
      if (k < dirty.outliers.size() && dirty.outliers[k] == i) {
        ++k;
        // Far apart in truth, at least min_loop_separation apart in time, a plausible measurement
        // (within loop_radius) with the odometry's information.
        CHECK(distance(f.first.id, f.second.id) > far);
        CHECK(f.first.id + o.min_loop_separation <= f.second.id);
        CHECK(f.measurement.head(dim).norm() <= o.loop_radius);
        CHECK(f.information == odometry->information);
        continue;
      }
      kept.push_back(f);
    }
    REQUIRE(kept.size() == clean.dataset.factors.size());
    for (std::size_t i = 0; i < kept.size(); ++i) {
      CHECK(kept[i].first == clean.dataset.factors[i].first);
      CHECK(kept[i].second == clean.dataset.factors[i].second);
      CHECK(kept[i].measurement == clean.dataset.factors[i].measurement);
    }
  }
}

TEST_CASE("worlds: grid2d without landmarks has generate's measurements") {
  SyntheticOptions g;
  g.poses = 300;
  g.seed = 5;
  const SyntheticWorld grid = generateManhattanWorld(g);
  WorldOptions o = defaultWorldOptions(WorldKind::Grid2D);
  o.steps = 300;
  o.seed = 5;
  o.landmarks = 0;
  const SimulatedWorld w = simulateWorld(WorldKind::Grid2D, o);
  REQUIRE(w.dataset.factors.size() == grid.dataset.edges.size());
  for (std::size_t i = 0; i < grid.dataset.edges.size(); ++i) {
    const Edge2D& e = grid.dataset.edges[i];
    const ModelFactor& f = w.dataset.factors[i];
    CHECK(f.first.id == e.from);
    CHECK(f.second.id == e.to);
    CHECK(f.measurement == Eigen::Vector3d(e.measurement.x, e.measurement.y, e.measurement.theta));
  }
  for (std::size_t i = 0; i < grid.ground_truth.size(); ++i) {
    const Pose2D& p = grid.ground_truth[i];
    CHECK(w.truth.vertices[i].value == Eigen::Vector3d(p.x, p.y, p.theta));
  }
}

TEST_CASE("worlds: geometry of each world") {
  WorldOptions sphere = defaultWorldOptions(WorldKind::Sphere3D);
  sphere.steps = 400;
  sphere.radius = 7.0;
  for (const ModelVertex& v : simulateWorld(WorldKind::Sphere3D, sphere).truth.vertices) {
    CHECK(v.value.head<3>().norm() == doctest::Approx(7.0).epsilon(1e-12));
  }
  WorldOptions garage = defaultWorldOptions(WorldKind::Garage3D);
  garage.steps = 800;
  garage.floors = 3;
  int top = 0;
  const std::vector<ModelVertex> floors = simulateWorld(WorldKind::Garage3D, garage).truth.vertices;
  for (std::size_t i = 0; i < floors.size(); ++i) {
    const Eigen::VectorXd& v = floors[i].value;
    CHECK(v[2] >= -1e-12);
    CHECK(v[2] <= 6.0 + 1e-12);
    if (v[2] > 6.0 - 1e-9) ++top;
    if (i == 0) continue;
    // It drives forward or back (the U-turns), never sideways: no lateral step in its own frame.
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    const Eigen::VectorXd& p = floors[i - 1].value;
    const Eigen::Quaterniond qp(p[6], p[3], p[4], p[5]);
    const Eigen::Vector3d step = qp.conjugate() * (v.head<3>() - p.head<3>());
    INFO("pose " << i);
    CHECK(std::abs(step.y()) < 1e-9);
  }
  CHECK(top > 0);  // reaches the top floor
  // points3d sweeps its radius out for 10 laps of 100 poses and back in for 10: a long run keeps
  // flying over the same landmarks, and sees some in every lap.
  WorldOptions points = defaultWorldOptions(WorldKind::Points3D);
  points.steps = 4000;
  const SimulatedWorld flown = simulateWorld(WorldKind::Points3D, points);
  std::vector<double> lap_radius(40, 0.0);
  std::vector<int> lap_observations(40, 0);
  for (int i = 0; i < points.steps; ++i) {
    const Eigen::VectorXd& v = flown.truth.vertices[static_cast<std::size_t>(i)].value;
    lap_radius[static_cast<std::size_t>(i / 100)] =
        std::max(lap_radius[static_cast<std::size_t>(i / 100)], std::hypot(v[0], v[1]));
  }
  for (const ModelFactor& f : flown.dataset.factors) {
    if (f.second.role == VariableRole::Landmark) ++lap_observations[f.first.id / 100];
  }
  for (std::size_t lap = 0; lap < 40; ++lap) {
    CAPTURE(lap);
    const double swept = static_cast<double>(std::min(lap % 20, 20 - lap % 20));
    CHECK(lap_radius[lap] == doctest::Approx(points.radius + 0.3 * swept).epsilon(1e-9));
    CHECK(lap_observations[lap] > 50);
  }
  // Landmarks: every observed one exists, and each lies within the sensor's range of its pose.
  WorldOptions grid = defaultWorldOptions(WorldKind::Grid2D);
  grid.steps = 300;
  const SimulatedWorld w = simulateWorld(WorldKind::Grid2D, grid);
  const ModelEstimate truth = valuesOf(w.truth);
  int observations = 0;
  for (const ModelFactor& f : w.dataset.factors) {
    if (f.second.role != VariableRole::Landmark) continue;
    ++observations;
    CHECK(f.second.id >= grid.steps);
    CHECK((truth.at(f.first).head<2>() - truth.at(f.second)).norm() <= grid.sensor_range);
  }
  CHECK(observations > 0);
  CHECK(observations <= grid.steps * grid.max_observations_per_pose);
}

TEST_CASE("worlds: options out of range are rejected") {
  WorldOptions o;
  o.steps = 1;
  CHECK_THROWS_AS(simulateWorld(WorldKind::Grid2D, o), std::invalid_argument);
  o = WorldOptions{};
  o.sigma_rotation = 0.0;
  CHECK_THROWS_AS(simulateWorld(WorldKind::Sphere3D, o), std::invalid_argument);
  o = WorldOptions{};
  o.outlier_rate = 1.5;
  CHECK_THROWS_AS(simulateWorld(WorldKind::Garage3D, o), std::invalid_argument);
  o = WorldOptions{};
  o.floors = 0;
  CHECK_THROWS_AS(simulateWorld(WorldKind::Garage3D, o), std::invalid_argument);
  CHECK(parseWorldKind("grid2d") == WorldKind::Grid2D);
  CHECK(parseWorldKind("points3d") == WorldKind::Points3D);
  CHECK_FALSE(parseWorldKind("moon").has_value());
}
