// Tests of the batch reference solver for every model (host_sim/model_batch_solver.h) on random
// problems from fixed seeds (truth, noisy measurements, perturbed start): convergence, a zero
// gradient of chi2 by central differences at the end, agreement with solveBatch2D on 2D pose
// graphs, exact problems solved to chi2 ~ 0, the gauge and invalid input.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "host_sim/batch_solver.h"
#include "host_sim/chi2.h"
#include "host_sim/model_batch_solver.h"
#include "host_sim/model_chi2.h"
#include "model_test_support.h"

using lslam::sim::BatchMethod;
using lslam::sim::BatchOptions;
using lslam::sim::FactorKind;
using lslam::sim::ModelBatchResult;
using lslam::sim::ModelDataset;
using lslam::sim::ModelEstimate;
using lslam::sim::ModelFactor;
using lslam::sim::ObjectiveConvention;
using lslam::sim::VariableKey;
using lslam::sim::VariableKind;
using lslam::sim::VariableRole;
using lslam::sim::Vector7d;
namespace sim = lslam::sim;
using namespace lslam::sim::test;

namespace {

constexpr double kPi = 3.14159265358979323846;

VariableKind kindOf(const ModelDataset& d, const VariableKey& k) {
  return sim::variableKinds(d).at(k);
}

// Largest |d chi2 / d delta| over every variable not in `fixed` (delta along the retraction), by
// central differences of sim::chi2.
double maxAbsGradient(const ModelDataset& d, const ModelEstimate& est,
                      const std::vector<VariableKey>& fixed) {
  const double h = 1e-6;
  double worst = 0.0;
  const auto kinds = sim::variableKinds(d);
  for (const auto& [key, kind] : kinds) {
    if (std::find(fixed.begin(), fixed.end(), key) != fixed.end()) continue;
    for (int k = 0; k < sim::tangentDimension(kind); ++k) {
      Eigen::VectorXd delta = Eigen::VectorXd::Zero(sim::tangentDimension(kind));
      ModelEstimate plus = est;
      ModelEstimate minus = est;
      delta[k] = h;
      plus[key] = sim::retractModel(kind, est.at(key), delta);
      delta[k] = -h;
      minus[key] = sim::retractModel(kind, est.at(key), delta);
      worst = std::max(worst, std::abs(sim::chi2(d, plus) - sim::chi2(d, minus)) / (2.0 * h));
    }
  }
  return worst;
}

struct Problem {
  ModelDataset d;
  ModelEstimate truth;
  ModelEstimate initial;
};

// 2D: poses on a random walk, odometry and loop closures; optionally point landmarks observed as
// PointXY2 and RangeBearing2, one landmark prior. Noise `sigma` on measurements (0: exact).
Problem make2D(unsigned seed, ObjectiveConvention convention, bool landmarks, double sigma) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Problem p;
  p.d.convention = convention;
  p.d.dimension = 2;
  const int n = 6 + static_cast<int>(seed % 10);
  Eigen::Vector3d x(u(rng), u(rng), kPi * u(rng));
  for (int i = 0; i < n; ++i) {
    p.truth[pose(3 + i)] = x;
    x = fromH2(h2(x) * h2(Eigen::Vector3d(1.0 + 0.3 * u(rng), 0.3 * u(rng), 0.7 * u(rng))));
  }
  const auto between = [&](int i, int j) {
    const Eigen::VectorXd exact =
        fromH2(h2(p.truth.at(pose(3 + i))).inverse() * h2(p.truth.at(pose(3 + j))));
    const Eigen::Vector3d z = exact + sigma * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng));
    p.d.factors.push_back(factor(FactorKind::BetweenSE2, pose(3 + i), pose(3 + j), z,
                                 randomInformation(rng, Eigen::Vector3d(10.0, 10.0, 40.0))));
  };
  for (int i = 0; i + 1 < n; ++i) between(i, i + 1);
  std::uniform_int_distribution<int> pick(0, n - 1);
  for (int k = 0; k < n / 2; ++k) {
    const int i = pick(rng);
    const int j = pick(rng);
    if (i != j) between(i, j);
  }
  if (landmarks) {
    const int m = 4;
    for (int l = 0; l < m; ++l) {
      const Eigen::Vector2d pos =
          p.truth.at(pose(3 + pick(rng))).head<2>() + Eigen::Vector2d(2.0 * u(rng), 2.0 * u(rng));
      p.truth[landmark(l)] = pos;
      for (int i = 0; i < n; ++i) {
        if (u(rng) < 0.0 && i != l) continue;
        const Eigen::VectorXd& xi = p.truth.at(pose(3 + i));
        const Eigen::Vector2d local =
            Eigen::Rotation2Dd(xi[2]).matrix().transpose() * (pos - xi.head<2>());
        if ((i + l) % 2 == 0) {
          p.d.factors.push_back(factor(FactorKind::PointXY2, pose(3 + i), landmark(l),
                                       local + sigma * Eigen::Vector2d(gauss(rng), gauss(rng)),
                                       randomInformation(rng, Eigen::Vector2d(20.0, 20.0))));
        } else {
          const Eigen::Vector2d rb(local.norm() + sigma * gauss(rng),
                                   std::atan2(local.y(), local.x()) + sigma * gauss(rng));
          p.d.factors.push_back(factor(FactorKind::RangeBearing2, pose(3 + i), landmark(l), rb,
                                       randomInformation(rng, Eigen::Vector2d(20.0, 50.0))));
        }
      }
    }
    p.d.factors.push_back(factor(FactorKind::PriorPoint2, landmark(0), VariableKey{},
                                 p.truth.at(landmark(0)) + sigma * Eigen::Vector2d(gauss(rng), 0),
                                 Eigen::Matrix2d::Identity()));
  }
  // Start: the online initial values from the true first pose, perturbed.
  ModelDataset first = p.d;
  sim::ModelVertex v0;
  v0.key = pose(3);
  v0.kind = VariableKind::SE2;
  v0.value = p.truth.at(pose(3));
  first.vertices.push_back(v0);
  p.initial = sim::initialEstimate(first);
  for (auto& [key, value] : p.initial) {
    if (key == pose(3)) continue;
    value[0] += 0.1 * gauss(rng);
    value[1] += 0.1 * gauss(rng);
    if (key.role == VariableRole::Pose) value[2] += 0.05 * gauss(rng);
  }
  return p;
}

