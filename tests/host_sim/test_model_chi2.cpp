// Tests of the model objective (host_sim/model_chi2.h): every error against a hand computation
// with homogeneous matrices written here, the qw >= 0 sign rule, the iSAM vs g2o conventions, the
// 2D chi2 against chi2G2o, and the initial estimate.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>

#include "host_sim/chi2.h"
#include "host_sim/model_chi2.h"

using lslam::sim::chi2G2o;
using lslam::sim::Dataset2D;
using lslam::sim::Edge2D;
using lslam::sim::Estimate2D;
using lslam::sim::FactorKind;
using lslam::sim::ModelDataset;
using lslam::sim::ModelEstimate;
using lslam::sim::ModelFactor;
using lslam::sim::ModelVertex;
using lslam::sim::ObjectiveConvention;
using lslam::sim::Pose2D;
using lslam::sim::VariableKey;
using lslam::sim::VariableKind;
using lslam::sim::VariableRole;
using lslam::sim::Vector6d;
using lslam::sim::Vector7d;
namespace sim = lslam::sim;

namespace {

constexpr double kPi = 3.14159265358979323846;

double wrap(double a) {
  return std::remainder(a, 2.0 * kPi);
}

Eigen::Matrix3d h2(const Eigen::Vector3d& x) {
  Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
  t(0, 0) = std::cos(x[2]);
  t(0, 1) = -std::sin(x[2]);
  t(1, 0) = std::sin(x[2]);
  t(1, 1) = std::cos(x[2]);
  t(0, 2) = x[0];
  t(1, 2) = x[1];
  return t;
}

Eigen::Vector3d v2(const Eigen::Matrix3d& t) {
  return Eigen::Vector3d(t(0, 2), t(1, 2), std::atan2(t(1, 0), t(0, 0)));
}

// Rotation matrix from a unit quaternion written out (not Eigen's conversion).
Eigen::Matrix3d rotFromQuat(double w, double x, double y, double z) {
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  w /= n;
  x /= n;
  y /= n;
  z /= n;
  Eigen::Matrix3d r;
  r << 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),  //
      2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),   //
      2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y);
  return r;
}

Eigen::Matrix4d h3(const Vector7d& p) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = rotFromQuat(p[6], p[3], p[4], p[5]);
  t.topRightCorner<3, 1>() = p.head<3>();
  return t;
}

// (t, qvec) with qw >= 0 of a homogeneous matrix: the quaternion by Shepperd's method written out.
Vector6d g2oVec(const Eigen::Matrix4d& t) {
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  double w = 0.0;
  double x = 0.0;
  double y = 0.0;
  double z = 0.0;
  const double tr = r.trace();
  if (tr > 0.0) {
    const double s = 2.0 * std::sqrt(1.0 + tr);
    w = 0.25 * s;
    x = (r(2, 1) - r(1, 2)) / s;
    y = (r(0, 2) - r(2, 0)) / s;
    z = (r(1, 0) - r(0, 1)) / s;
  } else if (r(0, 0) > r(1, 1) && r(0, 0) > r(2, 2)) {
    const double s = 2.0 * std::sqrt(1.0 + r(0, 0) - r(1, 1) - r(2, 2));
    w = (r(2, 1) - r(1, 2)) / s;
    x = 0.25 * s;
    y = (r(0, 1) + r(1, 0)) / s;
    z = (r(0, 2) + r(2, 0)) / s;
  } else if (r(1, 1) > r(2, 2)) {
    const double s = 2.0 * std::sqrt(1.0 + r(1, 1) - r(0, 0) - r(2, 2));
    w = (r(0, 2) - r(2, 0)) / s;
    x = (r(0, 1) + r(1, 0)) / s;
    y = 0.25 * s;
    z = (r(1, 2) + r(2, 1)) / s;
  } else {
    const double s = 2.0 * std::sqrt(1.0 + r(2, 2) - r(0, 0) - r(1, 1));
    w = (r(1, 0) - r(0, 1)) / s;
    x = (r(0, 2) + r(2, 0)) / s;
    y = (r(1, 2) + r(2, 1)) / s;
    z = 0.25 * s;
  }
  const double sign = w < 0.0 ? -1.0 : 1.0;
  Vector6d e;
  e << t(0, 3), t(1, 3), t(2, 3), sign * x, sign * y, sign * z;
  return e;
}

