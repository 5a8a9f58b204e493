#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "lslam/factors/information.h"
#include "lslam/factors/se2_factors.h"
#include "lslam/geometry/se2.h"
#include "lslam/status.h"
#include "numerical_diff.h"

using lslam::betweenErrorSE2;
using lslam::checkInformation;
using lslam::Mat2;
using lslam::Mat3;
using lslam::priorErrorSE2;
using lslam::SE2;
using lslam::Status;
using lslam::Vec3;
using namespace lslam::test;

namespace {

using Mat6 = Eigen::Matrix<double, 6, 6>;

constexpr int kCases = 900;
constexpr unsigned kSeed = 77031u;

// The g2o error of a residual pose given as a homogeneous matrix: (x, y, theta), not Log.
Vec3 referenceError(const Mat3& residual) {
  return Vec3(residual(0, 2), residual(1, 2), std::atan2(residual(1, 0), residual(0, 0)));
}

// Errors compared with the angle taken modulo 2 pi, so pi and -pi + 1e-17 count as equal.
double errorDistance(const Vec3& a, const Vec3& b) {
  const double angle = std::abs(std::remainder(a(2) - b(2), 2.0 * kPi));
  return std::max((a.head<2>() - b.head<2>()).cwiseAbs().maxCoeff(), angle);
}

// Statuses are compared by name: readable on failure, and doctest cannot stringify the enum
// itself (its unqualified toString() call finds lslam::toString by argument-dependent lookup).
std::string name(Status status) {
  return lslam::toString(status);
}

bool nearCut(double angle) {
  return std::abs(angle) > kPi - 1e-4;
}

}  // namespace

