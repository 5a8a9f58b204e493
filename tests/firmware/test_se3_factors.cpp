#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "lie_3d_test_util.h"
#include "lslam/factors/se3_factors.h"
#include "lslam/geometry/se3.h"
#include "numerical_diff.h"

using lslam::betweenErrorSE3;
using lslam::linearizeBetweenSE3;
using lslam::Mat3;
using lslam::Mat4;
using lslam::Mat6;
using lslam::priorErrorSE3;
using lslam::SE3;
using lslam::SO3;
using lslam::Vec3;
using lslam::Vec6;
using namespace lslam::test;
using Quat = Eigen::Quaterniond;

namespace {

constexpr int kCases = 900;
constexpr unsigned kSeed = 20261126u;

// ---- References that do not call the factors, SE3's or SO3's operations ---------------------

// The quaternion of a homogeneous matrix's rotation, by Eigen's matrix-to-quaternion conversion,
// with w >= 0.
Quat canonicalQuaternion(const Mat4& m) {
  const Mat3 r = m.topLeftCorner<3, 3>();
  Quat q(r);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  return q;
}

// The g2o error of a residual pose given as a homogeneous matrix.
Vec6 referenceError(const Mat4& residual) {
  Vec6 e;
  e << residual.topRightCorner<3, 1>(), canonicalQuaternion(residual).vec();
  return e;
}

// Errors compared as g2o defines them; within `ambiguous` of a half turn the sign of the
// rotation part is a matter of rounding, so either sign is accepted there.
double errorDistance(const Vec6& e, const Mat4& residual, double ambiguous = 1e-12) {
  const Vec6 reference = referenceError(residual);
  const double direct = maxAbsDiff(e, reference);
  if (canonicalQuaternion(residual).w() > ambiguous) return direct;
  Vec6 flipped = reference;
  flipped.tail<3>() = -flipped.tail<3>();
  return std::min(direct, maxAbsDiff(e, flipped));
}

double chi2(const Vec6& e, const Mat6& information) {
  return e.dot(information * e);
}

// ---- Random cases ---------------------------------------------------------------------------

// A pose with a random translation, the rotation by `angle` about a random axis built by Eigen's
// angle-axis conversion, and the stored quaternion's sign chosen at random (w < 0 is allowed).
SE3 poseWithAngle(std::mt19937& rng, double angle) {
  const Vec3 t = randomVector(rng, 10.0);
  const Vec3 axis = randomAxis(rng);
  Quat q = angleAxisRotation(angle, axis).quaternion();
  if (std::bernoulli_distribution(0.5)(rng)) q.coeffs() = -q.coeffs();
  return SE3(SO3(q), t);
}

SE3 randomPose3(std::mt19937& rng, int case_index) {
  return poseWithAngle(rng, randomAngle(rng, case_index));
}

// Rotation angles of the residual, cycling through: generic; near a half turn on either side
// with |w| = sin(delta/2) in [5e-5, 5e-3] (Jacobians are defined there, and the sign of w flips
// between the two sides); near and at the identity; beyond pi.
double residualAngle(std::mt19937& rng, int case_index) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double delta = 1e-4 + 1e-2 * unit(rng);
  switch (case_index % 8) {
    case 0:
      return kPi * unit(rng);
    case 1:
      return kPi - delta;
    case 2:
      return kPi + delta;
    case 3:
      return 1e-12 * unit(rng);
    case 4:
      return 0.0;
    case 5:
      return 1e-6 * unit(rng);
    case 6:
      return 1e-2 * unit(rng);
    default:
      return kPi + 3.0 * unit(rng);
  }
}

// A measurement z with z^-1 xi^-1 xj = d for a chosen residual d.
SE3 measurementFor(const SE3& xi, const SE3& xj, const SE3& d) {
  return poseFromMatrix(inverseMatrix(poseMatrix(xi)) * poseMatrix(xj) *
                        inverseMatrix(poseMatrix(d)));
}

Mat6 randomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> entry(-1.0, 1.0);
  Mat6 a;
  for (int k = 0; k < 36; ++k) a(k) = entry(rng);
  return a * a.transpose() + 0.1 * Mat6::Identity();
}

// The canonical |w| of the residual, from matrices.
double residualW(const SE3& xi, const SE3& xj, const SE3& z) {
  return canonicalQuaternion(inverseMatrix(poseMatrix(z)) * inverseMatrix(poseMatrix(xi)) *
                             poseMatrix(xj))
      .w();
}