// (x, y, z, yaw, pitch, roll) from the rotation matrix (iSAM's Rot3d(wRo) formulas, a different
// route from the quaternion formulas of the code under test).
Vector6d isamVec(const Eigen::Matrix4d& t) {
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  const double yaw = std::atan2(r(1, 0), r(0, 0));
  const double c = std::cos(yaw);
  const double s = std::sin(yaw);
  const double pitch = std::atan2(-r(2, 0), r(0, 0) * c + r(1, 0) * s);
  const double roll = std::atan2(r(0, 2) * s - r(1, 2) * c, -r(0, 1) * s + r(1, 1) * c);
  Vector6d v;
  v << t(0, 3), t(1, 3), t(2, 3), yaw, pitch, roll;
  return v;
}

Vector7d randomSE3(std::mt19937& rng, double extent) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Vector4d q(u(rng), u(rng), u(rng), u(rng));
  q.normalize();
  Vector7d p;
  p << extent * u(rng), extent * u(rng), extent * u(rng), q[0], q[1], q[2], q[3];
  return p;
}

Eigen::Vector3d randomSE2(std::mt19937& rng, double extent) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return Eigen::Vector3d(extent * u(rng), extent * u(rng), kPi * u(rng));
}

Vector7d identity7() {
  Vector7d p = Vector7d::Zero();
  p[6] = 1.0;
  return p;
}

ModelFactor factor(FactorKind kind, VariableKey a, VariableKey b, Eigen::VectorXd z,
                   Eigen::MatrixXd info) {
  ModelFactor f;
  f.kind = kind;
  f.first = a;
  f.second = b;
  f.measurement = std::move(z);
  f.information = std::move(info);
  return f;
}

VariableKey pose(std::int64_t id) {
  return VariableKey{VariableRole::Pose, id};
}
VariableKey landmark(std::int64_t id) {
  return VariableKey{VariableRole::Landmark, id};
}

}  // namespace

