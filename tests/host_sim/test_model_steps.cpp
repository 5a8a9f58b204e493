// Tests of the online step builder of every model (host_sim/model_steps.h): step contents of
// hand-made 2D and 3D datasets with landmarks, every factor exactly once, landmark entry, the
// errors and their lines, initial values against hand computations, and the real files.
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <unordered_set>
#include <utility>
#include <vector>

#include "dataset_files.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/model_steps.h"

using lslam::sim::test::datasetPath;
using lslam::sim::test::present;

using lslam::sim::buildModelSteps;
using lslam::sim::DatasetError;
using lslam::sim::FactorKind;
using lslam::sim::initialValue;
using lslam::sim::ModelDataset;
using lslam::sim::ModelEstimate;
using lslam::sim::ModelFactor;
using lslam::sim::ModelStep;
using lslam::sim::ModelVertex;
using lslam::sim::VariableKey;
using lslam::sim::VariableKind;
using lslam::sim::VariableRole;
namespace sim = lslam::sim;

namespace {

constexpr double kPi = 3.14159265358979323846;

VariableKey pose(std::int64_t id) {
  return {VariableRole::Pose, id};
}
VariableKey lm(std::int64_t id) {
  return {VariableRole::Landmark, id};
}

// Hand geometry (homogeneous matrices), independent of the code under test.
Eigen::Matrix3d mat2(const Eigen::VectorXd& p) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m.topLeftCorner<2, 2>() << std::cos(p[2]), -std::sin(p[2]), std::sin(p[2]), std::cos(p[2]);
  m(0, 2) = p[0];
  m(1, 2) = p[1];
  return m;
}
Eigen::VectorXd params2(const Eigen::Matrix3d& m) {
  return Eigen::Vector3d(m(0, 2), m(1, 2), std::atan2(m(1, 0), m(0, 0)));
}
Eigen::Matrix4d mat3(const Eigen::VectorXd& p) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::Quaterniond(p[6], p[3], p[4], p[5]).toRotationMatrix();
  m.topRightCorner<3, 1>() = p.head<3>();
  return m;
}
Eigen::VectorXd params3(const Eigen::Matrix4d& m) {
  const Eigen::Quaterniond q(Eigen::Matrix3d(m.topLeftCorner<3, 3>()));
  Eigen::VectorXd p(7);
  p << m.topRightCorner<3, 1>(), q.x(), q.y(), q.z(), q.w();
  return p;
}
Eigen::VectorXd se3(double x, double y, double z, double roll, double pitch, double yaw) {
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  Eigen::VectorXd p(7);
  p << x, y, z, q.x(), q.y(), q.z(), q.w();
  return p;
}

ModelFactor factor(FactorKind kind, VariableKey a, VariableKey b, Eigen::VectorXd z,
                   std::size_t line) {
  ModelFactor f;
  f.kind = kind;
  f.first = a;
  f.second = b;
  f.measurement = std::move(z);
  const int n = sim::errorDimension(kind);
  f.information = Eigen::MatrixXd::Identity(n, n);
  f.line = line;
  return f;
}

// Distance between two values of a kind (SE2 angle wrapped; SE3 quaternion sign ignored).
double distance(VariableKind kind, const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  REQUIRE(a.size() == sim::parameterCount(kind));
  REQUIRE(b.size() == sim::parameterCount(kind));
  if (kind == VariableKind::SE2) {
    return std::max((a.head<2>() - b.head<2>()).cwiseAbs().maxCoeff(),
                    std::abs(std::remainder(a[2] - b[2], 2.0 * kPi)));
  }
  if (kind == VariableKind::SE3) {
    const double dq = std::min((a.tail<4>() - b.tail<4>()).cwiseAbs().maxCoeff(),
                               (a.tail<4>() + b.tail<4>()).cwiseAbs().maxCoeff());
    return std::max((a.head<3>() - b.head<3>()).cwiseAbs().maxCoeff(), dq);
  }
  return (a - b).cwiseAbs().maxCoeff();
}

