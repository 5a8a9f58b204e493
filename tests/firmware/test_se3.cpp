#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <type_traits>
#include <utility>

#include "lie_3d_test_util.h"
#include "lslam/geometry/se3.h"
#include "numerical_diff.h"

using lslam::Mat3;
using lslam::Mat36;
using lslam::Mat4;
using lslam::Mat6;
using lslam::SE3;
using lslam::SO3;
using lslam::Vec3;
using lslam::Vec6;
using namespace lslam::test;
using Quat = Eigen::Quaterniond;

namespace {

constexpr int kCases = 900;
constexpr unsigned kSeed = 20261127u;

// ---- Random cases ---------------------------------------------------------------------------

// The regimes of randomAngle() (generic, near +-pi, tiny, zero, at SO3's series switches), and
// every tenth case on either side of SE3's series switch at 1, or beyond pi.
double randomRotationAngle(std::mt19937& rng, int case_index) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (case_index % 10 == 8)
    return (unit(rng) < 0.5 ? -1.0 : 1.0) * (1.0 + 1e-6 * (2.0 * unit(rng) - 1.0));
  if (case_index % 10 == 9) return kPi + 2.0 * unit(rng);
  return randomAngle(rng, case_index);
}

Vec6 randomTangent6(std::mt19937& rng, int case_index) {
  const Vec3 rho = randomVector(rng, 5.0);
  const Vec3 axis = randomAxis(rng);
  Vec6 tau;
  tau << rho, randomRotationAngle(rng, case_index) * axis;
  return tau;
}

// Rotation by Eigen's angle-axis conversion, not by SO3::exp.
SE3 randomPose3(std::mt19937& rng, int case_index) {
  const Vec3 t = randomVector(rng, 10.0);
  const Vec3 axis = randomAxis(rng);
  const double angle = randomRotationAngle(rng, case_index);
  return SE3(angleAxisRotation(angle, axis), t);
}

}  // namespace

TEST_CASE("construction, accessors and the homogeneous matrix") {
  const SE3 identity;
  CHECK(SE3::kDof == 6);
  CHECK(identity.matrix() == Mat4::Identity());
  CHECK(identity.translation() == Vec3::Zero());
  std::mt19937 rng(kSeed);
  for (int i = 0; i < kCases; ++i) {
    const SE3 a = randomPose3(rng, i);
    CAPTURE(i);
    CHECK(maxAbsDiff(a.matrix(), poseMatrix(a)) < 4e-15);
    CHECK(a.matrix().row(3) == Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0));
  }
}

TEST_CASE("the tangent is ordered (rho, phi): translation first, rotation second") {
  const Vec3 rho(1.0, -2.0, 3.0);
  const Vec3 phi(0.1, 0.2, -0.3);
  Vec6 translation_only;
  translation_only << rho, Vec3::Zero();
  const SE3 x = SE3::exp(translation_only);
  CHECK(x.translation() == rho);
  CHECK(x.rotation().quaternion().coeffs() == Quat::Identity().coeffs());
  Vec6 rotation_only;
  rotation_only << Vec3::Zero(), phi;
  const SE3 y = SE3::exp(rotation_only);
  CHECK(y.translation() == Vec3::Zero());
  CHECK(maxAbsDiff(y.rotation().log(), phi) < 1e-16);
  CHECK(maxAbsDiff(x.log(), translation_only) == 0.0);
}

TEST_CASE("compose, inverse, between and transformFrom match homogeneous matrices") {
  std::mt19937 rng(kSeed + 1);
  for (int i = 0; i < kCases; ++i) {
    const SE3 a = randomPose3(rng, i);
    const SE3 b = randomPose3(rng, i + 4);
    const Vec3 p = randomVector(rng, 10.0);
    const Mat4 ma = poseMatrix(a);
    const Mat4 mb = poseMatrix(b);
    CAPTURE(i);
    CHECK(maxAbsDiff(poseMatrix(a.compose(b)), ma * mb) < 1e-13);
    CHECK(maxAbsDiff(poseMatrix(a.inverse()), ma.inverse()) < 1e-13);
    CHECK(maxAbsDiff(poseMatrix(a.between(b)), ma.inverse() * mb) < 1e-13);
    const Eigen::Vector4d ph(p.x(), p.y(), p.z(), 1.0);
    CHECK(maxAbsDiff(a.transformFrom(p), (ma * ph).head<3>()) < 1e-13);
  }
}

