#include <doctest/doctest.h>

#include <cmath>
#include <random>

#include "lslam/geometry/se2.h"
#include "numerical_diff.h"

using lslam::Mat2;
using lslam::Mat23;
using lslam::Mat3;
using lslam::SE2;
using lslam::Vec2;
using lslam::Vec3;
using namespace lslam::test;

namespace {

constexpr int kCases = 900;  // 100 per angle regime of randomAngle()
constexpr unsigned kSeed = 20240601u;

// Angle of a pose, from the matrix reference rather than from SE2.
double referenceAngle(const Mat3& m) {
  return std::atan2(m(1, 0), m(0, 0));
}

bool nearCut(double angle) {
  return std::abs(angle) > kPi - 1e-4;
}

Vec2 randomPoint(std::mt19937& rng) {
  std::uniform_real_distribution<double> coordinate(-10.0, 10.0);
  const double x = coordinate(rng);
  const double y = coordinate(rng);
  return Vec2(x, y);
}

}  // namespace

TEST_CASE("construction wraps theta; the default pose is the identity") {
  const SE2 identity;
  CHECK(identity.x() == 0.0);
  CHECK(identity.y() == 0.0);
  CHECK(identity.theta() == 0.0);
  CHECK(SE2::kDof == 3);

  const SE2 p(1.5, -2.0, 2.0 * kPi + 0.25);
  CHECK(p.x() == 1.5);
  CHECK(p.y() == -2.0);
  CHECK(p.theta() == doctest::Approx(0.25).epsilon(1e-15));
  CHECK(SE2(0.0, 0.0, -kPi).theta() == kPi);
}

TEST_CASE("rotation, translation and vector agree with the stored coordinates") {
  std::mt19937 rng(kSeed);
  for (int i = 0; i < kCases; ++i) {
    const SE2 a = randomPose(rng, i);
    const Mat3 m = toMatrix(a);
    CHECK(maxAbsDiff(a.rotation(), m.topLeftCorner<2, 2>()) < 1e-15);
    CHECK(maxAbsDiff(a.translation(), m.topRightCorner<2, 1>()) == 0.0);
    CHECK(maxAbsDiff(a.vector(), Vec3(a.x(), a.y(), a.theta())) == 0.0);
    CHECK(a.theta() > -kPi);
    CHECK(a.theta() <= kPi);
  }
}

TEST_CASE("compose, inverse, between and transformFrom match homogeneous matrices") {
  std::mt19937 rng(kSeed + 1);
  for (int i = 0; i < kCases; ++i) {
    const SE2 a = randomPose(rng, i);
    const SE2 b = randomPose(rng, i + 4);
    const Vec2 p = randomPoint(rng);
    const Mat3 ma = toMatrix(a);
    const Mat3 mb = toMatrix(b);
    CAPTURE(i);

    const SE2 c = a.compose(b);
    CHECK(maxAbsDiff(toMatrix(c), ma * mb) < 1e-12);
    CHECK(c.theta() > -kPi);
    CHECK(c.theta() <= kPi);

    const SE2 inv = a.inverse();
    CHECK(maxAbsDiff(toMatrix(inv), ma.inverse()) < 1e-12);
    CHECK(inv.theta() > -kPi);
    CHECK(inv.theta() <= kPi);

    const SE2 d = a.between(b);
    CHECK(maxAbsDiff(toMatrix(d), ma.inverse() * mb) < 1e-12);
    CHECK(d.theta() > -kPi);
    CHECK(d.theta() <= kPi);

    const Eigen::Vector3d ph(p.x(), p.y(), 1.0);
    CHECK(maxAbsDiff(a.transformFrom(p), (ma * ph).head<2>()) < 1e-12);
  }
}