// The invariants of any step list: ascending poses, every factor exactly once, every variable
// introduced once, and a step's factors only on variables introduced so far.
void checkInvariants(const ModelDataset& d, const std::vector<ModelStep>& steps) {
  std::vector<int> seen(d.factors.size(), 0);
  std::unordered_set<VariableKey, sim::VariableKeyHash> introduced;
  std::int64_t last_pose = -1;
  for (const ModelStep& s : steps) {
    if (s.new_pose.id >= 0) {
      CHECK(s.new_pose.role == VariableRole::Pose);
      CHECK(s.new_pose.id > last_pose);
      last_pose = s.new_pose.id;
      CHECK(introduced.insert(s.new_pose).second);
    }
    for (const VariableKey& k : s.new_landmarks) {
      CHECK(k.role == VariableRole::Landmark);
      CHECK(introduced.insert(k).second);
    }
    for (std::size_t i : s.factors) {
      REQUIRE(i < d.factors.size());
      ++seen[i];
      const ModelFactor& f = d.factors[i];
      CHECK(introduced.count(f.first) == 1);
      if (sim::arity(f.kind) == 2) CHECK(introduced.count(f.second) == 1);
    }
    for (std::size_t j = 1; j < s.factors.size(); ++j) CHECK(s.factors[j - 1] < s.factors[j]);
  }
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (seen[i] != 1) FAIL("factor " << i << " (line " << d.factors[i].line << ") in " << seen[i]);
  }
}

// Chains initialValue over the steps from an empty estimate.
ModelEstimate chain(const ModelDataset& d, const std::vector<ModelStep>& steps) {
  ModelEstimate est;
  for (const ModelStep& s : steps) {
    if (s.new_pose.id >= 0) est[s.new_pose] = initialValue(d, s, s.new_pose, est);
    for (const VariableKey& k : s.new_landmarks) est[k] = initialValue(d, s, k, est);
  }
  return est;
}

std::size_t errorLine(const ModelDataset& d) {
  try {
    buildModelSteps(d);
  } catch (const DatasetError& e) {
    MESSAGE(std::string(e.what()));
    return e.line();
  }
  FAIL("no DatasetError");
  return 0;
}

// A noise-free 2D dataset: poses 0..3, landmarks 1, 4, 7 (their own ids: landmark 1 and pose 1
// coexist), lines 1..10 in the order below.
struct World2 {
  ModelDataset d;
  std::vector<Eigen::VectorXd> x;  // poses 0..3
  Eigen::Vector2d l1{2.0, 1.5}, l4{-1.0, 3.0}, l7{4.0, -2.0};
};

Eigen::VectorXd local2(const Eigen::VectorXd& x, const Eigen::Vector2d& l) {
  return (mat2(x).inverse() * Eigen::Vector3d(l.x(), l.y(), 1.0)).head<2>();
}

World2 makeWorld2() {
  World2 w;
  w.x = {Eigen::Vector3d(0.5, -0.2, 0.3), Eigen::Vector3d(1.5, 0.4, 1.2),
         Eigen::Vector3d(1.0, 2.0, 2.9), Eigen::Vector3d(-0.5, 1.0, -2.8)};
  const auto rel = [&](int i, int j) { return params2(mat2(w.x[i]).inverse() * mat2(w.x[j])); };
  const Eigen::Vector2d d7 = local2(w.x[2], w.l7);
  ModelDataset& d = w.d;
  d.name = "world2";
  d.factors = {
      factor(FactorKind::BetweenSE2, pose(0), pose(1), rel(0, 1), 1),
      factor(FactorKind::PointXY2, pose(0), lm(1), local2(w.x[0], w.l1), 2),
      factor(FactorKind::BetweenSE2, pose(1), pose(2), rel(1, 2), 3),
      factor(FactorKind::RangeBearing2, pose(2), lm(7),
             Eigen::Vector2d(d7.norm(), std::atan2(d7.y(), d7.x())), 4),
      factor(FactorKind::PointXY2, pose(1), lm(4), local2(w.x[1], w.l4), 5),
      factor(FactorKind::PriorPoint2, lm(7), {}, w.l7, 6),
      factor(FactorKind::BetweenSE2, pose(3), pose(2), rel(3, 2), 7),  // stored new -> older
      factor(FactorKind::BetweenSE2, pose(0), pose(3), rel(0, 3), 8),
      factor(FactorKind::PointXY2, pose(3), lm(1), local2(w.x[3], w.l1), 9),
      factor(FactorKind::PriorSE2, pose(0), {}, w.x[0], 10),
  };
  return w;
}

}  // namespace

