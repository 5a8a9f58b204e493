#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <type_traits>
#include <utility>

#include "lie_3d_test_util.h"
#include "lslam/geometry/so3.h"
#include "lslam/status.h"
#include "numerical_diff.h"

using lslam::Mat3;
using lslam::SO3;
using lslam::Status;
using lslam::validateQuaternion;
using lslam::Vec3;
using namespace lslam::test;
using Quat = Eigen::Quaterniond;

namespace {

constexpr int kCases = 900;
constexpr unsigned kSeed = 20261126u;

// ---- Random cases ---------------------------------------------------------------------------

// The regimes of randomAngle() (generic, near +-pi, tiny, zero, at the series switches) and
// every tenth case an angle beyond pi, which Exp takes and Log maps back below pi.
double randomRotationAngle(std::mt19937& rng, int case_index) {
  if (case_index % 10 == 9) {
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    return kPi + 2.0 * unit(rng);
  }
  return randomAngle(rng, case_index);
}

Vec3 randomTangent3(std::mt19937& rng, int case_index) {
  const Vec3 axis = randomAxis(rng);
  return randomRotationAngle(rng, case_index) * axis;
}

// Built by Eigen's angle-axis conversion, not by SO3::exp.
SO3 randomRotation(std::mt19937& rng, int case_index) {
  const Vec3 axis = randomAxis(rng);
  const double angle = randomRotationAngle(rng, case_index);
  return angleAxisRotation(angle, axis);
}

}  // namespace

TEST_CASE("validateQuaternion: unit, near unit, off unit, non-finite, zero") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  CHECK(lslam::kUnitQuaternionTolerance == 1e-6);
  CHECK(validateQuaternion(Quat::Identity()) == Status::Ok);
  CHECK(validateQuaternion(Quat(0.0, 0.0, 0.0, 1.0)) == Status::Ok);
  CHECK(validateQuaternion(Quat(-0.5, 0.5, -0.5, 0.5)) == Status::Ok);

  // Scaled within and beyond the tolerance, both ways.
  const Quat unit = Quat(0.1, -0.7, 0.2, 0.4).normalized();
  const auto scaled = [&](double s) { return Quat(unit.coeffs() * s); };
  CHECK(validateQuaternion(scaled(1.0 + 0.5e-6)) == Status::Ok);
  CHECK(validateQuaternion(scaled(1.0 - 0.5e-6)) == Status::Ok);
  CHECK(validateQuaternion(scaled(1.0 + 2e-6)) == Status::InvalidArgument);
  CHECK(validateQuaternion(scaled(1.0 - 2e-6)) == Status::InvalidArgument);
  CHECK(validateQuaternion(scaled(2.0)) == Status::InvalidArgument);
  CHECK(validateQuaternion(scaled(-1.0)) == Status::Ok);  // -q: the same rotation, also unit
  // A caller's own tolerance.
  CHECK(validateQuaternion(scaled(1.0 + 1e-4), 1e-3) == Status::Ok);
  CHECK(validateQuaternion(scaled(1.0 + 1e-2), 1e-3) == Status::InvalidArgument);
  CHECK(validateQuaternion(Quat::Identity(), 0.0) == Status::Ok);

  CHECK(validateQuaternion(Quat(0.0, 0.0, 0.0, 0.0)) == Status::InvalidArgument);
  CHECK(validateQuaternion(Quat(1e200, 0.0, 0.0, 0.0)) == Status::InvalidArgument);  // |q|^2 = Inf
  CHECK(validateQuaternion(Quat(1e-200, 0.0, 0.0, 0.0)) == Status::InvalidArgument);
  for (int k = 0; k < 4; ++k) {
    for (double bad : {nan, inf, -inf}) {
      Quat q = Quat::Identity();
      q.coeffs()(k) = bad;
      CAPTURE(k);
      CAPTURE(bad);
      CHECK(validateQuaternion(q) == Status::NonFiniteInput);
    }
  }

  std::mt19937 rng(kSeed);
  for (int i = 0; i < kCases; ++i) {
    CHECK(validateQuaternion(randomRotation(rng, i).quaternion()) == Status::Ok);
  }
}