TEST_CASE("2D errors: homogeneous-matrix hand computations, both conventions") {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d xi = randomSE2(rng, 5.0);
    const Eigen::Vector3d xj = randomSE2(rng, 5.0);
    const Eigen::Vector3d z = randomSE2(rng, 2.0);
    // g2o: (x, y, theta) of Z^-1 Xi^-1 Xj.
    const Eigen::Vector3d g = v2(h2(z).inverse() * h2(xi).inverse() * h2(xj));
    const Eigen::Vector3d eg = sim::errorBetweenSE2G2o(xi, xj, z);
    CHECK((eg.head<2>() - g.head<2>()).norm() < 1e-12);
    CHECK(std::abs(wrap(eg[2] - g[2])) < 1e-12);
    CHECK(std::abs(eg[2]) <= kPi);
    // g2o prior: Xi = identity.
    const Eigen::Vector3d gp = v2(h2(z).inverse() * h2(xj));
    const Eigen::Vector3d ep = sim::errorPriorSE2G2o(xj, z);
    CHECK((ep.head<2>() - gp.head<2>()).norm() < 1e-12);
    CHECK(std::abs(wrap(ep[2] - gp[2])) < 1e-12);
    // iSAM: (x, y, theta) of Xi^-1 Xj minus z.
    const Eigen::Vector3d rel = v2(h2(xi).inverse() * h2(xj));
    const Eigen::Vector3d ei = sim::errorBetweenSE2Isam(xi, xj, z);
    CHECK((ei.head<2>() - (rel.head<2>() - z.head<2>())).norm() < 1e-12);
    CHECK(std::abs(wrap(ei[2] - (rel[2] - z[2]))) < 1e-12);
    CHECK(std::abs(ei[2]) <= kPi);
    // The conventions differ by the rotation of z on the translation part, agree on the angle.
    CHECK((eg.head<2>() - h2(z).topLeftCorner<2, 2>().transpose() * ei.head<2>()).norm() < 1e-12);
    CHECK(std::abs(wrap(eg[2] - ei[2])) < 1e-12);
    const Eigen::Vector3d pi = sim::errorPriorSE2Isam(xj, z);
    CHECK((pi.head<2>() - (xj.head<2>() - z.head<2>())).norm() < 1e-15);
    CHECK(std::abs(wrap(pi[2] - (xj[2] - z[2]))) < 1e-12);

    // Landmarks: d = R^T (l - t) via the homogeneous inverse.
    const Eigen::Vector2d l(3.0 * std::cos(trial), 2.0 * std::sin(0.7 * trial));
    const Eigen::Vector2d zl(0.3, -0.2);
    const Eigen::Vector3d d = h2(xi).inverse() * Eigen::Vector3d(l.x(), l.y(), 1.0);
    CHECK((sim::errorPointXY2(xi, l, zl) - (d.head<2>() - zl)).norm() < 1e-12);
    const Eigen::Vector2d rb(1.5, 0.4);
    const Eigen::Vector2d erb = sim::errorRangeBearing2(xi, l, rb);
    CHECK(erb[0] == doctest::Approx(d.head<2>().norm() - 1.5).epsilon(1e-12));
    CHECK(std::abs(wrap(erb[1] - (std::atan2(d.y(), d.x()) - 0.4))) < 1e-12);
  }
  // Wrapping: an angle difference of 350 degrees is -10 degrees in both conventions.
  const Eigen::Vector3d a(0.0, 0.0, kPi * 170.0 / 180.0);
  const Eigen::Vector3d b(0.0, 0.0, -kPi * 170.0 / 180.0);
  const Eigen::Vector3d zero = Eigen::Vector3d::Zero();
  CHECK(sim::errorBetweenSE2G2o(a, b, zero)[2] == doctest::Approx(kPi * 20.0 / 180.0));
  CHECK(sim::errorBetweenSE2Isam(a, b, zero)[2] == doctest::Approx(kPi * 20.0 / 180.0));
  CHECK(sim::errorRangeBearing2(zero, Eigen::Vector2d(-1.0, -1e-9), Eigen::Vector2d(1.0, kPi))[1] ==
        doctest::Approx(-1e-9).epsilon(1e-6));
}

TEST_CASE("3D errors: homogeneous-matrix hand computations, both conventions") {
  std::mt19937 rng(12);
  for (int trial = 0; trial < 200; ++trial) {
    const Vector7d xi = randomSE3(rng, 5.0);
    const Vector7d xj = randomSE3(rng, 5.0);
    const Vector7d z = randomSE3(rng, 2.0);
    const Eigen::Matrix4d rel = h3(xi).inverse() * h3(xj);
    // g2o: (t, qvec with qw >= 0) of Z^-1 Xi^-1 Xj.
    CHECK((sim::errorBetweenSE3G2o(xi, xj, z) - g2oVec(h3(z).inverse() * rel)).norm() < 1e-12);
    CHECK((sim::errorPriorSE3G2o(xj, z) - g2oVec(h3(z).inverse() * h3(xj))).norm() < 1e-12);
    // iSAM: v(Xi^-1 Xj) - v(Z), angles wrapped.
    Vector6d want = isamVec(rel) - isamVec(h3(z));
    const Vector6d got = sim::errorBetweenSE3Isam(xi, xj, z);
    CHECK((got.head<3>() - want.head<3>()).norm() < 1e-12);
    for (int k = 3; k < 6; ++k) {
      CHECK(std::abs(wrap(got[k] - want[k])) < 1e-9);
      CHECK(std::abs(got[k]) <= kPi);
    }
    want = isamVec(h3(xj)) - isamVec(h3(z));
    const Vector6d gotp = sim::errorPriorSE3Isam(xj, z);
    CHECK((gotp.head<3>() - want.head<3>()).norm() < 1e-12);
    for (int k = 3; k < 6; ++k) CHECK(std::abs(wrap(gotp[k] - want[k])) < 1e-9);
    // The conventions differ: translation in Z's frame (g2o) vs minus z (iSAM).
    const Vector6d g = sim::errorBetweenSE3G2o(xi, xj, z);
    CHECK((g.head<3>() -
           h3(z).topLeftCorner<3, 3>().transpose() * (rel.topRightCorner<3, 1>() - z.head<3>()))
              .norm() < 1e-12);
    CHECK((g.head<3>() - got.head<3>()).norm() > 1e-6);

    // Point observation: R^T (l - t) - z via the homogeneous inverse.
    const Eigen::Vector3d l(1.0 + trial * 0.01, -2.0, 0.5);
    const Eigen::Vector3d zl(0.1, 0.2, -0.3);
    const Eigen::Vector4d d = h3(xi).inverse() * Eigen::Vector4d(l.x(), l.y(), l.z(), 1.0);
    CHECK((sim::errorPointXYZ3(xi, l, zl) - (d.head<3>() - zl)).norm() < 1e-12);
  }
}