TEST_CASE("model steps: 2D poses and landmarks, contents and initial values") {
  const World2 w = makeWorld2();
  const std::vector<ModelStep> steps = buildModelSteps(w.d);
  REQUIRE(steps.size() == 4);
  checkInvariants(w.d, steps);
  for (int k = 0; k < 4; ++k) CHECK(steps[k].new_pose == pose(k));
  CHECK(steps[0].factors == std::vector<std::size_t>{1, 9});
  CHECK(steps[0].new_landmarks == std::vector<VariableKey>{lm(1)});
  CHECK(steps[1].factors == std::vector<std::size_t>{0, 4});
  CHECK(steps[1].new_landmarks == std::vector<VariableKey>{lm(4)});
  CHECK(steps[2].factors == std::vector<std::size_t>{2, 3, 5});  // the landmark prior with it
  CHECK(steps[2].new_landmarks == std::vector<VariableKey>{lm(7)});
  CHECK(steps[3].factors == std::vector<std::size_t>{6, 7, 8});
  CHECK(steps[3].new_landmarks.empty());

  // Noise-free: chaining from the prior on pose 0 reproduces the truth.
  const ModelEstimate est = chain(w.d, steps);
  REQUIRE(est.size() == 7);
  for (int k = 0; k < 4; ++k) CHECK(distance(VariableKind::SE2, est.at(pose(k)), w.x[k]) < 1e-12);
  CHECK(distance(VariableKind::Point2, est.at(lm(1)), w.l1) < 1e-12);
  CHECK(distance(VariableKind::Point2, est.at(lm(4)), w.l4) < 1e-12);
  CHECK(distance(VariableKind::Point2, est.at(lm(7)), w.l7) < 1e-12);

  // Hand computations with values that are not the truth: pose 3 from line 7 (3 -> 2 stored):
  // x2 * z^-1; landmark 7 from its range-bearing observation, not its prior.
  ModelEstimate cur;
  cur[pose(2)] = Eigen::Vector3d(10.0, -3.0, 0.5);
  const Eigen::VectorXd z = w.d.factors[6].measurement;
  const Eigen::VectorXd x3 = initialValue(w.d, steps[3], pose(3), cur);
  CHECK(distance(VariableKind::SE2, x3, params2(mat2(cur[pose(2)]) * mat2(z).inverse())) < 1e-12);
  const Eigen::Vector2d rb = w.d.factors[3].measurement;
  const Eigen::Vector2d l7 = Eigen::Vector2d(10.0, -3.0) +
                             rb[0] * Eigen::Vector2d(std::cos(0.5 + rb[1]), std::sin(0.5 + rb[1]));
  CHECK(distance(VariableKind::Point2, initialValue(w.d, steps[2], lm(7), cur), l7) < 1e-12);
  // Step 0's pose from its prior; without the prior, the origin.
  CHECK(distance(VariableKind::SE2, initialValue(w.d, steps[0], pose(0), {}), w.x[0]) < 1e-15);
  ModelDataset no_prior = w.d;
  no_prior.factors.pop_back();
  const auto steps2 = buildModelSteps(no_prior);
  CHECK(steps2[0].factors == std::vector<std::size_t>{1});
  CHECK(initialValue(no_prior, steps2[0], pose(0), {}) == Eigen::Vector3d::Zero());

  // Misuse.
  CHECK_THROWS_AS(initialValue(w.d, steps[3], pose(2), cur), std::invalid_argument);
  CHECK_THROWS_AS(initialValue(w.d, steps[3], lm(1), cur), std::invalid_argument);
  CHECK_THROWS_AS(initialValue(w.d, steps[1], pose(1), {}), std::invalid_argument);  // no pose 0
}