TEST_CASE("construction: identity by default, the quaternion stored as given") {
  const SO3 identity;
  CHECK(SO3::kDof == 3);
  CHECK(identity.quaternion().coeffs() == Quat::Identity().coeffs());
  CHECK(identity.matrix() == Mat3::Identity());
  const Quat q(-0.5, 0.5, -0.5, 0.5);  // w < 0 is kept
  CHECK(SO3(q).quaternion().coeffs() == q.coeffs());
  CHECK(maxAbsDiff(SO3(q).matrix(), SO3(Quat(q.coeffs() * -1.0)).matrix()) == 0.0);
}

TEST_CASE("matrix is the rotation of the quaternion, orthonormal with determinant 1") {
  std::mt19937 rng(kSeed + 1);
  for (int i = 0; i < kCases; ++i) {
    const SO3 a = randomRotation(rng, i);
    const Mat3 r = a.matrix();
    CAPTURE(i);
    CHECK(maxAbsDiff(r, rotationMatrix(a)) < 4e-15);
    CHECK(maxAbsDiff(r * r.transpose(), Mat3::Identity()) < 4e-15);
    CHECK(r.determinant() == doctest::Approx(1.0).epsilon(1e-15));
  }
}

TEST_CASE("compose, inverse, between and act match rotation matrices") {
  std::mt19937 rng(kSeed + 2);
  for (int i = 0; i < kCases; ++i) {
    const SO3 a = randomRotation(rng, i);
    const SO3 b = randomRotation(rng, i + 4);
    const Vec3 p = randomVector(rng, 10.0);
    const Mat3 ra = rotationMatrix(a);
    const Mat3 rb = rotationMatrix(b);
    CAPTURE(i);
    CHECK(maxAbsDiff(rotationMatrix(a.compose(b)), ra * rb) < 4e-15);
    CHECK(maxAbsDiff(rotationMatrix(a.inverse()), ra.transpose()) < 4e-15);
    CHECK(maxAbsDiff(rotationMatrix(a.between(b)), ra.transpose() * rb) < 4e-15);
    CHECK(maxAbsDiff(a.act(p), ra * p) < 1e-13);
  }
}

TEST_CASE("group laws: associativity, identity, inverse, between") {
  std::mt19937 rng(kSeed + 3);
  const SO3 identity;
  for (int i = 0; i < kCases; ++i) {
    const SO3 a = randomRotation(rng, i);
    const SO3 b = randomRotation(rng, i + 3);
    const SO3 c = randomRotation(rng, i + 6);
    CAPTURE(i);
    CHECK(rotationDistance(a.compose(b).compose(c), a.compose(b.compose(c))) < 4e-15);
    CHECK(rotationDistance(a.compose(identity), a) < 4e-15);
    CHECK(rotationDistance(identity.compose(a), a) < 4e-15);
    CHECK(rotationDistance(a.compose(a.inverse()), identity) < 4e-15);
    CHECK(rotationDistance(a.inverse().compose(a), identity) < 4e-15);
    CHECK(rotationDistance(a.inverse().inverse(), a) == 0.0);
    CHECK(rotationDistance(a.between(b), a.inverse().compose(b)) < 4e-15);
    CHECK(rotationDistance(a.compose(a.between(b)), b) < 4e-15);
  }
}

TEST_CASE("long chains of compositions keep the quaternion unit") {
  std::mt19937 rng(kSeed + 4);
  SO3 x = randomRotation(rng, 0);
  SO3 y = x;
  const SO3 step = SO3::exp(Vec3(0.3, -0.2, 0.1));
  for (int i = 0; i < 100000; ++i) {
    x = x.compose(step);
    y = y.retract(Vec3(1e-3, 2e-3, -1e-3));
  }
  CHECK(std::abs(x.quaternion().norm() - 1.0) < 4e-15);
  CHECK(std::abs(y.quaternion().norm() - 1.0) < 4e-15);
}