TEST_CASE("3D g2o error: the quaternion is taken with qw >= 0, and q and -q are one rotation") {
  // Xj: 200 degrees about z, stored with qw = cos(100 deg) < 0. Z^-1 Xi^-1 Xj is that rotation;
  // with qw >= 0 it reads as -160 degrees about z: qvec = (0, 0, -sin(100 deg)).
  const double half = kPi * 100.0 / 180.0;
  Vector7d xj;
  xj << 1.0, 2.0, 3.0, 0.0, 0.0, std::sin(half), std::cos(half);
  REQUIRE(xj[6] < 0.0);
  const Vector6d e = sim::errorBetweenSE3G2o(identity7(), xj, identity7());
  CHECK(e.head<3>().isApprox(Eigen::Vector3d(1.0, 2.0, 3.0)));
  CHECK(e[3] == doctest::Approx(0.0));
  CHECK(e[4] == doctest::Approx(0.0));
  CHECK(e[5] == doctest::Approx(-std::sin(half)));
  CHECK(sim::errorPriorSE3G2o(xj, identity7())[5] == doctest::Approx(-std::sin(half)));
  // Negating every quaternion changes nothing.
  std::mt19937 rng(5);
  for (int trial = 0; trial < 50; ++trial) {
    Vector7d a = randomSE3(rng, 3.0);
    Vector7d b = randomSE3(rng, 3.0);
    Vector7d z = randomSE3(rng, 1.0);
    const Vector6d e1 = sim::errorBetweenSE3G2o(a, b, z);
    const Vector6d i1 = sim::errorBetweenSE3Isam(a, b, z);
    a.tail<4>() *= -1.0;
    b.tail<4>() *= -1.0;
    z.tail<4>() *= -1.0;
    CHECK((sim::errorBetweenSE3G2o(a, b, z) - e1).norm() < 1e-12);
    CHECK((sim::errorBetweenSE3Isam(a, b, z) - i1).norm() < 1e-12);
  }
}

TEST_CASE("isamYawPitchRoll inverts R = Rz(yaw) Ry(pitch) Rx(roll)") {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 100; ++trial) {
    const double yaw = kPi * u(rng);
    const double pitch = 0.49 * kPi * u(rng);
    const double roll = kPi * u(rng);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()));
    const Eigen::Vector3d ypr = sim::isamYawPitchRoll(q);
    CHECK(std::abs(wrap(ypr[0] - yaw)) < 1e-9);
    CHECK(ypr[1] == doctest::Approx(pitch).epsilon(1e-9));
    CHECK(std::abs(wrap(ypr[2] - roll)) < 1e-9);
  }
}

