// Prior factors on point landmarks: e = x - z against coordinate-wise differences, the Jacobian
// against central differences, and the input checks.
#include <doctest/doctest.h>

#include <limits>
#include <random>
#include <string>

#include "lie_3d_test_util.h"
#include "lslam/factors/point_priors.h"
#include "lslam/geometry/point.h"
#include "lslam/status.h"
#include "numerical_diff.h"

using lslam::Mat2;
using lslam::Mat3;
using lslam::Point2;
using lslam::Point3;
using lslam::priorErrorPoint2;
using lslam::priorErrorPoint3;
using lslam::Status;
using lslam::validatePriorPoint2;
using lslam::validatePriorPoint3;
using lslam::Vec2;
using lslam::Vec3;
using namespace lslam::test;

namespace {

constexpr int kCases = 500;
constexpr unsigned kSeed = 90125u;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string name(Status status) {
  return lslam::toString(status);
}

Vec2 randomVector2(std::mt19937& rng, double half_width) {
  std::uniform_real_distribution<double> coordinate(-half_width, half_width);
  const double x = coordinate(rng);
  const double y = coordinate(rng);
  return Vec2(x, y);
}

template <int N>
Eigen::Matrix<double, N, N> randomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> entry(-1.0, 1.0);
  Eigen::Matrix<double, N, N> a;
  for (int k = 0; k < N * N; ++k) a(k) = entry(rng);
  return a * a.transpose() + 0.1 * Eigen::Matrix<double, N, N>::Identity();
}

}  // namespace

TEST_CASE("priorErrorPoint2 is x - z") {
  std::mt19937 rng(kSeed);
  for (int i = 0; i < kCases; ++i) {
    const Vec2 x = randomVector2(rng, 50.0);
    const Vec2 z = randomVector2(rng, 50.0);
    CAPTURE(i);
    const Vec2 e = priorErrorPoint2(Point2(x), Point2(z));
    CHECK(e(0) == x(0) - z(0));
    CHECK(e(1) == x(1) - z(1));
    CHECK(priorErrorPoint2(Point2(x), Point2(x)).cwiseAbs().maxCoeff() == 0.0);
  }
  // By hand: the landmark estimated 1 m east and 2 m south of where the prior puts it.
  const Vec2 e = priorErrorPoint2(Point2(4.0, 1.0), Point2(3.0, 3.0));
  CHECK(e(0) == 1.0);
  CHECK(e(1) == -2.0);
}

TEST_CASE("priorErrorPoint3 is x - z") {
  std::mt19937 rng(kSeed + 1);
  for (int i = 0; i < kCases; ++i) {
    const Vec3 x = randomVector(rng, 50.0);
    const Vec3 z = randomVector(rng, 50.0);
    CAPTURE(i);
    const Vec3 e = priorErrorPoint3(Point3(x), Point3(z));
    CHECK(e(0) == x(0) - z(0));
    CHECK(e(1) == x(1) - z(1));
    CHECK(e(2) == x(2) - z(2));
    CHECK(priorErrorPoint3(Point3(x), Point3(x)).cwiseAbs().maxCoeff() == 0.0);
  }
  const Vec3 e = priorErrorPoint3(Point3(4.0, 1.0, -1.0), Point3(3.0, 3.0, 2.0));
  CHECK(e(0) == 1.0);
  CHECK(e(1) == -2.0);
  CHECK(e(2) == -3.0);
}

TEST_CASE("point prior Jacobians match central differences") {
  std::mt19937 rng(kSeed + 2);
  for (int i = 0; i < kCases; ++i) {
    const Vec2 x2 = randomVector2(rng, 50.0);
    const Vec2 z2 = randomVector2(rng, 50.0);
    const Vec3 x3 = randomVector(rng, 50.0);
    const Vec3 z3 = randomVector(rng, 50.0);
    CAPTURE(i);
    Mat2 J2;
    const Vec2 e2 = priorErrorPoint2(Point2(x2), Point2(z2), &J2);
    CHECK(maxAbsDiff(e2, priorErrorPoint2(Point2(x2), Point2(z2))) == 0.0);
    CHECK_JACOBIAN(
        J2,
        centralJacobian(
            [&](const Vec2& p) -> Vec2 { return priorErrorPoint2(Point2(p), Point2(z2)); }, x2));
    Mat3 J3;
    const Vec3 e3 = priorErrorPoint3(Point3(x3), Point3(z3), &J3);
    CHECK(maxAbsDiff(e3, priorErrorPoint3(Point3(x3), Point3(z3))) == 0.0);
    CHECK_JACOBIAN(
        J3,
        centralJacobian(
            [&](const Vec3& p) -> Vec3 { return priorErrorPoint3(Point3(p), Point3(z3)); }, x3));
  }
}