TEST_CASE("exp matches the matrix exponential, including tiny angles and angles near pi") {
  std::mt19937 rng(kSeed + 5);
  for (int i = 0; i < kCases; ++i) {
    const Vec3 phi = randomTangent3(rng, i);
    CAPTURE(i);
    CAPTURE(phi.transpose());
    const SO3 x = SO3::exp(phi);
    CHECK(std::abs(x.quaternion().norm() - 1.0) < 4e-15);
    CHECK(maxAbsDiff(rotationMatrix(x), expMatrix3(phi)) < 1e-14);
  }
  // Zero: exactly the identity.
  CHECK(SO3::exp(Vec3::Zero()).quaternion().coeffs() == Quat::Identity().coeffs());
  // Tiny: to first order q = (1, phi/2), exact at 1e-12.
  const Vec3 tiny(1e-12, -2e-12, 3e-12);
  const Quat q = SO3::exp(tiny).quaternion();
  CHECK(q.w() == 1.0);
  CHECK(maxAbsDiff(q.vec(), 0.5 * tiny) < 1e-28);
}

TEST_CASE("log matches the matrix logarithm away from pi") {
  std::mt19937 rng(kSeed + 6);
  for (int i = 0; i < kCases; ++i) {
    const SO3 a = randomRotation(rng, i);
    if (referenceAngle(a) > 3.0) continue;  // the matrix logarithm degrades towards pi
    CAPTURE(i);
    CHECK(maxAbsDiff(a.log(), logMatrix3(rotationMatrix(a))) < 1e-13);
  }
  CHECK(SO3().log() == Vec3::Zero());
}

TEST_CASE("exp and log are inverse for random rotations and tangents") {
  std::mt19937 rng(kSeed + 7);
  for (int i = 0; i < kCases; ++i) {
    const SO3 a = randomRotation(rng, i);
    CAPTURE(i);
    const Vec3 phi = a.log();
    CHECK(phi.norm() <= kPi);
    CHECK(rotationDistance(SO3::exp(phi), a) < 4e-15);
    CHECK(maxAbsDiff(expMatrix3(phi), rotationMatrix(a)) < 1e-14);  // log against a reference
    // The sign of the stored quaternion does not matter.
    const SO3 minus_a(Quat(a.quaternion().coeffs() * -1.0));
    if (std::abs(a.quaternion().w()) > 0.0) CHECK(maxAbsDiff(minus_a.log(), phi) == 0.0);
  }
  for (int i = 0; i < kCases; ++i) {
    const Vec3 phi = randomTangent3(rng, i);
    CAPTURE(i);
    CAPTURE(phi.transpose());
    const Vec3 back = SO3::exp(phi).log();
    if (phi.norm() < kPi) {
      CHECK(maxAbsDiff(back, phi) < 1e-14);
    } else {
      // Beyond pi: the same rotation, turned the other way, by 2 pi - |phi|.
      CHECK(back.norm() == doctest::Approx(2.0 * kPi - phi.norm()).epsilon(1e-14));
      CHECK(maxAbsDiff(back.normalized(), -phi.normalized()) < 1e-14);
    }
  }
}

TEST_CASE("log(exp(phi)) == phi near zero, at the series switch and near pi") {
  std::mt19937 rng(kSeed + 8);
  for (int i = 0; i < 100; ++i) {
    const Vec3 axis = randomAxis(rng);
    for (double angle : {1e-300, 1e-12, 1e-9, 1e-6, 1e-4 - 1e-12, 1e-4 + 1e-12, 0.3, 1.0, 2.0,
                         kPi - 1e-3, kPi - 1e-6, kPi - 1e-9}) {
      const Vec3 phi = angle * axis;
      CAPTURE(i);
      CAPTURE(angle);
      const Vec3 back = SO3::exp(phi).log();
      // Relative accuracy: no 0/0, no cancellation, no loss near the half turn.
      CHECK(maxAbsDiff(back, phi) <= 4e-16 * angle);
    }
  }
}