TEST_CASE("model steps: 3D poses and point landmarks") {
  const std::vector<Eigen::VectorXd> x = {se3(1, 2, 3, 0.1, -0.2, 0.3), se3(2, 2, 3, 0.4, 0.2, 1.0),
                                          se3(2, 4, 1, -0.3, 0.5, 2.5)};
  const Eigen::Vector3d p0(5, 1, 2), p3(-1, 7, 0.5), p9(0, 0, 10);
  const auto rel = [&](int i, int j) { return params3(mat3(x[i]).inverse() * mat3(x[j])); };
  const auto local = [&](int i, const Eigen::Vector3d& p) {
    return Eigen::Vector3d((mat3(x[i]).inverse() * p.homogeneous()).head<3>());
  };
  ModelDataset d;
  d.name = "world3";
  d.dimension = 3;
  // Poses 10, 11, 12; landmarks 0, 3 observed; landmark 9 declared with a prior only.
  ModelVertex v9;
  v9.key = lm(9);
  v9.kind = VariableKind::Point3;
  v9.value = Eigen::Vector3d(100, 100, 100);  // vertex values are not used
  v9.line = 1;
  d.vertices = {v9};
  d.factors = {
      factor(FactorKind::PointXYZ3, pose(11), lm(3), local(1, p3), 2),
      factor(FactorKind::BetweenSE3, pose(11), pose(10), rel(1, 0), 3),  // stored new -> older
      factor(FactorKind::PointXYZ3, pose(10), lm(0), local(0, p0), 4),
      factor(FactorKind::PriorPoint3, lm(9), {}, p9, 5),
      factor(FactorKind::BetweenSE3, pose(11), pose(12), rel(1, 2), 6),
      factor(FactorKind::PointXYZ3, pose(12), lm(0), local(2, p0), 7),
      factor(FactorKind::PointXYZ3, pose(10), lm(3), local(0, p3), 8),
      factor(FactorKind::PriorPoint3, lm(3), {}, p3, 9),
      factor(FactorKind::BetweenSE3, pose(10), pose(12), rel(0, 2), 10),
  };
  const auto steps = buildModelSteps(d);
  REQUIRE(steps.size() == 3);
  checkInvariants(d, steps);
  CHECK(steps[0].new_pose == pose(10));
  CHECK(steps[0].factors == std::vector<std::size_t>{2, 3, 6, 7});
  // Landmark 3: first observed from pose 10 (line 8) although line 2 observes it from pose 11.
  CHECK(steps[0].new_landmarks == std::vector<VariableKey>{lm(0), lm(3), lm(9)});
  CHECK(steps[1].new_pose == pose(11));
  CHECK(steps[1].factors == std::vector<std::size_t>{0, 1});
  CHECK(steps[1].new_landmarks.empty());
  CHECK(steps[2].new_pose == pose(12));
  CHECK(steps[2].factors == std::vector<std::size_t>{4, 5, 8});

  // Step 0 starts at the identity (no pose prior): the chain is the truth seen from pose 10.
  const ModelEstimate est = chain(d, steps);
  const Eigen::Matrix4d to10 = mat3(x[0]).inverse();
  CHECK(distance(VariableKind::SE3, est.at(pose(10)), se3(0, 0, 0, 0, 0, 0)) == 0.0);
  for (int k = 0; k < 3; ++k) {
    CHECK(distance(VariableKind::SE3, est.at(pose(10 + k)), params3(to10 * mat3(x[k]))) < 1e-12);
  }
  CHECK(distance(VariableKind::Point3, est.at(lm(0)), (to10 * p0.homogeneous()).head<3>()) < 1e-12);
  CHECK(distance(VariableKind::Point3, est.at(lm(3)), (to10 * p3.homogeneous()).head<3>()) < 1e-12);
  CHECK(distance(VariableKind::Point3, est.at(lm(9)), p9) == 0.0);  // from its prior

  // Hand computations: pose 11 from line 3 (11 -> 10 stored): x10 * z^-1; from a pose prior.
  ModelEstimate cur;
  cur[pose(10)] = x[2];
  const Eigen::VectorXd x11 = initialValue(d, steps[1], pose(11), cur);
  CHECK(distance(VariableKind::SE3, x11,
                 params3(mat3(x[2]) * mat3(d.factors[1].measurement).inverse())) < 1e-12);
  ModelDataset with_prior = d;
  with_prior.factors.insert(with_prior.factors.begin(),
                            factor(FactorKind::PriorSE3, pose(11), {}, x[1], 1));
  const auto steps_p = buildModelSteps(with_prior);
  CHECK(steps_p[1].factors == std::vector<std::size_t>{0, 1, 2});
  CHECK(distance(VariableKind::SE3, initialValue(with_prior, steps_p[1], pose(11), cur), x[1]) ==
        0.0);
}