// 3D: SE3 poses on a random walk, odometry and loop closures; optionally Point3 landmarks
// (PointXYZ3), one pose prior, one landmark prior.
Problem make3D(unsigned seed, ObjectiveConvention convention, bool landmarks, double sigma) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Problem p;
  p.d.convention = convention;
  p.d.dimension = 3;
  const int n = 6 + static_cast<int>(seed % 10);
  const auto randomStep = [&](double t, double r) {
    Eigen::VectorXd d(6);
    for (int k = 0; k < 6; ++k) d[k] = (k < 3 ? t : r) * u(rng);
    return d;
  };
  Eigen::VectorXd start(7);
  start << u(rng), u(rng), u(rng), 0.0, 0.0, 0.0, 1.0;
  Eigen::VectorXd x = sim::retractModel(VariableKind::SE3, start, randomStep(1.0, 2.0));
  for (int i = 0; i < n; ++i) {
    p.truth[pose(i)] = x;
    Eigen::VectorXd step = randomStep(0.3, 0.5);
    step[0] += 1.0;
    x = sim::retractModel(VariableKind::SE3, x, step);
  }
  const Eigen::VectorXd diag6 = (Eigen::VectorXd(6) << 10, 10, 10, 40, 40, 40).finished();
  const auto noisy = [&](const Eigen::VectorXd& exact) {
    Eigen::VectorXd d(6);
    for (int k = 0; k < 6; ++k) d[k] = sigma * gauss(rng);
    return sim::retractModel(VariableKind::SE3, exact, d);
  };
  const auto between = [&](int i, int j) {
    const Eigen::VectorXd exact =
        fromH3(h3(p.truth.at(pose(i))).inverse() * h3(p.truth.at(pose(j))));
    p.d.factors.push_back(factor(FactorKind::BetweenSE3, pose(i), pose(j), noisy(exact),
                                 randomInformation(rng, diag6)));
  };
  for (int i = 0; i + 1 < n; ++i) between(i, i + 1);
  std::uniform_int_distribution<int> pick(0, n - 1);
  for (int k = 0; k < n / 2; ++k) {
    const int i = pick(rng);
    const int j = pick(rng);
    if (i != j) between(i, j);
  }
  if (landmarks) {
    for (int l = 0; l < 4; ++l) {
      const Eigen::Vector3d pos = p.truth.at(pose(pick(rng))).head<3>() +
                                  Eigen::Vector3d(2.0 * u(rng), 2.0 * u(rng), 2.0 * u(rng));
      p.truth[landmark(l)] = pos;
      for (int i = 0; i < n; ++i) {
        if (u(rng) < 0.0 && i != l) continue;
        const Eigen::Vector4d local =
            h3(p.truth.at(pose(i))).inverse() * Eigen::Vector4d(pos.x(), pos.y(), pos.z(), 1.0);
        p.d.factors.push_back(
            factor(FactorKind::PointXYZ3, pose(i), landmark(l),
                   local.head<3>() + sigma * Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)),
                   randomInformation(rng, Eigen::Vector3d(20.0, 20.0, 20.0))));
      }
    }
    p.d.factors.push_back(factor(FactorKind::PriorSE3, pose(2), VariableKey{},
                                 noisy(p.truth.at(pose(2))), randomInformation(rng, diag6)));
    p.d.factors.push_back(factor(FactorKind::PriorPoint3, landmark(1), VariableKey{},
                                 p.truth.at(landmark(1)), Eigen::Matrix3d::Identity()));
  }
  p.initial = p.truth;
  for (auto& [key, value] : p.initial) {
    if (key == pose(0)) continue;
    if (key.role == VariableRole::Pose) {
      value = sim::retractModel(VariableKind::SE3, value, randomStep(0.2, 0.1));
    } else {
      value += Eigen::Vector3d(0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng));
    }
  }
  return p;
}