TEST_CASE("group laws: associativity, identity, inverse, between") {
  std::mt19937 rng(kSeed + 2);
  const SE2 identity;
  for (int i = 0; i < kCases; ++i) {
    const SE2 a = randomPose(rng, i);
    const SE2 b = randomPose(rng, i + 3);
    const SE2 c = randomPose(rng, i + 6);
    CAPTURE(i);
    CHECK(poseDistance(a.compose(b).compose(c), a.compose(b.compose(c))) < 1e-12);
    CHECK(poseDistance(a.compose(identity), a) < 1e-15);
    CHECK(poseDistance(identity.compose(a), a) < 1e-15);
    CHECK(poseDistance(a.compose(a.inverse()), identity) < 1e-12);
    CHECK(poseDistance(a.inverse().compose(a), identity) < 1e-12);
    CHECK(poseDistance(a.inverse().inverse(), a) < 1e-12);
    CHECK(poseDistance(a.between(b), a.inverse().compose(b)) < 1e-12);
    CHECK(poseDistance(a.compose(a.between(b)), b) < 1e-12);
  }
}

TEST_CASE("exp matches the matrix exponential, including tiny angles and angles near pi") {
  std::mt19937 rng(kSeed + 3);
  for (int i = 0; i < kCases; ++i) {
    const Vec3 tau = randomTangent(rng, i);
    CAPTURE(i);
    CAPTURE(tau.transpose());
    const SE2 x = SE2::exp(tau);
    CHECK(maxAbsDiff(toMatrix(x), expMatrix(tau)) < 1e-12);
    CHECK(x.theta() > -kPi);
    CHECK(x.theta() <= kPi);
  }
  // Exactly zero rotation: Exp is a pure translation, with no 0/0 on the way.
  const SE2 pure = SE2::exp(Vec3(1.0, -2.0, 0.0));
  CHECK(pure.x() == 1.0);
  CHECK(pure.y() == -2.0);
  CHECK(pure.theta() == 0.0);
  // Tiny rotation: to first order t = v + (w/2) J v, exactly representable at w = 1e-12.
  const double w = 1e-12;
  const SE2 tiny = SE2::exp(Vec3(3.0, 4.0, w));
  CHECK(tiny.x() == doctest::Approx(3.0 - 0.5 * w * 4.0).epsilon(1e-16));
  CHECK(tiny.y() == doctest::Approx(4.0 + 0.5 * w * 3.0).epsilon(1e-16));
  CHECK(tiny.theta() == w);
}

TEST_CASE("log matches the matrix logarithm away from the cut at pi") {
  std::mt19937 rng(kSeed + 4);
  for (int i = 0; i < kCases; ++i) {
    const SE2 a = randomPose(rng, i);
    if (std::abs(a.theta()) > 3.0) continue;  // the matrix logarithm degrades towards pi
    CAPTURE(i);
    CHECK(maxAbsDiff(a.log(), logMatrix(toMatrix(a))) < 1e-10);
  }
  CHECK(maxAbsDiff(SE2(1.0, -2.0, 0.0).log(), Vec3(1.0, -2.0, 0.0)) == 0.0);
}

TEST_CASE("exp and log are inverse, including tiny angles and angles near pi") {
  std::mt19937 rng(kSeed + 5);
  for (int i = 0; i < kCases; ++i) {
    const SE2 a = randomPose(rng, i);
    CAPTURE(i);
    const Vec3 tau = a.log();
    CHECK(tau(2) > -kPi);
    CHECK(tau(2) <= kPi);
    CHECK(maxAbsDiff(toMatrix(SE2::exp(tau)), toMatrix(a)) < 1e-12);
    CHECK(maxAbsDiff(expMatrix(tau), toMatrix(a)) < 1e-11);  // log checked against a reference
  }
  for (int i = 0; i < kCases; ++i) {
    const Vec3 tau = randomTangent(rng, i);
    if (tau(2) <= -kPi || tau(2) > kPi) continue;  // Log returns the principal angle only
    CAPTURE(i);
    CAPTURE(tau.transpose());
    CHECK(maxAbsDiff(SE2::exp(tau).log(), tau) < 1e-11);
  }
  // Relative accuracy where the closed forms would be 0/0 or cancel.
  for (double w : {1e-12, -1e-12, 1e-8, 1e-5, 1e-4, 0.29999, 0.30001}) {
    const Vec3 tau(0.7, -1.3, w);
    const Vec3 back = SE2::exp(tau).log();
    CAPTURE(w);
    CHECK(back(0) == doctest::Approx(tau(0)).epsilon(1e-15));
    CHECK(back(1) == doctest::Approx(tau(1)).epsilon(1e-15));
    CHECK(back(2) == doctest::Approx(w).epsilon(1e-15));
  }
}