TEST_CASE("model steps: errors and their lines") {
  SUBCASE("a between factor from a pose to itself") {
    World2 w = makeWorld2();
    w.d.factors[4] = factor(FactorKind::BetweenSE2, pose(1), pose(1), Eigen::Vector3d::Zero(), 5);
    CHECK(errorLine(w.d) == 5);
  }
  SUBCASE("a negative id, a wrong role") {
    World2 w = makeWorld2();
    w.d.factors[7].second = pose(-3);
    CHECK(errorLine(w.d) == 8);
    w = makeWorld2();
    w.d.factors[8].second = pose(1);  // PointXY2 naming a pose as its landmark
    CHECK(errorLine(w.d) == 9);
  }
  SUBCASE("a pose without factor to an older pose nor prior") {
    World2 w = makeWorld2();
    w.d.factors[2] = factor(FactorKind::PointXY2, pose(2), lm(4), Eigen::Vector2d(1, 1), 3);
    // Pose 2 is then linked only to the later pose 3 (line 7) and observes landmarks.
    w.d.factors[6] = factor(FactorKind::BetweenSE2, pose(2), pose(3), Eigen::Vector3d::Zero(), 7);
    CHECK(errorLine(w.d) == 3);
    // With a prior it is a new component: fine, initialised from the prior.
    w.d.factors.push_back(factor(FactorKind::PriorSE2, pose(2), {}, Eigen::Vector3d(1, 2, 3), 11));
    const auto steps = buildModelSteps(w.d);
    checkInvariants(w.d, steps);
    CHECK(initialValue(w.d, steps[2], pose(2), {}) == Eigen::Vector3d(1, 2, 3));
  }
  SUBCASE("a pose vertex without factor") {
    World2 w = makeWorld2();
    ModelVertex v;
    v.key = pose(2);
    v.value = Eigen::Vector3d::Zero();
    v.line = 20;
    w.d.vertices = {v};
    w.d.factors.erase(w.d.factors.begin() + 2, w.d.factors.begin() + 4);  // lines 3, 4
    w.d.factors.erase(w.d.factors.begin() + 3, w.d.factors.begin() + 5);  // lines 6, 7
    CHECK(errorLine(w.d) == 20);
  }
  SUBCASE("a landmark prior on a landmark never observed") {
    World2 w = makeWorld2();
    w.d.factors.push_back(factor(FactorKind::PriorPoint2, lm(8), {}, Eigen::Vector2d(1, 1), 11));
    CHECK(errorLine(w.d) == 11);
    ModelVertex v;  // declared: enters in step 0
    v.key = lm(8);
    v.kind = VariableKind::Point2;
    v.value = Eigen::Vector2d::Zero();
    v.line = 12;
    w.d.vertices = {v};
    const auto steps = buildModelSteps(w.d);
    checkInvariants(w.d, steps);
    CHECK(steps[0].factors == std::vector<std::size_t>{1, 9, 10});
    CHECK(steps[0].new_landmarks == std::vector<VariableKey>{lm(1), lm(8)});
    CHECK(initialValue(w.d, steps[0], lm(8), {}) == Eigen::Vector2d(1, 1));
  }
  SUBCASE("a landmark vertex without factor") {
    World2 w = makeWorld2();
    ModelVertex v;
    v.key = lm(8);
    v.kind = VariableKind::Point2;
    v.value = Eigen::Vector2d::Zero();
    v.line = 13;
    w.d.vertices = {v};
    CHECK(errorLine(w.d) == 13);
  }
}