TEST_CASE("a half turn: exactly pi, and quaternions on both sides of w = 0") {
  std::mt19937 rng(kSeed + 9);
  for (int i = 0; i < 100; ++i) {
    const Vec3 axis = randomAxis(rng);
    CAPTURE(i);
    // Exactly pi (the double nearest): phi or -phi, the same rotation.
    const Vec3 phi = kPi * axis;
    const SO3 x = SO3::exp(phi);
    const Vec3 back = x.log();
    CHECK(std::min(maxAbsDiff(back, phi), maxAbsDiff(back, -phi)) < 4e-15);
    CHECK(rotationDistance(SO3::exp(back), x) < 4e-15);
    // w = 0 exactly, either sign of the vector part: the angle is pi.
    const SO3 half(Quat(0.0, axis.x(), axis.y(), axis.z()));
    CHECK(maxAbsDiff(half.log(), kPi * axis) < 4e-15);
    const SO3 minus_half(Quat(0.0, -axis.x(), -axis.y(), -axis.z()));
    CHECK(maxAbsDiff(minus_half.log(), -kPi * axis) < 4e-15);
    CHECK(rotationDistance(SO3::exp(minus_half.log()), half) < 4e-15);
    // Just past pi (w < 0): pi - e about the opposite axis.
    for (double e : {1e-9, 1e-6}) {
      CAPTURE(e);
      const Vec3 past = SO3::exp((kPi + e) * axis).log();
      CHECK(maxAbsDiff(past, -(kPi - e) * axis) < 4e-15);
    }
  }
}

TEST_CASE("the right Jacobian and its inverse are inverses, and Jl = Jr^T = Jr(-phi)") {
  std::mt19937 rng(kSeed + 10);
  for (int i = 0; i < kCases; ++i) {
    Vec3 phi = randomTangent3(rng, i);
    if (phi.norm() > kPi) continue;  // Jr^-1 is meant for what Log returns
    CAPTURE(i);
    CAPTURE(phi.transpose());
    const Mat3 jr = SO3::rightJacobian(phi);
    const Mat3 jr_inv = SO3::rightJacobianInverse(phi);
    CHECK(maxAbsDiff(jr * jr_inv, Mat3::Identity()) < 1e-14);
    CHECK(maxAbsDiff(SO3::rightJacobian(-phi), jr.transpose()) < 4e-15);
    // Jl: d Exp(phi + d) = Exp(Jl d) Exp(phi), against central differences.
    const Mat3 jl_numeric = centralJacobian(
        [&](const Vec3& p) -> Vec3 {
          return logMatrix3(rotationMatrix(SO3::exp(p)) *
                            rotationMatrix(SO3::exp(phi)).transpose());
        },
        phi);
    CHECK_JACOBIAN(jr.transpose(), jl_numeric);
  }
}

TEST_CASE("compose and inverse Jacobians match central differences") {
  std::mt19937 rng(kSeed + 11);
  for (int i = 0; i < kCases; ++i) {
    const SO3 a = randomRotation(rng, i);
    const SO3 b = randomRotation(rng, i + 1);
    CAPTURE(i);
    Mat3 J_c_a;
    Mat3 J_c_b;
    a.compose(b, &J_c_a, &J_c_b);
    CHECK_JACOBIAN(J_c_a, centralJacobian([&](const SO3& x) { return x.compose(b); }, a));
    CHECK_JACOBIAN(J_c_b, centralJacobian([&](const SO3& x) { return a.compose(x); }, b));
    Mat3 J_inv_a;
    a.inverse(&J_inv_a);
    CHECK_JACOBIAN(J_inv_a, centralJacobian([](const SO3& x) { return x.inverse(); }, a));
  }
}

TEST_CASE("between and act Jacobians match central differences") {
  std::mt19937 rng(kSeed + 12);
  for (int i = 0; i < kCases; ++i) {
    const SO3 a = randomRotation(rng, i);
    const SO3 b = randomRotation(rng, i + 2);
    const Vec3 p = randomVector(rng, 10.0);
    CAPTURE(i);
    Mat3 J_d_a;
    Mat3 J_d_b;
    a.between(b, &J_d_a, &J_d_b);
    CHECK_JACOBIAN(J_d_a, centralJacobian([&](const SO3& x) { return x.between(b); }, a));
    CHECK_JACOBIAN(J_d_b, centralJacobian([&](const SO3& x) { return a.between(x); }, b));
    Mat3 J_p_a;
    Mat3 J_p_p;
    a.act(p, &J_p_a, &J_p_p);
    CHECK_JACOBIAN(J_p_a, centralJacobian([&](const SO3& x) -> Vec3 { return x.act(p); }, a));
    CHECK_JACOBIAN(J_p_p, centralJacobian([&](const Vec3& q) -> Vec3 { return a.act(q); }, p));
  }
}