TEST_CASE("point priors accept finite measurements with positive definite information") {
  std::mt19937 rng(kSeed + 3);
  for (int i = 0; i < 100; ++i) {
    CAPTURE(i);
    const Point2 z2(randomVector2(rng, 1e6));
    const Point3 z3(randomVector(rng, 1e6));
    CHECK(name(validatePriorPoint2(z2, randomInformation<2>(rng))) == name(Status::Ok));
    CHECK(name(validatePriorPoint3(z3, randomInformation<3>(rng))) == name(Status::Ok));
  }
  CHECK(name(validatePriorPoint2(Point2(), Mat2::Identity())) == name(Status::Ok));
  CHECK(name(validatePriorPoint3(Point3(), 1e-4 * Mat3::Identity())) == name(Status::Ok));
}

TEST_CASE("point priors reject NaN or Inf in the measurement") {
  const double bad[] = {kNaN, kInf, -kInf};
  for (const double v : bad) {
    for (int k = 0; k < 2; ++k) {
      Vec2 z(1.0, 2.0);
      z(k) = v;
      CAPTURE(k);
      CHECK(name(validatePriorPoint2(Point2(z), Mat2::Identity())) == name(Status::NonFiniteInput));
    }
    for (int k = 0; k < 3; ++k) {
      Vec3 z(1.0, 2.0, 3.0);
      z(k) = v;
      CAPTURE(k);
      CHECK(name(validatePriorPoint3(Point3(z), Mat3::Identity())) == name(Status::NonFiniteInput));
    }
  }
}

TEST_CASE("point priors reject information that is non-finite or not positive definite") {
  const Point2 z2(1.0, 2.0);
  const Point3 z3(1.0, 2.0, 3.0);
  Mat2 nan2 = Mat2::Identity();
  nan2(1, 1) = kNaN;
  CHECK(name(validatePriorPoint2(z2, nan2)) == name(Status::NonFiniteInput));
  Mat3 inf3 = Mat3::Identity();
  inf3(0, 2) = inf3(2, 0) = kInf;
  CHECK(name(validatePriorPoint3(z3, inf3)) == name(Status::NonFiniteInput));

  CHECK(name(validatePriorPoint2(z2, Mat2::Zero())) ==
        name(Status::InformationNotPositiveDefinite));
  CHECK(name(validatePriorPoint2(z2, Mat2(-Mat2::Identity()))) ==
        name(Status::InformationNotPositiveDefinite));
  Mat2 indefinite2;
  indefinite2 << 1.0, 2.0, 2.0, 1.0;  // eigenvalues 3 and -1
  CHECK(name(validatePriorPoint2(z2, indefinite2)) == name(Status::InformationNotPositiveDefinite));
  Mat2 asymmetric2;
  asymmetric2 << 2.0, 0.5, 0.0, 2.0;
  CHECK(name(validatePriorPoint2(z2, asymmetric2)) == name(Status::InformationNotPositiveDefinite));

  Mat3 singular3 = Mat3::Identity();
  singular3(2, 2) = 0.0;
  CHECK(name(validatePriorPoint3(z3, singular3)) == name(Status::InformationNotPositiveDefinite));
  Mat3 indefinite3;
  indefinite3 << 1.0, 0.0, 2.0, 0.0, 1.0, 0.0, 2.0, 0.0, 1.0;
  CHECK(name(validatePriorPoint3(z3, indefinite3)) == name(Status::InformationNotPositiveDefinite));
}