TEST_CASE("model steps: degenerate datasets") {
  CHECK(buildModelSteps(ModelDataset{}).empty());
  ModelDataset d;  // one pose vertex: one step without factors, at the vertex's value
  ModelVertex v;
  v.key = pose(4);
  v.value = Eigen::Vector3d(1, 2, 3);
  d.vertices = {v};
  auto steps = buildModelSteps(d);
  REQUIRE(steps.size() == 1);
  CHECK(steps[0].new_pose == pose(4));
  CHECK(steps[0].factors.empty());
  CHECK(initialValue(d, steps[0], pose(4), {}) == Eigen::Vector3d(1, 2, 3));
  // Only a declared landmark with a prior: one step without a pose.
  v.key = lm(2);
  v.kind = VariableKind::Point2;
  d.vertices = {v};
  d.factors = {factor(FactorKind::PriorPoint2, lm(2), {}, Eigen::Vector2d(5, 6), 2)};
  steps = buildModelSteps(d);
  REQUIRE(steps.size() == 1);
  CHECK(steps[0].new_pose.id == -1);
  CHECK(steps[0].new_landmarks == std::vector<VariableKey>{lm(2)});
  CHECK(steps[0].factors == std::vector<std::size_t>{0});
  CHECK(initialValue(d, steps[0], lm(2), {}) == Eigen::Vector2d(5, 6));
}

TEST_CASE("model steps: file order of a pose graph") {
  // World2's poses out of time order: 1 -> 2 first, pose 0 enters late through 0 -> 1.
  const World2 w = makeWorld2();
  const auto rel = [&](int i, int j) { return params2(mat2(w.x[i]).inverse() * mat2(w.x[j])); };
  ModelDataset d;
  d.name = "file-order";
  d.factors = {
      factor(FactorKind::BetweenSE2, pose(1), pose(2), rel(1, 2), 1),
      factor(FactorKind::BetweenSE2, pose(3), pose(2), rel(3, 2), 2),  // stored new -> known
      factor(FactorKind::BetweenSE2, pose(1), pose(3), rel(1, 3), 3),  // both known: this step
      factor(FactorKind::BetweenSE2, pose(0), pose(1), rel(0, 1), 4),  // an older id enters last
      factor(FactorKind::PriorSE2, pose(3), {}, w.x[3], 5),
  };
  ModelVertex v;
  v.key = pose(1);
  v.value = w.x[1];
  v.line = 9;
  d.vertices = {v};
  const auto steps = buildModelSteps(d, sim::StepOrder::File);
  REQUIRE(steps.size() == 4);
  CHECK(steps[0].new_pose == pose(1));
  CHECK(steps[0].factors.empty());
  CHECK(steps[1].new_pose == pose(2));
  CHECK(steps[1].factors == std::vector<std::size_t>{0});
  CHECK(steps[2].new_pose == pose(3));
  CHECK(steps[2].factors == std::vector<std::size_t>{1, 2});
  CHECK(steps[3].new_pose == pose(0));
  CHECK(steps[3].factors == std::vector<std::size_t>{3, 4});
  // Noise-free, from the first pose's vertex (the file's frame): the chain is the truth.
  const ModelEstimate est = chain(d, steps);
  for (int k = 0; k < 4; ++k) CHECK(distance(VariableKind::SE2, est.at(pose(k)), w.x[k]) < 1e-12);
  // The online order of the same file also starts from pose 0's value: it has no vertex, so the
  // origin, and pose 3's prior then fixes nothing of pose 0.
  const auto online = buildModelSteps(d);
  CHECK(initialValue(d, online[0], pose(0), {}) == Eigen::Vector3d::Zero());

  // Errors: two new poses (its line), a pose vertex no factor names (the vertex line).
  ModelDataset two = d;
  two.factors.push_back(factor(FactorKind::BetweenSE2, pose(7), pose(8), rel(0, 1), 6));
  try {
    (void)buildModelSteps(two, sim::StepOrder::File);
    FAIL("no DatasetError");
  } catch (const DatasetError& e) {
    CHECK(e.line() == 6);
    CHECK(std::string(e.what()).find("two new poses") != std::string::npos);
  }
  ModelDataset lonely = d;
  v.key = pose(9);
  v.line = 11;
  lonely.vertices.push_back(v);
  try {
    (void)buildModelSteps(lonely, sim::StepOrder::File);
    FAIL("no DatasetError");
  } catch (const DatasetError& e) {
    CHECK(e.line() == 11);
  }
}