TEST_CASE("group laws: associativity, identity, inverse, between") {
  std::mt19937 rng(kSeed + 2);
  const SE3 identity;
  for (int i = 0; i < kCases; ++i) {
    const SE3 a = randomPose3(rng, i);
    const SE3 b = randomPose3(rng, i + 3);
    const SE3 c = randomPose3(rng, i + 6);
    CAPTURE(i);
    CHECK(poseDistance3(a.compose(b).compose(c), a.compose(b.compose(c))) < 1e-13);
    CHECK(poseDistance3(a.compose(identity), a) < 4e-15);
    CHECK(poseDistance3(identity.compose(a), a) < 4e-15);
    CHECK(poseDistance3(a.compose(a.inverse()), identity) < 1e-13);
    CHECK(poseDistance3(a.inverse().compose(a), identity) < 1e-13);
    CHECK(poseDistance3(a.inverse().inverse(), a) < 1e-13);
    CHECK(poseDistance3(a.between(b), a.inverse().compose(b)) < 1e-13);
    CHECK(poseDistance3(a.compose(a.between(b)), b) < 1e-13);
  }
}

TEST_CASE("adjoint: X Exp(tau) X^-1 = Exp(Ad(X) tau)") {
  std::mt19937 rng(kSeed + 3);
  for (int i = 0; i < kCases; ++i) {
    const SE3 a = randomPose3(rng, i);
    const Vec6 tau = 0.1 * randomTangent6(rng, i);
    CAPTURE(i);
    const Mat4 ma = poseMatrix(a);
    CHECK(maxAbsDiff(ma * expMatrix6(tau) * ma.inverse(), expMatrix6(a.adjoint() * tau)) < 1e-12);
  }
}

TEST_CASE("exp matches the matrix exponential, including tiny angles and angles near pi") {
  std::mt19937 rng(kSeed + 4);
  for (int i = 0; i < kCases; ++i) {
    const Vec6 tau = randomTangent6(rng, i);
    CAPTURE(i);
    CAPTURE(tau.transpose());
    CHECK(maxAbsDiff(poseMatrix(SE3::exp(tau)), expMatrix6(tau)) < 1e-13);
  }
  CHECK(SE3::exp(Vec6::Zero()).matrix() == Mat4::Identity());
  // Tiny rotation: to first order t = rho + phi x rho / 2, exact at 1e-12.
  Vec6 tiny;
  tiny << 3.0, 4.0, -1.0, 0.0, 0.0, 1e-12;
  const SE3 x = SE3::exp(tiny);
  CHECK(x.translation().x() == doctest::Approx(3.0 - 0.5e-12 * 4.0).epsilon(1e-16));
  CHECK(x.translation().y() == doctest::Approx(4.0 + 0.5e-12 * 3.0).epsilon(1e-16));
  CHECK(x.translation().z() == -1.0);
}

TEST_CASE("log matches the matrix logarithm away from pi") {
  std::mt19937 rng(kSeed + 5);
  for (int i = 0; i < kCases; ++i) {
    const SE3 a = randomPose3(rng, i);
    if (referenceAngle(a) > 3.0) continue;  // the matrix logarithm degrades towards pi
    CAPTURE(i);
    CHECK(maxAbsDiff(a.log(), logMatrix6(poseMatrix(a))) < 1e-11);
  }
}

TEST_CASE("exp and log are inverse for random poses and tangents") {
  std::mt19937 rng(kSeed + 6);
  for (int i = 0; i < kCases; ++i) {
    const SE3 a = randomPose3(rng, i);
    CAPTURE(i);
    const Vec6 tau = a.log();
    CHECK(tau.tail<3>().norm() <= kPi);
    CHECK(poseDistance3(SE3::exp(tau), a) < 1e-13);
    CHECK(maxAbsDiff(expMatrix6(tau), poseMatrix(a)) < 1e-12);  // log against a reference
  }
  for (int i = 0; i < kCases; ++i) {
    const Vec6 tau = randomTangent6(rng, i);
    if (tau.tail<3>().norm() >= kPi) continue;  // Log returns angles up to pi only
    CAPTURE(i);
    CAPTURE(tau.transpose());
    CHECK(maxAbsDiff(SE3::exp(tau).log(), tau) < 1e-12);
  }
}

