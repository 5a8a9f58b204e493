// Tests of the g2o chi2 (host_sim/chi2.h) against independent computations with 3x3 homogeneous
// matrices.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <stdexcept>

#include "host_sim/chi2.h"
#include "pose2d_matrices.h"

using lslam::sim::chi2G2o;
using lslam::sim::Dataset2D;
using lslam::sim::Edge2D;
using lslam::sim::edgeErrorG2o;
using lslam::sim::Estimate2D;
using lslam::sim::Pose2D;
using lslam::sim::wrapAngle;

using lslam::test::fromHomogeneous;
using lslam::test::homogeneous;

namespace {

constexpr double kPi = 3.14159265358979323846;

// e = (x, y, theta) of Z^-1 Xi^-1 Xj, computed with matrix inverses and atan2.
Eigen::Vector3d handError(const Pose2D& xi, const Pose2D& xj, const Pose2D& z) {
  const Eigen::Matrix3d e = homogeneous(z).inverse() * homogeneous(xi).inverse() * homogeneous(xj);
  return Eigen::Vector3d(e(0, 2), e(1, 2), std::atan2(e(1, 0), e(0, 0)));
}

Eigen::Matrix3d randomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3d b;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) b(r, c) = 5.0 * u(rng);
  }
  return b * b.transpose() +
         Eigen::Vector3d(1.0 + std::abs(u(rng)), 1.0, 2.0).asDiagonal().toDenseMatrix();
}

Pose2D randomPose(std::mt19937& rng, double extent) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  return Pose2D{extent * u(rng), extent * u(rng), kPi * u(rng)};
}

}  // namespace

TEST_CASE("wrapAngle maps to (-pi, pi] and only removes multiples of 2 pi") {
  CHECK(wrapAngle(kPi) == kPi);
  CHECK(wrapAngle(-kPi) == kPi);
  CHECK(wrapAngle(0.0) == 0.0);
  CHECK(wrapAngle(0.5) == doctest::Approx(0.5));
  CHECK(wrapAngle(2.0 * kPi + 0.25) == doctest::Approx(0.25));
  CHECK(wrapAngle(-2.0 * kPi - 0.25) == doctest::Approx(-0.25));
  CHECK(wrapAngle(kPi + 0.1) == doctest::Approx(-kPi + 0.1));
  CHECK(wrapAngle(-kPi - 0.1) == doctest::Approx(kPi - 0.1));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-100.0, 100.0);
  for (int k = 0; k < 2000; ++k) {
    const double a = u(rng);
    const double w = wrapAngle(a);
    CHECK(w > -kPi);
    CHECK(w <= kPi);
    const double turns = (a - w) / (2.0 * kPi);
    CHECK(turns == doctest::Approx(std::round(turns)).epsilon(1e-12));
  }
}

TEST_CASE("edgeErrorG2o: hand-computed values") {
  // Xi^-1 Xj = (1, 0, 0) when xj is one metre ahead of xi along xi's heading (+y).
  const Eigen::Vector3d e1 =
      edgeErrorG2o({1.0, 2.0, kPi / 2}, {1.0, 3.0, kPi / 2}, {0.0, 0.0, 0.0});
  CHECK(e1.x() == doctest::Approx(1.0));
  CHECK(std::abs(e1.y()) < 1e-15);
  CHECK(e1.z() == doctest::Approx(0.0));
  // Z^-1 Xj with Z = (1, 0, 0), Xj = (1, 0, pi/2): (0, 0, pi/2).
  const Eigen::Vector3d e2 = edgeErrorG2o({0.0, 0.0, 0.0}, {1.0, 0.0, kPi / 2}, {1.0, 0.0, 0.0});
  CHECK(std::abs(e2.x()) < 1e-15);
  CHECK(std::abs(e2.y()) < 1e-15);
  CHECK(e2.z() == doctest::Approx(kPi / 2));
  // Translation residual expressed in the measurement frame: Z = (0, 0, pi/2), Xj = (1, 0, pi/2).
  const Eigen::Vector3d e3 =
      edgeErrorG2o({0.0, 0.0, 0.0}, {1.0, 0.0, kPi / 2}, {0.0, 0.0, kPi / 2});
  CHECK(std::abs(e3.x()) < 1e-15);
  CHECK(e3.y() == doctest::Approx(-1.0));
  CHECK(e3.z() == doctest::Approx(0.0));

  Dataset2D d;
  Edge2D edge;
  edge.from = 0;
  edge.to = 1;
  edge.measurement = {1.0, 0.0, 0.0};
  edge.information = Eigen::Vector3d(1.0, 2.0, 3.0).asDiagonal();
  d.edges.push_back(edge);
  Estimate2D est{{0, {0.0, 0.0, 0.0}}, {1, {1.0, 0.0, kPi / 2}}};
  CHECK(chi2G2o(d, est) == doctest::Approx(3.0 * (kPi / 2) * (kPi / 2)));
}