TEST_CASE("model steps: file order with landmarks") {
  // World2 as a stream: a landmark enters in the step of its first observation (or prior) in file
  // order, from whichever known pose sees it; factors between known variables join the last step.
  const World2 w = makeWorld2();
  const auto steps = buildModelSteps(w.d, sim::StepOrder::File);
  REQUIRE(steps.size() == 4);
  for (int k = 0; k < 4; ++k) CHECK(steps[k].new_pose == pose(k));
  CHECK(steps[0].factors.empty());
  CHECK(steps[1].factors == std::vector<std::size_t>{0, 1});  // pose 0 sees landmark 1
  CHECK(steps[1].new_landmarks == std::vector<VariableKey>{lm(1)});
  CHECK(steps[2].factors == std::vector<std::size_t>{2, 3, 4, 5});
  CHECK(steps[2].new_landmarks == (std::vector<VariableKey>{lm(7), lm(4)}));
  CHECK(steps[3].factors == std::vector<std::size_t>{6, 7, 8, 9});
  CHECK(steps[3].new_landmarks.empty());
  // Noise-free, pose 0 at the origin (its prior comes last): the truth seen from pose 0.
  const ModelEstimate est = chain(w.d, steps);
  REQUIRE(est.size() == 7);
  const Eigen::Matrix3d from0 = mat2(w.x[0]).inverse();
  for (int k = 0; k < 4; ++k) {
    CHECK(distance(VariableKind::SE2, est.at(pose(k)), params2(from0 * mat2(w.x[k]))) < 1e-12);
  }
  for (const auto& [key, l] :
       {std::make_pair(lm(1), w.l1), std::make_pair(lm(4), w.l4), std::make_pair(lm(7), w.l7)}) {
    const Eigen::Vector2d seen = (from0 * Eigen::Vector3d(l.x(), l.y(), 1.0)).head<2>();
    CHECK(distance(VariableKind::Point2, est.at(key), seen) < 1e-12);
  }

  // A file that starts with an observation: step 0 is its pose, with it.
  ModelDataset seen_first = w.d;
  seen_first.factors.insert(seen_first.factors.begin(), w.d.factors[1]);  // pose 0 sees lm 1
  const auto from_observation = buildModelSteps(seen_first, sim::StepOrder::File);
  REQUIRE(from_observation.size() == 4);
  CHECK(from_observation[0].new_pose == pose(0));
  CHECK(from_observation[0].factors == std::vector<std::size_t>{0});
  CHECK(from_observation[0].new_landmarks == std::vector<VariableKey>{lm(1)});
  CHECK(from_observation[1].factors == std::vector<std::size_t>{1, 2});
  CHECK(from_observation[1].new_landmarks.empty());
  // A landmark prior before any pose: step 0 holds it, and the first pose takes that step.
  ModelDataset prior_first = w.d;
  prior_first.factors.insert(prior_first.factors.begin(), w.d.factors[5]);  // lm 7's prior
  const auto from_prior = buildModelSteps(prior_first, sim::StepOrder::File);
  REQUIRE(from_prior.size() == 4);
  CHECK(from_prior[0].new_pose == pose(0));
  CHECK(from_prior[0].factors == std::vector<std::size_t>{0});
  CHECK(from_prior[0].new_landmarks == std::vector<VariableKey>{lm(7)});
  CHECK(from_prior[2].new_landmarks == std::vector<VariableKey>{lm(4)});  // lm 7 is known
  // A declared landmark with only a prior, and a pose vertex: one step, that pose's.
  ModelVertex v;
  v.key = lm(9);
  v.kind = VariableKind::Point2;
  v.value = w.l1;
  v.line = 12;
  ModelVertex p0;
  p0.key = pose(0);
  p0.kind = VariableKind::SE2;
  p0.value = w.x[0];
  p0.line = 13;
  ModelDataset declared;
  declared.factors = {factor(FactorKind::PriorPoint2, lm(9), {}, w.l1, 1)};
  declared.vertices = {v, p0};
  const auto only_prior = buildModelSteps(declared, sim::StepOrder::File);
  REQUIRE(only_prior.size() == 1);
  CHECK(only_prior[0].new_pose == pose(0));
  CHECK(only_prior[0].new_landmarks == std::vector<VariableKey>{lm(9)});

  // Errors at their lines: an observation from a pose no earlier factor introduced, a landmark
  // vertex no factor names, a prior on a landmark nothing observes and no vertex declares (as in
  // online order).
  ModelDataset unseen = w.d;
  unseen.factors.push_back(factor(FactorKind::PointXY2, pose(8), lm(1), w.l1, 11));
  ModelDataset lonely = w.d;
  lonely.vertices.push_back(v);
  ModelDataset stray_prior = w.d;
  stray_prior.factors.push_back(factor(FactorKind::PriorPoint2, lm(5), {}, w.l1, 14));
  CHECK(errorLine(stray_prior) == 14);
  for (const auto& [d, line] : {std::make_pair(&unseen, 11), std::make_pair(&lonely, 12),
                                std::make_pair(&stray_prior, 14)}) {
    try {
      (void)buildModelSteps(*d, sim::StepOrder::File);
      FAIL("no DatasetError");
    } catch (const DatasetError& e) {
      CHECK(e.line() == static_cast<std::size_t>(line));
    }
  }
}