SE3 negatedQuaternion(const SE3& x) {
  Quat q = x.rotation().quaternion();
  q.coeffs() = -q.coeffs();
  return SE3(SO3(q), x.translation());
}

}  // namespace

TEST_CASE("betweenErrorSE3 is the g2o error of z^-1 * xi^-1 * xj") {
  std::mt19937 rng(kSeed);
  for (int i = 0; i < kCases; ++i) {
    const SE3 xi = randomPose3(rng, i);
    const SE3 xj = randomPose3(rng, i + 2);
    const SE3 z = i % 2 == 0 ? randomPose3(rng, i + 5)
                             : measurementFor(xi, xj, poseWithAngle(rng, residualAngle(rng, i)));
    CAPTURE(i);
    const Vec6 e = betweenErrorSE3(xi, xj, z);
    const Mat4 residual =
        inverseMatrix(poseMatrix(z)) * inverseMatrix(poseMatrix(xi)) * poseMatrix(xj);
    CHECK(errorDistance(e, residual) < 1e-12);
    CHECK(e.tail<3>().norm() <= 1.0 + 1e-15);

    // A measurement that agrees with the poses leaves no error.
    const SE3 exact = poseFromMatrix(inverseMatrix(poseMatrix(xi)) * poseMatrix(xj));
    CHECK(betweenErrorSE3(xi, xj, exact).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("priorErrorSE3 is the g2o error of z^-1 * x") {
  std::mt19937 rng(kSeed + 1);
  const SE3 identity;
  for (int i = 0; i < kCases; ++i) {
    const SE3 x = randomPose3(rng, i);
    const SE3 z = i % 2 == 0
                      ? randomPose3(rng, i + 4)
                      : measurementFor(identity, x, poseWithAngle(rng, residualAngle(rng, i)));
    CAPTURE(i);
    const Vec6 e = priorErrorSE3(x, z);
    CHECK(errorDistance(e, inverseMatrix(poseMatrix(z)) * poseMatrix(x)) < 1e-12);
    CHECK(priorErrorSE3(x, x).cwiseAbs().maxCoeff() < 1e-15);
    // A prior is a between factor from the origin.
    CHECK(maxAbsDiff(e, betweenErrorSE3(identity, x, z)) < 1e-13);
  }
}

TEST_CASE("the rotation error is the quaternion vector part with w >= 0, not the rotation vector") {
  const SE3 identity;
  const Vec3 t(1.0, 2.0, 3.0);
  // A rotation by 0.5 rad about z: e = (t, 0, 0, sin(0.25)).
  const SE3 x(SO3(Quat(Eigen::AngleAxisd(0.5, Vec3::UnitZ()))), t);
  const Vec6 e = betweenErrorSE3(identity, x, identity);
  CHECK(maxAbsDiff(e.head<3>(), t) == 0.0);
  CHECK(std::abs(e(3)) < 1e-17);
  CHECK(std::abs(e(4)) < 1e-17);
  CHECK(e(5) == doctest::Approx(std::sin(0.25)).epsilon(1e-15));
  CHECK(std::abs(e(5) - 0.5) > 0.2);  // the two conventions really differ

  // Stored with w < 0: the same rotation, the same error.
  const Vec6 negated = priorErrorSE3(negatedQuaternion(x), identity);
  CHECK(maxAbsDiff(negated, e) == 0.0);

  // Past a half turn, pi + 0.2 about +z is pi - 0.2 about -z: v = (0, 0, -cos(0.1)).
  const SE3 y(SO3(Quat(Eigen::AngleAxisd(kPi + 0.2, Vec3::UnitZ()))), t);
  REQUIRE(y.rotation().quaternion().w() < 0.0);
  const Vec6 ey = priorErrorSE3(y, identity);
  CHECK(ey(5) == doctest::Approx(-std::cos(0.1)).epsilon(1e-15));
  CHECK(std::abs(ey(3)) < 1e-16);
  CHECK(std::abs(ey(4)) < 1e-16);
}

TEST_CASE("the error does not depend on the signs of the stored quaternions") {
  std::mt19937 rng(kSeed + 2);
  for (int i = 0; i < kCases; ++i) {
    const SE3 xi = randomPose3(rng, i);
    const SE3 xj = randomPose3(rng, i + 3);
    const SE3 z = randomPose3(rng, i + 6);
    CAPTURE(i);
    const Vec6 e = betweenErrorSE3(xi, xj, z);
    CHECK(maxAbsDiff(betweenErrorSE3(negatedQuaternion(xi), xj, z), e) < 1e-15);
    CHECK(maxAbsDiff(betweenErrorSE3(xi, negatedQuaternion(xj), z), e) < 1e-15);
    CHECK(maxAbsDiff(betweenErrorSE3(xi, xj, negatedQuaternion(z)), e) < 1e-15);
    CHECK(maxAbsDiff(priorErrorSE3(negatedQuaternion(xi), z), priorErrorSE3(xi, z)) < 1e-15);
  }
}

TEST_CASE("the between error and chi2 are invariant under a change of the world frame") {
  std::mt19937 rng(kSeed + 3);
  for (int i = 0; i < kCases; ++i) {
    const SE3 xi = randomPose3(rng, i);
    const SE3 xj = randomPose3(rng, i + 1);
    const SE3 z = randomPose3(rng, i + 2);
    const SE3 g = randomPose3(rng, i + 4);
    const Mat6 information = randomInformation(rng);
    if (residualW(xi, xj, z) < 1e-9) continue;  // the sign of v is rounding there
    CAPTURE(i);
    const SE3 gxi = poseFromMatrix(poseMatrix(g) * poseMatrix(xi));
    const SE3 gxj = poseFromMatrix(poseMatrix(g) * poseMatrix(xj));
    const Vec6 e = betweenErrorSE3(xi, xj, z);
    const Vec6 moved = betweenErrorSE3(gxi, gxj, z);
    CHECK(maxAbsDiff(moved, e) < 1e-11);
    const double c = chi2(e, information);
    CHECK(std::abs(chi2(moved, information) - c) <= 1e-10 * std::max(1.0, c));
  }
}

TEST_CASE("across a half turn v flips sign, and chi2 without cross terms does not jump") {
  std::mt19937 rng(kSeed + 4);
  const SE3 identity;
  for (int i = 0; i < 200; ++i) {
    const Vec3 axis = randomAxis(rng);
    const Vec3 t = randomVector(rng, 10.0);
    const double delta = std::pow(10.0, -2.0 - (i % 8));  // 1e-2 .. 1e-9
    const SE3 below(SO3(Quat(Eigen::AngleAxisd(kPi - delta, axis))), t);
    const SE3 above(SO3(Quat(Eigen::AngleAxisd(kPi + delta, axis))), t);
    CAPTURE(i);
    const Vec6 e_below = betweenErrorSE3(identity, below, identity);
    const Vec6 e_above = betweenErrorSE3(identity, above, identity);
    CHECK(maxAbsDiff(e_below.head<3>(), e_above.head<3>()) == 0.0);
    CHECK(maxAbsDiff(e_below.tail<3>(), axis * std::cos(0.5 * delta)) < 1e-15);
    CHECK(maxAbsDiff(e_above.tail<3>(), -axis * std::cos(0.5 * delta)) < 1e-15);
    // With no translation-rotation coupling in the information, chi2 is even in v.
    Mat6 information = randomInformation(rng);
    information.topRightCorner<3, 3>().setZero();
    information.bottomLeftCorner<3, 3>().setZero();
    const double c = chi2(e_below, information);
    CHECK(std::abs(chi2(e_above, information) - c) <= 1e-13 * c);
  }
}

TEST_CASE("betweenErrorSE3 Jacobians match central differences") {
  std::mt19937 rng(kSeed + 5);
  int checked = 0;
  int near_half_turn = 0;
  int near_identity = 0;
  for (int i = 0; i < kCases; ++i) {
    const SE3 xi = randomPose3(rng, i);
    const SE3 xj = randomPose3(rng, i + 3);
    const SE3 z = measurementFor(xi, xj, poseWithAngle(rng, residualAngle(rng, i)));
    CAPTURE(i);
    Mat6 J_e_xi;
    Mat6 J_e_xj;
    const Vec6 e = betweenErrorSE3(xi, xj, z, &J_e_xi, &J_e_xj);
    CHECK(maxAbsDiff(e, betweenErrorSE3(xi, xj, z)) == 0.0);
    Mat6 only_xi;
    Mat6 only_xj;
    betweenErrorSE3(xi, xj, z, &only_xi, nullptr);
    betweenErrorSE3(xi, xj, z, nullptr, &only_xj);
    CHECK(maxAbsDiff(only_xi, J_e_xi) == 0.0);
    CHECK(maxAbsDiff(only_xj, J_e_xj) == 0.0);
    const double w = residualW(xi, xj, z);
    if (w < 1e-5) continue;  // the central difference would straddle the jump of v
    ++checked;
    if (w < 1e-2) ++near_half_turn;
    if (w > 1.0 - 1e-4) ++near_identity;
    CHECK_JACOBIAN(
        J_e_xi,
        centralJacobian([&](const SE3& x) -> Vec6 { return betweenErrorSE3(x, xj, z); }, xi));
    CHECK_JACOBIAN(
        J_e_xj,
        centralJacobian([&](const SE3& x) -> Vec6 { return betweenErrorSE3(xi, x, z); }, xj));
  }
  CHECK(checked > kCases * 9 / 10);
  CHECK(near_half_turn > kCases / 5);
  CHECK(near_identity > kCases / 3);
}

TEST_CASE("linearizeBetweenSE3 is J^T Omega J and -J^T Omega e of the general products") {
  std::mt19937 rng(kSeed + 9);
  for (int i = 0; i < kCases; ++i) {
    const SE3 xi = randomPose3(rng, i);
    const SE3 xj = randomPose3(rng, i + 3);
    const SE3 z = measurementFor(xi, xj, poseWithAngle(rng, residualAngle(rng, i)));
    const Mat6 omega = randomInformation(rng);
    CAPTURE(i);
    Mat6 j_i;
    Mat6 j_j;
    const Vec6 e = betweenErrorSE3(xi, xj, z, &j_i, &j_j);
    Mat6 ii;
    Mat6 jj;
    Mat6 ji;
    Vec6 eta_i;
    Vec6 eta_j;
    CHECK(maxAbsDiff(linearizeBetweenSE3(xi, xj, z, omega, &ii, &jj, &ji, &eta_i, &eta_j), e) ==
          0.0);
    const double scale = omega.norm() * (1.0 + j_i.norm() * j_i.norm());
    CHECK(maxAbsDiff(ii, Mat6(j_i.transpose() * omega * j_i)) <= 1e-14 * scale);
    CHECK(maxAbsDiff(jj, Mat6(j_j.transpose() * omega * j_j)) <= 1e-14 * scale);
    CHECK(maxAbsDiff(ji, Mat6(j_j.transpose() * omega * j_i)) <= 1e-14 * scale);
    const double scale_e = scale * (1.0 + e.norm());
    CHECK(maxAbsDiff(eta_i, Vec6(-(j_i.transpose() * omega * e))) <= 1e-14 * scale_e);
    CHECK(maxAbsDiff(eta_j, Vec6(-(j_j.transpose() * omega * e))) <= 1e-14 * scale_e);
  }
}

TEST_CASE("priorErrorSE3 Jacobian matches central differences") {
  std::mt19937 rng(kSeed + 6);
  const SE3 identity;
  int checked = 0;
  int stored_negative = 0;
  for (int i = 0; i < kCases; ++i) {
    const SE3 x = randomPose3(rng, i);
    const SE3 z = i % 3 == 0
                      ? identity  // the residual is x itself, with its stored sign
                      : measurementFor(identity, x, poseWithAngle(rng, residualAngle(rng, i)));
    CAPTURE(i);
    Mat6 J_e_x;
    const Vec6 e = priorErrorSE3(x, z, &J_e_x);
    CHECK(maxAbsDiff(e, priorErrorSE3(x, z)) == 0.0);
    Mat6 J_between;
    betweenErrorSE3(identity, x, z, nullptr, &J_between);
    CHECK(maxAbsDiff(J_between, J_e_x) < 1e-13);
    if (residualW(identity, x, z) < 1e-5) continue;
    ++checked;
    if (z.rotation().quaternion().w() == 1.0 && x.rotation().quaternion().w() < 0.0) {
      ++stored_negative;  // the sign flip inside the error is exercised
    }
    CHECK_JACOBIAN(J_e_x,
                   centralJacobian([&](const SE3& p) -> Vec6 { return priorErrorSE3(p, z); }, x));
  }
  CHECK(checked > kCases * 9 / 10);
  CHECK(stored_negative > kCases / 10);
}