void checkSolved(const Problem& p, const std::string& what) {
  for (const BatchMethod method : {BatchMethod::LevenbergMarquardt, BatchMethod::GaussNewton}) {
    BatchOptions o;
    o.method = method;
    const ModelBatchResult r = sim::solveModelBatch(p.d, p.initial, o);
    const double g0 = maxAbsGradient(p.d, p.initial, r.fixed);
    const double g1 = maxAbsGradient(p.d, r.values, r.fixed);
    CAPTURE(what);
    CAPTURE(method == BatchMethod::GaussNewton ? "GN" : "LM");
    CAPTURE(r.stop_reason);
    CAPTURE(r.chi2_initial);
    CAPTURE(r.chi2);
    CAPTURE(g0);
    CAPTURE(g1);
    CHECK(r.converged);
    CHECK(r.chi2 <= r.chi2_initial);
    CHECK(g1 < 1e-5 * std::max(1.0, r.chi2));
    CHECK(g1 < 1e-6 * g0);
    CHECK(r.values.size() == p.initial.size());
    CHECK(sim::chi2(p.d, r.values) == r.chi2);
    for (const VariableKey& k : r.fixed) CHECK(r.values.at(k) == p.initial.at(k));
  }
}

}  // namespace

TEST_CASE("retractModel: SE3 composes with the increment read as a pose; points add") {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    Eigen::Vector4d q(u(rng), u(rng), u(rng), u(rng));
    q.normalize();
    Eigen::VectorXd x(7);
    x << u(rng), u(rng), u(rng), q[0], q[1], q[2], q[3];
    Eigen::VectorXd d(6);
    for (int k = 0; k < 6; ++k) d[k] = u(rng);
    Eigen::Matrix4d inc = Eigen::Matrix4d::Identity();
    inc.topLeftCorner<3, 3>() =
        Eigen::AngleAxisd(d.tail<3>().norm(), d.tail<3>().normalized()).matrix();
    inc.topRightCorner<3, 1>() = d.head<3>();
    const Eigen::VectorXd y = sim::retractModel(VariableKind::SE3, x, d);
    CHECK((h3(y) - h3(x) * inc).norm() < 1e-12);
    CHECK(y.tail<4>().norm() == doctest::Approx(1.0).epsilon(1e-14));
    // SE2 as retract2D.
    const Eigen::VectorXd p2 = sim::retractModel(VariableKind::SE2, x.head<3>(), d.head<3>());
    const sim::Pose2D r2 = sim::retract2D(sim::Pose2D{x[0], x[1], x[2]}, d.head<3>());
    CHECK(p2 == Eigen::Vector3d(r2.x, r2.y, r2.theta));
    CHECK(sim::retractModel(VariableKind::Point3, x.head<3>(), d.head<3>()) ==
          Eigen::VectorXd(x.head<3>() + d.head<3>()));
    CHECK(sim::retractModel(VariableKind::Point2, x.head<2>(), d.head<2>()) ==
          Eigen::VectorXd(x.head<2>() + d.head<2>()));
  }
  CHECK_THROWS_AS(sim::retractModel(VariableKind::SE3, Eigen::VectorXd(3), Eigen::VectorXd(6)),
                  std::invalid_argument);
}