TEST_CASE("betweenErrorSE2 is the g2o error of z^-1 * xi^-1 * xj") {
  std::mt19937 rng(kSeed);
  for (int i = 0; i < kCases; ++i) {
    const SE2 xi = randomPose(rng, i);
    const SE2 xj = randomPose(rng, i + 2);
    const SE2 z = randomPose(rng, i + 5);
    CAPTURE(i);
    const Vec3 e = betweenErrorSE2(xi, xj, z);
    const Mat3 residual = toMatrix(z).inverse() * toMatrix(xi).inverse() * toMatrix(xj);
    CHECK(errorDistance(e, referenceError(residual)) < 1e-12);
    CHECK(e(2) > -kPi);
    CHECK(e(2) <= kPi);

    // A measurement that agrees with the poses leaves no error.
    const SE2 exact = fromMatrix(toMatrix(xi).inverse() * toMatrix(xj));
    CHECK(betweenErrorSE2(xi, xj, exact).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("betweenErrorSE2 on a case worked by hand") {
  // xi faces +y; xj is one metre ahead of it and turned 0.1 rad further left. The measurement
  // says "0.9 m ahead, 0.5 m to the left, no turn".
  const SE2 xi(1.0, 2.0, 0.5 * kPi);
  const SE2 xj(1.0, 3.0, 0.5 * kPi + 0.1);
  const SE2 z(0.9, 0.5, 0.0);
  const Vec3 e = betweenErrorSE2(xi, xj, z);
  CHECK(e(0) == doctest::Approx(0.1).epsilon(1e-12));
  CHECK(e(1) == doctest::Approx(-0.5).epsilon(1e-12));
  CHECK(e(2) == doctest::Approx(0.1).epsilon(1e-12));

  // Rotated measurement: the error is expressed in the measured frame.
  const SE2 zr(1.0, 0.0, 0.5 * kPi);
  const Vec3 er = betweenErrorSE2(xi, xj, zr);
  CHECK(std::abs(er(0)) < 1e-12);
  CHECK(std::abs(er(1)) < 1e-12);
  CHECK(er(2) == doctest::Approx(0.1 - 0.5 * kPi).epsilon(1e-12));
}

TEST_CASE("the error is the g2o vector, not the Lie logarithm") {
  const SE2 xi(0.0, 0.0, 0.0);
  const SE2 xj(2.0, 1.0, 0.8);
  const SE2 z;  // identity: the residual is xj itself
  const Vec3 e = betweenErrorSE2(xi, xj, z);
  CHECK(e(0) == doctest::Approx(2.0).epsilon(1e-15));
  CHECK(e(1) == doctest::Approx(1.0).epsilon(1e-15));
  CHECK(e(2) == doctest::Approx(0.8).epsilon(1e-15));
  const Vec3 lie = logMatrix(toMatrix(xj));
  CHECK(std::abs(lie(0) - e(0)) > 0.1);  // the two conventions really differ here
}

TEST_CASE("the angle error wraps across pi") {
  const SE2 xi(0.0, 0.0, 3.0);
  const SE2 xj(0.0, 0.0, -3.0);  // 2 pi - 6 = 0.283 rad further left, across the cut
  const Vec3 e = betweenErrorSE2(xi, xj, SE2());
  CHECK(e(2) == doctest::Approx(2.0 * kPi - 6.0).epsilon(1e-14));
  const Vec3 p = priorErrorSE2(xj, xi);
  CHECK(p(2) == doctest::Approx(2.0 * kPi - 6.0).epsilon(1e-14));
}

TEST_CASE("priorErrorSE2 is the g2o error of z^-1 * x") {
  std::mt19937 rng(kSeed + 1);
  for (int i = 0; i < kCases; ++i) {
    const SE2 x = randomPose(rng, i);
    const SE2 z = randomPose(rng, i + 4);
    CAPTURE(i);
    const Vec3 e = priorErrorSE2(x, z);
    CHECK(errorDistance(e, referenceError(toMatrix(z).inverse() * toMatrix(x))) < 1e-12);
    CHECK(e(2) > -kPi);
    CHECK(e(2) <= kPi);
    CHECK(priorErrorSE2(x, x).cwiseAbs().maxCoeff() == 0.0);
    // A prior is a between factor from the origin.
    CHECK(errorDistance(e, betweenErrorSE2(SE2(), x, z)) < 1e-12);
  }
}

TEST_CASE("betweenErrorSE2 Jacobians match central differences") {
  std::mt19937 rng(kSeed + 2);
  int checked = 0;
  for (int i = 0; i < kCases; ++i) {
    const SE2 xi = randomPose(rng, i);
    const SE2 xj = randomPose(rng, i + 3);
    // Half of the measurements near the truth, as in a converging solve.
    const SE2 z = i % 2 == 0 ? fromMatrix(toMatrix(xi).inverse() * toMatrix(xj) *
                                          expMatrix(0.1 * randomTangent(rng, i)))
                             : randomPose(rng, i + 6);
    CAPTURE(i);
    Mat3 J_e_xi;
    Mat3 J_e_xj;
    const Vec3 e = betweenErrorSE2(xi, xj, z, &J_e_xi, &J_e_xj);
    CHECK(maxAbsDiff(e, betweenErrorSE2(xi, xj, z)) == 0.0);
    if (nearCut(e(2))) continue;  // the wrapped angle jumps by 2 pi there
    ++checked;
    CHECK_JACOBIAN(
        J_e_xi,
        numericalJacobianSE2([&](const SE2& x) -> Vec3 { return betweenErrorSE2(x, xj, z); }, xi));
    CHECK_JACOBIAN(
        J_e_xj,
        numericalJacobianSE2([&](const SE2& x) -> Vec3 { return betweenErrorSE2(xi, x, z); }, xj));
  }
  CHECK(checked > kCases / 2);
}

TEST_CASE("linearizeBetweenSE2 is J^T Omega J and -J^T Omega e of the general products") {
  std::mt19937 rng(kSeed + 4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < kCases; ++i) {
    const SE2 xi = randomPose(rng, i);
    const SE2 xj = randomPose(rng, i + 3);
    const SE2 z = randomPose(rng, i + 6);
    Mat3 a;  // a random symmetric positive definite information
    for (int k = 0; k < 9; ++k) a(k / 3, k % 3) = u(rng);
    const Mat3 omega = a * a.transpose() + 0.1 * Mat3::Identity();
    CAPTURE(i);
    Mat3 j_i;
    Mat3 j_j;
    const Vec3 e = betweenErrorSE2(xi, xj, z, &j_i, &j_j);
    Mat3 ii;
    Mat3 jj;
    Mat3 ji;
    Vec3 eta_i;
    Vec3 eta_j;
    CHECK(lslam::linearizeBetweenSE2(xi, xj, z, omega, &ii, &jj, &ji, &eta_i, &eta_j) == e);
    const double scale = omega.norm() * (1.0 + j_i.norm() * j_i.norm());
    CHECK(maxAbsDiff(ii, Mat3(j_i.transpose() * omega * j_i)) <= 1e-14 * scale);
    CHECK(maxAbsDiff(jj, Mat3(j_j.transpose() * omega * j_j)) <= 1e-14 * scale);
    CHECK(maxAbsDiff(ji, Mat3(j_j.transpose() * omega * j_i)) <= 1e-14 * scale);
    const double scale_e = scale * (1.0 + e.norm());
    CHECK(maxAbsDiff(eta_i, Vec3(-(j_i.transpose() * omega * e))) <= 1e-14 * scale_e);
    CHECK(maxAbsDiff(eta_j, Vec3(-(j_j.transpose() * omega * e))) <= 1e-14 * scale_e);
  }
}

TEST_CASE("priorErrorSE2 Jacobian matches central differences") {
  std::mt19937 rng(kSeed + 3);
  int checked = 0;
  for (int i = 0; i < kCases; ++i) {
    const SE2 x = randomPose(rng, i);
    const SE2 z = i % 2 == 0 ? fromMatrix(toMatrix(x) * expMatrix(0.1 * randomTangent(rng, i)))
                             : randomPose(rng, i + 5);
    CAPTURE(i);
    Mat3 J_e_x;
    const Vec3 e = priorErrorSE2(x, z, &J_e_x);
    CHECK(maxAbsDiff(e, priorErrorSE2(x, z)) == 0.0);
    if (nearCut(e(2))) continue;
    ++checked;
    CHECK_JACOBIAN(
        J_e_x, numericalJacobianSE2([&](const SE2& p) -> Vec3 { return priorErrorSE2(p, z); }, x));
  }
  CHECK(checked > kCases / 2);
}

TEST_CASE("checkInformation accepts symmetric positive definite matrices") {
  std::mt19937 rng(kSeed + 4);
  std::uniform_real_distribution<double> entry(-1.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    Mat3 a;
    for (int k = 0; k < 9; ++k) a(k) = entry(rng);
    const double scale = std::pow(10.0, (i % 13) - 6);  // 1e-6 .. 1e6
    const Mat3 information = scale * (a * a.transpose() + 0.1 * Mat3::Identity());
    CAPTURE(i);
    CHECK(name(checkInformation(information)) == name(Status::Ok));
  }
  CHECK(name(checkInformation(Mat3::Identity())) == name(Status::Ok));
  Mat3 typical = Mat3::Zero();
  typical.diagonal() << 500.0, 500.0, 5000.0;  // a typical g2o odometry information
  CHECK(name(checkInformation(typical)) == name(Status::Ok));
  CHECK(name(checkInformation(Mat2::Identity())) == name(Status::Ok));
  CHECK(name(checkInformation(Mat6::Identity())) == name(Status::Ok));

  // Asymmetry from rounding, far below the relative tolerance, is accepted.
  Mat3 rounded = 1e8 * Mat3::Identity();
  rounded(0, 1) = 1e-3;
  rounded(1, 0) = 1e-3 + 1e-6;
  CHECK(name(checkInformation(rounded)) == name(Status::Ok));
}

TEST_CASE("checkInformation rejects non-symmetric, indefinite, zero and singular matrices") {
  Mat3 asymmetric = Mat3::Identity();
  asymmetric(0, 2) = 0.1;
  CHECK(name(checkInformation(asymmetric)) == name(Status::InformationNotPositiveDefinite));
  // Just above the 1e-9 relative tolerance, on a large matrix.
  Mat3 barely = 1e6 * Mat3::Identity();
  barely(2, 1) = 1.0;
  barely(1, 2) = 1.0 + 2e-3;
  CHECK(name(checkInformation(barely)) == name(Status::InformationNotPositiveDefinite));

  Mat3 indefinite = Mat3::Identity();
  indefinite(1, 1) = -1.0;
  CHECK(name(checkInformation(indefinite)) == name(Status::InformationNotPositiveDefinite));
  CHECK(name(checkInformation(Mat3(-Mat3::Identity()))) ==
        name(Status::InformationNotPositiveDefinite));
  Mat3 coupled;  // positive diagonal, but the off-diagonal coupling makes it indefinite
  coupled << 1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0;
  CHECK(name(checkInformation(coupled)) == name(Status::InformationNotPositiveDefinite));

  CHECK(name(checkInformation(Mat3::Zero())) == name(Status::InformationNotPositiveDefinite));
  Mat3 singular = Mat3::Identity();
  singular(2, 2) = 0.0;
  CHECK(name(checkInformation(singular)) == name(Status::InformationNotPositiveDefinite));
  Mat3 rank_one = Vec3(1.0, 2.0, 3.0) * Vec3(1.0, 2.0, 3.0).transpose();
  CHECK(name(checkInformation(rank_one)) == name(Status::InformationNotPositiveDefinite));
  // Finite and indefinite (its 2x2 minor on x, theta is 1e-300 - 1e600 < 0), but the elimination
  // overflows: 1 - 1e300 * 1e300 / 1e-300 is -inf, its square root NaN, a pivot Eigen's LLT lets
  // through. The reference: the determinant's sign, of the same minor computed as its products.
  Mat3 overflowing;
  overflowing << 1e-300, 0.0, 1e300, 0.0, 1.0, 0.0, 1e300, 0.0, 1.0;
  REQUIRE(overflowing(0, 0) * overflowing(2, 2) < overflowing(0, 2) * overflowing(2, 0));
  CHECK(name(checkInformation(overflowing)) == name(Status::InformationNotPositiveDefinite));

  Mat2 asymmetric2 = Mat2::Identity();
  asymmetric2(1, 0) = 0.5;
  CHECK(name(checkInformation(asymmetric2)) == name(Status::InformationNotPositiveDefinite));
  CHECK(name(checkInformation(Mat2(-Mat2::Identity()))) ==
        name(Status::InformationNotPositiveDefinite));
  Mat6 indefinite6 = Mat6::Identity();
  indefinite6(5, 5) = -1e-3;
  CHECK(name(checkInformation(indefinite6)) == name(Status::InformationNotPositiveDefinite));
}

namespace {

// Positive definiteness of a symmetric 3x3 matrix, by a route that cannot overflow: it is invariant
// under the congruence D M D with D = diag(1 / sqrt(M(i,i))), which gives the unit-diagonal matrix
// C of correlations c(i,j) = M(i,j) / sqrt(M(i,i)) / sqrt(M(i,i)); C is positive definite iff every
// |c| < 1 and det C = 1 + 2 c01 c02 c12 - c01^2 - c02^2 - c12^2 > 0 (Sylvester). Returns -1 when
// the case is too close to the boundary for either computation to be trusted.
int referencePositiveDefinite(const Mat3& m) {
  for (int i = 0; i < 3; ++i) {
    if (!(m(i, i) > 0.0)) return 0;
  }
  const auto c = [&](int i, int j) { return m(i, j) / std::sqrt(m(i, i)) / std::sqrt(m(j, j)); };
  const double c01 = c(0, 1), c02 = c(0, 2), c12 = c(1, 2);
  for (const double x : {c01, c02, c12}) {
    if (std::abs(x) > 1.0 + 1e-9) return 0;
    if (std::abs(x) >= 1.0 - 1e-9) return -1;
  }
  const double det = 1.0 + 2.0 * c01 * c02 * c12 - c01 * c01 - c02 * c02 - c12 * c12;
  if (std::abs(det) < 1e-9) return -1;
  return det > 0.0 ? 1 : 0;
}

}  // namespace

TEST_CASE("checkInformation agrees with a scale-free reference over 1e-300 .. 1e300") {
  // Diagonals spread over 600 decades, correlations mostly in (-1.5, 1.5), one in ten up to 1e300
  // and one in ten exactly 0: the matrices that a direct elimination over- or underflows on are
  // the point (inf * 0 in an elimination gives a NaN pivot, which must not pass as definite).
  std::mt19937 rng(2026);
  std::uniform_real_distribution<double> exponent(-300.0, 300.0);
  std::uniform_real_distribution<double> correlation(-1.5, 1.5);
  std::uniform_real_distribution<double> huge_exponent(0.0, 300.0);
  std::uniform_int_distribution<int> one_in_ten(0, 9);
  int definite = 0, indefinite = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    Vec3 sd;
    for (int i = 0; i < 3; ++i) sd(i) = std::pow(10.0, exponent(rng) / 2.0);
    Mat3 m;
    for (int i = 0; i < 3; ++i) {
      m(i, i) = sd(i) * sd(i);
      for (int j = i + 1; j < 3; ++j) {
        const int kind = one_in_ten(rng);
        const double c = kind == 0   ? std::pow(10.0, huge_exponent(rng))
                         : kind == 1 ? 0.0
                                     : correlation(rng);
        m(i, j) = m(j, i) = c * sd(i) * sd(j);
      }
    }
    if (!m.allFinite()) continue;
    const int expected = referencePositiveDefinite(m);
    if (expected < 0) continue;
    CAPTURE(trial);
    CAPTURE(m);
    const Status got = checkInformation(m);
    CHECK(name(got) == name(expected == 1 ? Status::Ok : Status::InformationNotPositiveDefinite));
    (expected == 1 ? definite : indefinite) += 1;
  }
  CHECK(definite > 1000);  // both kinds were exercised
  CHECK(indefinite > 1000);
}

TEST_CASE("checkInformation reports NaN and Inf in any entry as non-finite input") {
  const double bad[] = {std::numeric_limits<double>::quiet_NaN(),
                        std::numeric_limits<double>::infinity(),
                        -std::numeric_limits<double>::infinity()};
  for (double value : bad) {
    for (int k = 0; k < 9; ++k) {
      Mat3 information = Mat3::Identity();
      information(k) = value;
      CAPTURE(k);
      CHECK(name(checkInformation(information)) == name(Status::NonFiniteInput));
    }
    Mat3 symmetric_bad = Mat3::Identity();  // non-finite wins over any other complaint
    symmetric_bad(0, 1) = value;
    symmetric_bad(1, 0) = value;
    CHECK(name(checkInformation(symmetric_bad)) == name(Status::NonFiniteInput));
    Mat2 information2 = Mat2::Identity();
    information2(1, 1) = value;
    CHECK(name(checkInformation(information2)) == name(Status::NonFiniteInput));
    Mat6 information6 = Mat6::Identity();
    information6(4, 2) = value;
    CHECK(name(checkInformation(information6)) == name(Status::NonFiniteInput));
  }
}