TEST_CASE("chi2 in each convention, and chi2 of a 2D pose dataset equals chi2G2o") {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Dataset2D d2;
  Estimate2D est2;
  ModelDataset md;
  md.dimension = 2;
  ModelEstimate mest;
  for (std::int64_t id = 0; id < 12; ++id) {
    const Eigen::Vector3d p = randomSE2(rng, 10.0);
    est2[id] = Pose2D{p[0], p[1], p[2]};
    mest[pose(id)] = p;
  }
  for (int k = 0; k < 30; ++k) {
    Edge2D e;
    e.from = k % 12;
    e.to = (k * 5 + 1) % 12;
    if (e.to == e.from) e.to = (e.from + 1) % 12;
    e.measurement = Pose2D{u(rng), u(rng), 3.0 * u(rng)};
    Eigen::Matrix3d b = Eigen::Matrix3d::Random();
    e.information = b * b.transpose() + Eigen::Matrix3d::Identity();
    e.line = static_cast<std::size_t>(k + 1);
    d2.edges.push_back(e);
    md.factors.push_back(factor(
        FactorKind::BetweenSE2, pose(e.from), pose(e.to),
        Eigen::Vector3d(e.measurement.x, e.measurement.y, e.measurement.theta), e.information));
  }
  const double want = chi2G2o(d2, est2);
  CHECK(sim::chi2(md, mest) == doctest::Approx(want).epsilon(1e-12));
  // Under the iSAM convention the same data give another number.
  md.convention = ObjectiveConvention::Isam;
  CHECK(sim::chi2(md, mest) != doctest::Approx(want).epsilon(1e-3));
  // Hand sum of e^T Omega e for a mixed 3D dataset.
  ModelDataset m3;
  m3.dimension = 3;
  ModelEstimate v3;
  v3[pose(1)] = randomSE3(rng, 3.0);
  v3[pose(2)] = randomSE3(rng, 3.0);
  v3[landmark(1)] = Eigen::Vector3d(1.0, 2.0, 3.0);
  const Vector7d z = randomSE3(rng, 1.0);
  Eigen::MatrixXd info6 = Eigen::MatrixXd::Identity(6, 6) * 2.0;
  info6(0, 1) = info6(1, 0) = 0.5;
  m3.factors.push_back(factor(FactorKind::BetweenSE3, pose(1), pose(2), z, info6));
  m3.factors.push_back(factor(FactorKind::PointXYZ3, pose(2), landmark(1),
                              Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Matrix3d::Identity() * 4.0));
  m3.factors.push_back(factor(FactorKind::PriorPoint3, landmark(1), VariableKey{},
                              Eigen::Vector3d(1.1, 2.0, 3.0), Eigen::Matrix3d::Identity()));
  m3.factors.push_back(factor(FactorKind::PriorSE3, pose(1), VariableKey{}, identity7(), info6));
  for (const ObjectiveConvention c : {ObjectiveConvention::G2o, ObjectiveConvention::Isam}) {
    m3.convention = c;
    const bool isam = c == ObjectiveConvention::Isam;
    const Vector7d x1 = v3.at(pose(1));
    const Vector7d x2 = v3.at(pose(2));
    const Vector6d e1 =
        isam ? sim::errorBetweenSE3Isam(x1, x2, z) : sim::errorBetweenSE3G2o(x1, x2, z);
    const Eigen::Vector3d e2 =
        sim::errorPointXYZ3(x2, Eigen::Vector3d(1.0, 2.0, 3.0), Eigen::Vector3d(0.1, 0.2, 0.3));
    const Vector6d e4 =
        isam ? sim::errorPriorSE3Isam(x1, identity7()) : sim::errorPriorSE3G2o(x1, identity7());
    const double hand = e1.dot(info6 * e1) + 4.0 * e2.squaredNorm() + 0.01 + e4.dot(info6 * e4);
    CHECK(sim::chi2(m3, v3) == doctest::Approx(hand).epsilon(1e-12));
  }
  // A missing value is an error.
  v3.erase(landmark(1));
  CHECK_THROWS_AS(sim::chi2(m3, v3), std::invalid_argument);
}