TEST_CASE("model steps: real files") {
  struct Case {
    const char* file;
    std::size_t poses;
    std::size_t landmarks;
  };
  const Case cases[] = {{"2d/victoriaPark.txt", 6969, 151},
                        {"3d/torus2000Points.txt", 1073, 20},
                        {"3d/sphere2500.g2o", 2500, 0},
                        {"3d/parking-garage.g2o", 0, 0}};  // poses: its pose vertices
  for (const Case& c : cases) {
    const std::string path = datasetPath(c.file);
    if (!present(path)) continue;
    CAPTURE(path);
    const ModelDataset d = sim::readModelDataset(path);
    const auto steps = buildModelSteps(d);
    checkInvariants(d, steps);
    std::size_t poses = c.poses;
    if (poses == 0) {
      for (const ModelVertex& v : d.vertices) poses += v.key.role == VariableRole::Pose ? 1 : 0;
    }
    CHECK(steps.size() == poses);
    std::size_t landmarks = 0;
    for (const ModelStep& s : steps) landmarks += s.new_landmarks.size();
    CHECK(landmarks == c.landmarks);

    // The chained online initial values: finite everywhere; on the edge-only files (victoriaPark,
    // torus2000Points: no vertices, file order = online order) initialEstimate.
    const ModelEstimate est = chain(d, steps);
    CHECK(est.size() == poses + landmarks);
    bool finite = true;
    for (const auto& kv : est) finite = finite && kv.second.allFinite();
    CHECK(finite);
    MESSAGE(std::string(c.file) << ": " << steps.size() << " steps, " << landmarks << " landmarks, "
                                << d.factors.size() << " factors");
    if (d.vertices.empty()) {
      const ModelEstimate ref = sim::initialEstimate(d);
      const auto kinds = sim::variableKinds(d);
      REQUIRE(ref.size() == est.size());
      double worst = 0.0;
      for (const auto& kv : ref) {
        worst = std::max(worst, distance(kinds.at(kv.first), est.at(kv.first), kv.second));
      }
      MESSAGE(std::string(c.file) << ": online initial values vs initialEstimate, max difference "
                                  << worst);
      CHECK(worst < 1e-9);
    }
  }
}