TEST_CASE("log(exp(tau)) == tau near zero, at the series switches and near pi") {
  std::mt19937 rng(kSeed + 7);
  for (int i = 0; i < 100; ++i) {
    const Vec3 axis = randomAxis(rng);
    const Vec3 rho = randomVector(rng, 5.0);
    for (double angle : {0.0, 1e-300, 1e-12, 1e-9, 1e-6, 1e-4, 0.3, 1.0 - 1e-12, 1.0 + 1e-12, 2.0,
                         kPi - 1e-3, kPi - 1e-6, kPi - 1e-9}) {
      Vec6 tau;
      tau << rho, angle * axis;
      CAPTURE(i);
      CAPTURE(angle);
      const Vec6 back = SE3::exp(tau).log();
      CHECK(maxAbsDiff(back.head<3>(), rho) < 1e-14 * (1.0 + rho.norm()));
      CHECK(maxAbsDiff(back.tail<3>(), angle * axis) <= 4e-16 * angle);
    }
    // Exactly pi: phi or -phi (the same rotation), and Exp(Log(X)) == X.
    Vec6 half;
    half << rho, kPi * axis;
    const SE3 x = SE3::exp(half);
    const Vec6 back = x.log();
    CHECK(std::min(maxAbsDiff(back.tail<3>(), kPi * axis),
                   maxAbsDiff(back.tail<3>(), -kPi * axis)) < 4e-15);
    CHECK(poseDistance3(SE3::exp(back), x) < 1e-13);
    // A rotation quaternion with w = 0 exactly.
    const SE3 y(SO3(Quat(0.0, axis.x(), axis.y(), axis.z())), rho);
    CHECK(poseDistance3(SE3::exp(y.log()), y) < 1e-13);
  }
}

TEST_CASE("the right Jacobian of Exp and the inverse right Jacobian of Log are inverses") {
  std::mt19937 rng(kSeed + 8);
  for (int i = 0; i < kCases; ++i) {
    const Vec6 tau = randomTangent6(rng, i);
    if (tau.tail<3>().norm() >= kPi) continue;
    CAPTURE(i);
    CAPTURE(tau.transpose());
    Mat6 J_r;
    Mat6 J_r_inv;
    SE3::exp(tau, &J_r).log(&J_r_inv);
    CHECK(maxAbsDiff(J_r * J_r_inv, Mat6::Identity()) < 1e-12);
  }
}

TEST_CASE("compose and inverse Jacobians match central differences") {
  std::mt19937 rng(kSeed + 9);
  for (int i = 0; i < kCases; ++i) {
    const SE3 a = randomPose3(rng, i);
    const SE3 b = randomPose3(rng, i + 1);
    CAPTURE(i);
    Mat6 J_c_a;
    Mat6 J_c_b;
    a.compose(b, &J_c_a, &J_c_b);
    CHECK_JACOBIAN(J_c_a, centralJacobian([&](const SE3& x) { return x.compose(b); }, a));
    CHECK_JACOBIAN(J_c_b, centralJacobian([&](const SE3& x) { return a.compose(x); }, b));
    Mat6 J_inv_a;
    a.inverse(&J_inv_a);
    CHECK_JACOBIAN(J_inv_a, centralJacobian([](const SE3& x) { return x.inverse(); }, a));
  }
}

TEST_CASE("between and transformFrom Jacobians match central differences") {
  std::mt19937 rng(kSeed + 10);
  for (int i = 0; i < kCases; ++i) {
    const SE3 a = randomPose3(rng, i);
    const SE3 b = randomPose3(rng, i + 2);
    const Vec3 p = randomVector(rng, 10.0);
    CAPTURE(i);
    Mat6 J_d_a;
    Mat6 J_d_b;
    a.between(b, &J_d_a, &J_d_b);
    CHECK_JACOBIAN(J_d_a, centralJacobian([&](const SE3& x) { return x.between(b); }, a));
    CHECK_JACOBIAN(J_d_b, centralJacobian([&](const SE3& x) { return a.between(x); }, b));
    Mat36 J_p_a;
    Mat3 J_p_p;
    a.transformFrom(p, &J_p_a, &J_p_p);
    CHECK_JACOBIAN(J_p_a,
                   centralJacobian([&](const SE3& x) -> Vec3 { return x.transformFrom(p); }, a));
    CHECK_JACOBIAN(J_p_p,
                   centralJacobian([&](const Vec3& q) -> Vec3 { return a.transformFrom(q); }, p));
  }
}