TEST_CASE("initialEstimate: vertices, then each variable from the first factor reaching it") {
  // 2D with landmarks, no vertices (iSAM-like): pose 0 at the origin, odometry composed, a
  // landmark from its observation, a reversed between initialising its first pose.
  ModelDataset d;
  d.convention = ObjectiveConvention::Isam;
  const Eigen::Matrix3d i3 = Eigen::Matrix3d::Identity();
  const Eigen::Matrix2d i2 = Eigen::Matrix2d::Identity();
  d.factors.push_back(
      factor(FactorKind::BetweenSE2, pose(0), pose(1), Eigen::Vector3d(1.0, 0.0, kPi / 2), i3));
  d.factors.push_back(
      factor(FactorKind::PointXY2, pose(1), landmark(0), Eigen::Vector2d(2.0, 0.0), i2));
  d.factors.push_back(
      factor(FactorKind::BetweenSE2, pose(5), pose(1), Eigen::Vector3d(0.0, 1.0, 0.0), i3));
  d.factors.push_back(  // later factor reaching landmark 0 again: not used for its value
      factor(FactorKind::PointXY2, pose(0), landmark(0), Eigen::Vector2d(9.0, 9.0), i2));
  d.factors.push_back(
      factor(FactorKind::RangeBearing2, pose(1), landmark(3), Eigen::Vector2d(2.0, kPi / 2), i2));
  ModelEstimate est = sim::initialEstimate(d);
  REQUIRE(est.size() == 5);
  CHECK(est.at(pose(0)).isApprox(Eigen::Vector3d(0.0, 0.0, 0.0)));
  CHECK(est.at(pose(1)).isApprox(Eigen::Vector3d(1.0, 0.0, kPi / 2)));
  CHECK(est.at(landmark(0)).isApprox(Eigen::Vector2d(1.0, 2.0)));
  // X5 = X1 Z^-1: Z^-1 = (-1, 0, 0) in 5's frame... X5 Z = X1.
  const Eigen::Matrix3d x5 = h2(est.at(pose(1))) * h2(Eigen::Vector3d(0.0, 1.0, 0.0)).inverse();
  CHECK((est.at(pose(5)) - v2(x5)).norm() < 1e-12);
  CHECK(est.at(landmark(3)).isApprox(Eigen::Vector2d(-1.0, 0.0)));
  // Every factor's measurement is matched exactly by the first factor's initial values.
  CHECK(sim::factorError(d.convention, d.factors[0], est).norm() < 1e-12);
  CHECK(sim::factorError(d.convention, d.factors[2], est).norm() < 1e-12);

  // 3D with a vertex file leaving pose 2 and landmark 7 out; vertex values are kept as given.
  ModelDataset d3;
  d3.dimension = 3;
  ModelVertex v0;
  v0.key = pose(0);
  v0.kind = VariableKind::SE3;
  Vector7d p0;
  p0 << 1.0, 2.0, 3.0, 0.0, 0.0, std::sin(0.3), std::cos(0.3);
  v0.value = p0;
  ModelVertex v1 = v0;
  v1.key = pose(1);
  v1.value = identity7();
  d3.vertices = {v0, v1};
  Vector7d z;
  z << 1.0, 0.0, 0.0, std::sin(0.2), 0.0, 0.0, std::cos(0.2);
  const Eigen::MatrixXd i6 = Eigen::MatrixXd::Identity(6, 6);
  d3.factors.push_back(factor(FactorKind::BetweenSE3, pose(0), pose(1), z, i6));
  d3.factors.push_back(factor(FactorKind::BetweenSE3, pose(0), pose(2), z, i6));
  d3.factors.push_back(factor(FactorKind::PointXYZ3, pose(2), landmark(7),
                              Eigen::Vector3d(0.0, 1.0, 0.0), Eigen::Matrix3d::Identity()));
  est = sim::initialEstimate(d3);
  REQUIRE(est.size() == 4);
  CHECK(est.at(pose(1)) == identity7());
  const Eigen::Matrix4d x2 = h3(p0) * h3(z);
  CHECK((h3(est.at(pose(2))) - x2).norm() < 1e-12);
  const Eigen::Vector4d l = x2 * Eigen::Vector4d(0.0, 1.0, 0.0, 1.0);
  CHECK((est.at(landmark(7)) - l.head<3>()).norm() < 1e-12);
  for (const ObjectiveConvention c : {ObjectiveConvention::G2o, ObjectiveConvention::Isam}) {
    CHECK(sim::factorError(c, d3.factors[1], est).norm() < 1e-12);
    CHECK(sim::factorError(c, d3.factors[2], est).norm() < 1e-12);
  }

  // One key used as two kinds is an error.
  d3.factors.push_back(factor(FactorKind::PriorPoint3, pose(1), VariableKey{},
                              Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity()));
  CHECK_THROWS_AS(sim::initialEstimate(d3), std::invalid_argument);
}