TEST_CASE("random 2D and 3D problems converge to a stationary point (both conventions)") {
  for (unsigned seed = 1; seed <= 12; ++seed) {
    for (const ObjectiveConvention c : {ObjectiveConvention::G2o, ObjectiveConvention::Isam}) {
      const std::string conv = c == ObjectiveConvention::G2o ? "G2o" : "Isam";
      checkSolved(make2D(seed, c, false, 0.05),
                  "2D poses " + conv + " seed " + std::to_string(seed));
      checkSolved(make2D(seed, c, true, 0.05),
                  "2D landmarks " + conv + " seed " + std::to_string(seed));
      checkSolved(make3D(seed, c, false, 0.05),
                  "3D poses " + conv + " seed " + std::to_string(seed));
      checkSolved(make3D(seed, c, true, 0.05),
                  "3D landmarks " + conv + " seed " + std::to_string(seed));
    }
  }
}

TEST_CASE("exact problems are solved to chi2 ~ 0 and the truth (up to the fixed pose)") {
  for (unsigned seed = 1; seed <= 6; ++seed) {
    for (const ObjectiveConvention c : {ObjectiveConvention::G2o, ObjectiveConvention::Isam}) {
      for (const bool three : {false, true}) {
        const Problem p = three ? make3D(seed, c, true, 0.0) : make2D(seed, c, true, 0.0);
        ModelEstimate init = p.initial;
        // Hold the true first pose (make2D starts from it; make3D leaves pose 0 unperturbed).
        const ModelBatchResult r = sim::solveModelBatch(p.d, init);
        CAPTURE(seed);
        CAPTURE(three);
        CAPTURE(r.stop_reason);
        CHECK(r.converged);
        CHECK(r.chi2 < 1e-14);
        for (const auto& [key, value] : p.truth) {
          const Eigen::VectorXd& got = r.values.at(key);
          if (kindOf(p.d, key) == VariableKind::SE3) {
            CHECK((h3(got) - h3(value)).norm() < 1e-6);
          } else {
            CHECK((got - value).norm() < 1e-6);
          }
        }
      }
    }
  }
}