TEST_CASE("retract and localCoordinates are inverse and retract is x * Exp(tau)") {
  std::mt19937 rng(kSeed + 6);
  for (int i = 0; i < kCases; ++i) {
    const SE2 a = randomPose(rng, i);
    const SE2 b = randomPose(rng, i + 5);
    const Vec3 tau = randomTangent(rng, i + 2);
    CAPTURE(i);
    CHECK(poseDistance(a.retract(a.localCoordinates(b)), b) < 1e-11);
    CHECK(maxAbsDiff(toMatrix(a.retract(tau)), toMatrix(a) * expMatrix(tau)) < 1e-11);
    if (tau(2) > -kPi && tau(2) <= kPi) {
      CHECK(maxAbsDiff(a.localCoordinates(a.retract(tau)), tau) < 1e-10);
    }
  }
}

TEST_CASE("the right Jacobian of Exp and the inverse right Jacobian of Log are inverses") {
  // Exp and Log compute their Jacobians from different series and closed forms; their product
  // being the identity to near machine precision checks the series switches for accuracy,
  // beyond what finite differences can resolve.
  std::mt19937 rng(kSeed + 7);
  for (int i = 0; i < kCases; ++i) {
    const Vec3 tau = randomTangent(rng, i);
    if (tau(2) <= -kPi || tau(2) > kPi) continue;
    CAPTURE(i);
    CAPTURE(tau.transpose());
    Mat3 J_r;
    Mat3 J_r_inv;
    const SE2 x = SE2::exp(tau, &J_r);
    x.log(&J_r_inv);
    CHECK(maxAbsDiff(J_r * J_r_inv, Mat3::Identity()) < 1e-12);
  }
}

TEST_CASE("compose and inverse Jacobians match central differences") {
  std::mt19937 rng(kSeed + 8);
  for (int i = 0; i < kCases; ++i) {
    const SE2 a = randomPose(rng, i);
    const SE2 b = randomPose(rng, i + 1);
    CAPTURE(i);
    Mat3 J_c_a;
    Mat3 J_c_b;
    a.compose(b, &J_c_a, &J_c_b);
    CHECK_JACOBIAN(J_c_a, numericalJacobianSE2([&](const SE2& x) { return x.compose(b); }, a));
    CHECK_JACOBIAN(J_c_b, numericalJacobianSE2([&](const SE2& x) { return a.compose(x); }, b));

    Mat3 J_inv_a;
    a.inverse(&J_inv_a);
    CHECK_JACOBIAN(J_inv_a, numericalJacobianSE2([](const SE2& x) { return x.inverse(); }, a));
  }
}

TEST_CASE("between and transformFrom Jacobians match central differences") {
  std::mt19937 rng(kSeed + 9);
  for (int i = 0; i < kCases; ++i) {
    const SE2 a = randomPose(rng, i);
    const SE2 b = randomPose(rng, i + 2);
    const Vec2 p = randomPoint(rng);
    CAPTURE(i);
    Mat3 J_d_a;
    Mat3 J_d_b;
    a.between(b, &J_d_a, &J_d_b);
    CHECK_JACOBIAN(J_d_a, numericalJacobianSE2([&](const SE2& x) { return x.between(b); }, a));
    CHECK_JACOBIAN(J_d_b, numericalJacobianSE2([&](const SE2& x) { return a.between(x); }, b));

    Mat23 J_p_a;
    Mat2 J_p_p;
    a.transformFrom(p, &J_p_a, &J_p_p);
    CHECK_JACOBIAN(
        J_p_a, numericalJacobianSE2([&](const SE2& x) -> Vec2 { return x.transformFrom(p); }, a));
    CHECK_JACOBIAN(J_p_p,
                   numericalJacobian([&](const Vec2& q) -> Vec2 { return a.transformFrom(q); }, p));
  }
}