TEST_CASE("edgeErrorG2o wraps the angle") {
  // thj - thi - thz = -6.2: wrapped to 2 pi - 6.2.
  const Eigen::Vector3d e = edgeErrorG2o({0.0, 0.0, 3.1}, {0.0, 0.0, -3.1}, {0.0, 0.0, 0.0});
  CHECK(e.z() == doctest::Approx(2.0 * kPi - 6.2));
  // A measurement of almost pi against a relative rotation of almost -pi: small error.
  const Eigen::Vector3d f =
      edgeErrorG2o({0.0, 0.0, 0.0}, {0.0, 0.0, -kPi + 0.01}, {0.0, 0.0, kPi - 0.01});
  CHECK(f.z() == doctest::Approx(0.02));
  // Exactly pi stays +pi.
  const Eigen::Vector3d g = edgeErrorG2o({0.0, 0.0, 0.0}, {0.0, 0.0, kPi}, {0.0, 0.0, 0.0});
  CHECK(g.z() == kPi);
  // The error angle is in (-pi, pi] for any inputs, even unwrapped ones.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-50.0, 50.0);
  for (int k = 0; k < 500; ++k) {
    const Eigen::Vector3d r =
        edgeErrorG2o({0.0, 0.0, u(rng)}, {1.0, 1.0, u(rng)}, {0.5, 0.0, u(rng)});
    CHECK(r.z() > -kPi);
    CHECK(r.z() <= kPi);
  }
}

TEST_CASE("chi2G2o matches a hand computation with homogeneous matrices") {
  std::mt19937 rng(12345);
  for (int trial = 0; trial < 50; ++trial) {
    Dataset2D d;
    Estimate2D est;
    const int n = 2 + trial % 9;
    for (int i = 0; i < n; ++i) est[100 + 3 * i] = randomPose(rng, 20.0);
    double expected = 0.0;
    std::uniform_int_distribution<int> pick(0, n - 1);
    for (int k = 0; k < 3 * n; ++k) {
      Edge2D e;
      e.from = 100 + 3 * pick(rng);
      e.to = 100 + 3 * pick(rng);
      if (e.from == e.to) continue;
      e.measurement = randomPose(rng, 3.0);
      e.information = randomInformation(rng);
      d.edges.push_back(e);
      const Eigen::Vector3d r = handError(est.at(e.from), est.at(e.to), e.measurement);
      const Eigen::Vector3d mine = edgeErrorG2o(est.at(e.from), est.at(e.to), e.measurement);
      CHECK((r - mine).norm() < 1e-9 * (1.0 + r.norm()));
      expected += r.transpose() * e.information * r;
    }
    CHECK(chi2G2o(d, est) == doctest::Approx(expected).epsilon(1e-10));
  }
}

TEST_CASE("chi2G2o of an exact graph is zero") {
  std::mt19937 rng(99);
  Dataset2D d;
  Estimate2D est;
  const int n = 30;
  for (int i = 0; i < n; ++i) est[i] = randomPose(rng, 50.0);
  std::uniform_int_distribution<int> pick(0, n - 1);
  for (int k = 0; k < 100; ++k) {
    Edge2D e;
    e.from = pick(rng);
    e.to = pick(rng);
    e.measurement =
        fromHomogeneous(homogeneous(est.at(e.from)).inverse() * homogeneous(est.at(e.to)));
    e.information = randomInformation(rng);
    d.edges.push_back(e);
  }
  CHECK(chi2G2o(d, est) < 1e-18);
  // Move one pose: chi2 becomes positive.
  est[5].x += 0.1;
  CHECK(chi2G2o(d, est) > 1e-6);
}

TEST_CASE("chi2G2o throws std::invalid_argument for a missing pose") {
  Dataset2D d;
  Edge2D e;
  e.from = 1;
  e.to = 2;
  d.edges.push_back(e);
  Estimate2D est{{1, {}}};
  CHECK_THROWS_AS(chi2G2o(d, est), std::invalid_argument);
  est[2] = Pose2D{};
  CHECK_NOTHROW(chi2G2o(d, est));
  // No edges: chi2 0 whatever the estimate.
  CHECK(chi2G2o(Dataset2D{}, Estimate2D{}) == 0.0);
}