TEST_CASE("2D pose graphs: the same optimum as solveBatch2D") {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const Problem p = make2D(seed, ObjectiveConvention::G2o, false, 0.1);
    sim::Dataset2D d2;
    for (const ModelFactor& f : p.d.factors) {
      sim::Edge2D e;
      e.from = f.first.id;
      e.to = f.second.id;
      e.measurement = sim::Pose2D{f.measurement[0], f.measurement[1], f.measurement[2]};
      e.information = f.information;
      d2.edges.push_back(e);
    }
    sim::Estimate2D init2;
    for (const auto& [key, v] : p.initial) init2[key.id] = sim::Pose2D{v[0], v[1], v[2]};
    for (const BatchMethod method : {BatchMethod::LevenbergMarquardt, BatchMethod::GaussNewton}) {
      BatchOptions o;
      o.method = method;
      const sim::BatchResult ref = sim::solveBatch2D(d2, init2, o);
      const ModelBatchResult r = sim::solveModelBatch(p.d, p.initial, o);
      CAPTURE(seed);
      CHECK(ref.converged);
      CHECK(r.converged);
      CHECK(r.chi2_initial == doctest::Approx(ref.chi2_initial).epsilon(1e-12));
      CHECK(r.chi2 == doctest::Approx(ref.chi2).epsilon(1e-10));
      for (const auto& [id, q] : ref.poses) {
        const Eigen::VectorXd& v = r.values.at(pose(id));
        CHECK(std::abs(v[0] - q.x) < 1e-7);
        CHECK(std::abs(v[1] - q.y) < 1e-7);
        CHECK(std::abs(std::remainder(v[2] - q.theta, 2 * kPi)) < 1e-7);
      }
    }
  }
}

TEST_CASE("gauge: explicit ids, FIX poses (landmark FIX ignored), default smallest pose id") {
  const Problem p = make2D(4, ObjectiveConvention::G2o, true, 0.05);
  ModelBatchResult r = sim::solveModelBatch(p.d, p.initial);
  REQUIRE(r.fixed.size() == 1);
  CHECK(r.fixed[0] == pose(3));
  ModelDataset d = p.d;
  d.fixed = {landmark(0), pose(5)};
  r = sim::solveModelBatch(d, p.initial);
  REQUIRE(r.fixed.size() == 1);
  CHECK(r.fixed[0] == pose(5));
  CHECK(r.values.at(pose(5)) == p.initial.at(pose(5)));
  CHECK(r.values.at(landmark(0)) != p.initial.at(landmark(0)));
  CHECK(r.converged);
  BatchOptions o;
  o.fixed = {4, 6};
  r = sim::solveModelBatch(d, p.initial, o);
  REQUIRE(r.fixed.size() == 2);
  CHECK(r.values.at(pose(4)) == p.initial.at(pose(4)));
  CHECK(r.values.at(pose(6)) == p.initial.at(pose(6)));
  CHECK(r.converged);
  // Values of variables no factor uses pass through.
  ModelEstimate extra = p.initial;
  extra[pose(1000)] = Eigen::Vector3d(1.0, 2.0, 3.0);
  r = sim::solveModelBatch(p.d, extra);
  CHECK(r.values.at(pose(1000)) == Eigen::Vector3d(1.0, 2.0, 3.0));
}

TEST_CASE("invalid input throws std::invalid_argument") {
  const Problem p = make3D(2, ObjectiveConvention::G2o, true, 0.05);
  ModelEstimate missing = p.initial;
  missing.erase(landmark(1));
  CHECK_THROWS_AS(sim::solveModelBatch(p.d, missing), std::invalid_argument);
  ModelEstimate wrong = p.initial;
  wrong[pose(1)] = Eigen::Vector3d::Zero();
  CHECK_THROWS_AS(sim::solveModelBatch(p.d, wrong), std::invalid_argument);
  ModelDataset bad = p.d;
  bad.factors[0].information(0, 0) = -1.0;
  CHECK_THROWS_AS(sim::solveModelBatch(bad, p.initial), std::invalid_argument);
  bad = p.d;
  bad.factors[0].measurement = Eigen::VectorXd(3);
  CHECK_THROWS_AS(sim::solveModelBatch(bad, p.initial), std::invalid_argument);
  // No factors: nothing to solve.
  const ModelBatchResult r = sim::solveModelBatch(ModelDataset{}, p.initial);
  CHECK(r.converged);
  CHECK(r.chi2 == 0.0);
}