TEST_CASE("exp and log Jacobians match central differences") {
  std::mt19937 rng(kSeed + 11);
  for (int i = 0; i < kCases; ++i) {
    const Vec6 tau = randomTangent6(rng, i);
    CAPTURE(i);
    CAPTURE(tau.transpose());
    Mat6 J_r;
    SE3::exp(tau, &J_r);
    CHECK_JACOBIAN(J_r, centralJacobian([](const Vec6& t) { return SE3::exp(t); }, tau));

    const SE3 a = randomPose3(rng, i);
    if (nearHalfTurn(referenceAngle(a))) continue;  // Log jumps there: no derivative
    Mat6 J_r_inv;
    a.log(&J_r_inv);
    CHECK_JACOBIAN(J_r_inv, centralJacobian([](const SE3& x) -> Vec6 { return x.log(); }, a));
  }
}

TEST_CASE("retract and localCoordinates: inverse, x * Exp(tau), Jacobians") {
  std::mt19937 rng(kSeed + 12);
  for (int i = 0; i < kCases; ++i) {
    const SE3 a = randomPose3(rng, i);
    const SE3 b = randomPose3(rng, i + 7);
    const Vec6 tau = randomTangent6(rng, i + 1);
    CAPTURE(i);
    CHECK(poseDistance3(a.retract(a.localCoordinates(b)), b) < 1e-13);
    CHECK(maxAbsDiff(poseMatrix(a.retract(tau)), poseMatrix(a) * expMatrix6(tau)) < 1e-12);
    if (tau.tail<3>().norm() < kPi) {
      CHECK(maxAbsDiff(a.localCoordinates(a.retract(tau)), tau) < 1e-11);
    }

    Mat6 J_x_a;
    Mat6 J_x_tau;
    a.retract(tau, &J_x_a, &J_x_tau);
    CHECK_JACOBIAN(J_x_a, centralJacobian([&](const SE3& x) { return x.retract(tau); }, a));
    CHECK_JACOBIAN(J_x_tau, centralJacobian([&](const Vec6& t) { return a.retract(t); }, tau));

    if (nearHalfTurn(referenceAngle(a.between(b)))) continue;
    Mat6 J_t_a;
    Mat6 J_t_b;
    a.localCoordinates(b, &J_t_a, &J_t_b);
    CHECK_JACOBIAN(J_t_a,
                   centralJacobian([&](const SE3& x) -> Vec6 { return x.localCoordinates(b); }, a));
    CHECK_JACOBIAN(J_t_b,
                   centralJacobian([&](const SE3& x) -> Vec6 { return a.localCoordinates(x); }, b));
  }
}

TEST_CASE("asking for Jacobians does not change the results") {
  std::mt19937 rng(kSeed + 13);
  for (int i = 0; i < 90; ++i) {
    const SE3 a = randomPose3(rng, i);
    const SE3 b = randomPose3(rng, i + 1);
    const Vec6 tau = randomTangent6(rng, i);
    const Vec3 p = randomVector(rng, 10.0);
    Mat6 j1;
    Mat6 j2;
    Mat36 j36;
    Mat3 j3;
    const auto same = [](const SE3& x, const SE3& y) { return x.matrix() == y.matrix(); };
    CHECK(same(a.compose(b, &j1, &j2), a.compose(b)));
    CHECK(same(a.inverse(&j1), a.inverse()));
    CHECK(same(a.between(b, &j1, &j2), a.between(b)));
    CHECK(a.transformFrom(p, &j36, &j3) == a.transformFrom(p));
    CHECK(same(SE3::exp(tau, &j1), SE3::exp(tau)));
    CHECK(a.log(&j1) == a.log());
    CHECK(same(a.retract(tau, &j1, &j2), a.retract(tau)));
    CHECK(a.localCoordinates(b, &j1, &j2) == a.localCoordinates(b));
    CHECK(a.localCoordinates(b, &j1, nullptr) == a.localCoordinates(b));
    CHECK(a.localCoordinates(b, nullptr, &j2) == a.localCoordinates(b));
  }
}