TEST_CASE("exp and log Jacobians match central differences") {
  std::mt19937 rng(kSeed + 10);
  for (int i = 0; i < kCases; ++i) {
    const Vec3 tau = randomTangent(rng, i);
    CAPTURE(i);
    CAPTURE(tau.transpose());
    Mat3 J_r;
    SE2::exp(tau, &J_r);
    CHECK_JACOBIAN(J_r, numericalJacobian([](const Vec3& t) { return SE2::exp(t); }, tau));

    const SE2 a = randomPose(rng, i);
    if (nearCut(a.theta())) continue;  // Log jumps by 2 pi there: no derivative to compare
    Mat3 J_r_inv;
    a.log(&J_r_inv);
    CHECK_JACOBIAN(J_r_inv, numericalJacobianSE2([](const SE2& x) -> Vec3 { return x.log(); }, a));
  }
}

TEST_CASE("retract and localCoordinates Jacobians match central differences") {
  std::mt19937 rng(kSeed + 11);
  for (int i = 0; i < kCases; ++i) {
    const SE2 a = randomPose(rng, i);
    const SE2 b = randomPose(rng, i + 7);
    const Vec3 tau = randomTangent(rng, i + 1);
    CAPTURE(i);
    Mat3 J_x_a;
    Mat3 J_x_tau;
    a.retract(tau, &J_x_a, &J_x_tau);
    CHECK_JACOBIAN(J_x_a, numericalJacobianSE2([&](const SE2& x) { return x.retract(tau); }, a));
    CHECK_JACOBIAN(J_x_tau, numericalJacobian([&](const Vec3& t) { return a.retract(t); }, tau));

    if (nearCut(referenceAngle(toMatrix(a).inverse() * toMatrix(b)))) continue;
    Mat3 J_t_a;
    Mat3 J_t_b;
    a.localCoordinates(b, &J_t_a, &J_t_b);
    CHECK_JACOBIAN(J_t_a, numericalJacobianSE2(
                              [&](const SE2& x) -> Vec3 { return x.localCoordinates(b); }, a));
    CHECK_JACOBIAN(J_t_b, numericalJacobianSE2(
                              [&](const SE2& x) -> Vec3 { return a.localCoordinates(x); }, b));
  }
}

TEST_CASE("asking for Jacobians does not change the results") {
  std::mt19937 rng(kSeed + 12);
  for (int i = 0; i < 90; ++i) {
    const SE2 a = randomPose(rng, i);
    const SE2 b = randomPose(rng, i + 1);
    const Vec3 tau = randomTangent(rng, i);
    const Vec2 p = randomPoint(rng);
    Mat3 j1;
    Mat3 j2;
    Mat23 j23;
    Mat2 j22;
    CHECK(poseDistance(a.compose(b, &j1, &j2), a.compose(b)) == 0.0);
    CHECK(poseDistance(a.inverse(&j1), a.inverse()) == 0.0);
    CHECK(poseDistance(a.between(b, &j1, &j2), a.between(b)) == 0.0);
    CHECK(maxAbsDiff(a.transformFrom(p, &j23, &j22), a.transformFrom(p)) == 0.0);
    CHECK(poseDistance(SE2::exp(tau, &j1), SE2::exp(tau)) == 0.0);
    CHECK(maxAbsDiff(a.log(&j1), a.log()) == 0.0);
    CHECK(poseDistance(a.retract(tau, &j1, &j2), a.retract(tau)) == 0.0);
    CHECK(maxAbsDiff(a.localCoordinates(b, &j1, &j2), a.localCoordinates(b)) == 0.0);
    CHECK(maxAbsDiff(a.localCoordinates(b, &j1, nullptr), a.localCoordinates(b)) == 0.0);
    CHECK(maxAbsDiff(a.localCoordinates(b, nullptr, &j2), a.localCoordinates(b)) == 0.0);
  }
}