TEST_CASE("exp and log Jacobians match central differences") {
  std::mt19937 rng(kSeed + 13);
  for (int i = 0; i < kCases; ++i) {
    const Vec3 phi = randomTangent3(rng, i);
    CAPTURE(i);
    CAPTURE(phi.transpose());
    Mat3 J_r;
    SO3::exp(phi, &J_r);
    CHECK_JACOBIAN(J_r, centralJacobian([](const Vec3& t) { return SO3::exp(t); }, phi));
    CHECK(maxAbsDiff(J_r, SO3::rightJacobian(phi)) == 0.0);

    const SO3 a = randomRotation(rng, i);
    if (nearHalfTurn(referenceAngle(a))) continue;  // Log jumps there: no derivative
    Mat3 J_r_inv;
    const Vec3 tau = a.log(&J_r_inv);
    CHECK_JACOBIAN(J_r_inv, centralJacobian([](const SO3& x) -> Vec3 { return x.log(); }, a));
    CHECK(maxAbsDiff(J_r_inv, SO3::rightJacobianInverse(tau)) == 0.0);
  }
}

TEST_CASE("retract and localCoordinates: inverse, x * Exp(tau), Jacobians") {
  std::mt19937 rng(kSeed + 14);
  for (int i = 0; i < kCases; ++i) {
    const SO3 a = randomRotation(rng, i);
    const SO3 b = randomRotation(rng, i + 7);
    const Vec3 tau = randomTangent3(rng, i + 1);
    CAPTURE(i);
    CHECK(rotationDistance(a.retract(a.localCoordinates(b)), b) < 4e-15);
    CHECK(maxAbsDiff(rotationMatrix(a.retract(tau)), rotationMatrix(a) * expMatrix3(tau)) < 1e-14);
    if (tau.norm() < kPi) CHECK(maxAbsDiff(a.localCoordinates(a.retract(tau)), tau) < 1e-13);

    Mat3 J_x_a;
    Mat3 J_x_tau;
    a.retract(tau, &J_x_a, &J_x_tau);
    CHECK_JACOBIAN(J_x_a, centralJacobian([&](const SO3& x) { return x.retract(tau); }, a));
    CHECK_JACOBIAN(J_x_tau, centralJacobian([&](const Vec3& t) { return a.retract(t); }, tau));

    if (nearHalfTurn(referenceAngle(a.between(b)))) continue;
    Mat3 J_t_a;
    Mat3 J_t_b;
    a.localCoordinates(b, &J_t_a, &J_t_b);
    CHECK_JACOBIAN(J_t_a,
                   centralJacobian([&](const SO3& x) -> Vec3 { return x.localCoordinates(b); }, a));
    CHECK_JACOBIAN(J_t_b,
                   centralJacobian([&](const SO3& x) -> Vec3 { return a.localCoordinates(x); }, b));
  }
}

TEST_CASE("asking for Jacobians does not change the results") {
  std::mt19937 rng(kSeed + 15);
  for (int i = 0; i < 90; ++i) {
    const SO3 a = randomRotation(rng, i);
    const SO3 b = randomRotation(rng, i + 1);
    const Vec3 tau = randomTangent3(rng, i);
    const Vec3 p = randomVector(rng, 10.0);
    Mat3 j1;
    Mat3 j2;
    const auto same = [](const SO3& x, const SO3& y) {
      return x.quaternion().coeffs() == y.quaternion().coeffs();
    };
    CHECK(same(a.compose(b, &j1, &j2), a.compose(b)));
    CHECK(same(a.inverse(&j1), a.inverse()));
    CHECK(same(a.between(b, &j1, &j2), a.between(b)));
    CHECK(a.act(p, &j1, &j2) == a.act(p));
    CHECK(same(SO3::exp(tau, &j1), SO3::exp(tau)));
    CHECK(a.log(&j1) == a.log());
    CHECK(same(a.retract(tau, &j1, &j2), a.retract(tau)));
    CHECK(a.localCoordinates(b, &j1, &j2) == a.localCoordinates(b));
    CHECK(a.localCoordinates(b, &j1, nullptr) == a.localCoordinates(b));
    CHECK(a.localCoordinates(b, nullptr, &j2) == a.localCoordinates(b));
  }
}
