// Landmark factors on 2D poses: errors against 3x3 homogeneous matrices built here, Jacobians
// against central differences (the pose perturbed by matrix exponential), the landmark
// initializations, and the input checks.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "lslam/factors/landmark_2d_factors.h"
#include "lslam/geometry/point.h"
#include "lslam/geometry/se2.h"
#include "lslam/status.h"
#include "numerical_diff.h"

using lslam::landmarkFromPointObservationSE2;
using lslam::landmarkFromRangeBearingSE2;
using lslam::Mat2;
using lslam::Mat23;
using lslam::Mat3;
using lslam::Point2;
using lslam::pointObservationErrorSE2;
using lslam::rangeBearingErrorSE2;
using lslam::SE2;
using lslam::Status;
using lslam::validatePointObservationSE2;
using lslam::validateRangeBearingSE2;
using lslam::Vec2;
using lslam::Vec3;
using namespace lslam::test;

namespace {

constexpr int kCases = 900;
constexpr unsigned kSeed = 311207u;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string name(Status status) {
  return lslam::toString(status);
}

// ---- References from homogeneous matrices ----------------------------------------------------

// The landmark in the pose's frame: the first two rows of T^-1 (l, 1).
Vec2 referenceLocal(const SE2& x, const Point2& l) {
  const Vec3 p = toMatrix(x).inverse() * Vec3(l.x(), l.y(), 1.0);
  return p.head<2>();
}

// T (p, 1) for a point p given in the pose's frame.
Vec2 referenceWorld(const SE2& x, const Vec2& p) {
  return (toMatrix(x) * Vec3(p(0), p(1), 1.0)).head<2>();
}

// Angles compared modulo 2 pi, so pi and -pi + 1e-17 count as equal.
double angleDistance(double a, double b) {
  return std::abs(std::remainder(a - b, 2.0 * kPi));
}

// ---- Random cases ----------------------------------------------------------------------------

double uniform(std::mt19937& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

// Distances from the robot: mostly generic, some close (down to 5 cm), some far.
double randomRange(std::mt19937& rng, int case_index) {
  switch (case_index % 5) {
    case 0:
      return uniform(rng, 0.05, 0.5);
    case 1:
      return uniform(rng, 20.0, 100.0);
    default:
      return uniform(rng, 0.5, 20.0);
  }
}

// Directions in the robot frame: generic, straight behind (on the cut of atan2, from both
// sides), straight ahead, and sideways.
double randomDirection(std::mt19937& rng, int case_index) {
  const double u = uniform(rng, 0.0, 1.0);
  switch (case_index % 7) {
    case 0:
      return kPi - 1e-9 * u;
    case 1:
      return -kPi + 1e-9 * u;
    case 2:
      return kPi;
    case 3:
      return 1e-12 * (2.0 * u - 1.0);
    case 4:
      return 0.5 * kPi;
    default:
      return kPi * (2.0 * u - 1.0);
  }
}

// A landmark at a chosen range and direction from x, placed through the homogeneous matrix.
Point2 landmarkNear(std::mt19937& rng, const SE2& x, int case_index) {
  const double r = randomRange(rng, case_index);
  const double a = randomDirection(rng, case_index / 5);
  return Point2(referenceWorld(x, Vec2(r * std::cos(a), r * std::sin(a))));
}

Mat2 randomInformation(std::mt19937& rng) {
  Mat2 a;
  for (int k = 0; k < 4; ++k) a(k) = uniform(rng, -1.0, 1.0);
  return a * a.transpose() + 0.1 * Mat2::Identity();
}

}  // namespace

// ---- Position in the robot frame -------------------------------------------------------------

TEST_CASE("pointObservationErrorSE2 is T^-1 l - z") {
  std::mt19937 rng(kSeed);
  for (int i = 0; i < kCases; ++i) {
    const SE2 x = randomPose(rng, i);
    const Point2 l = landmarkNear(rng, x, i);
    const Vec2 z(uniform(rng, -20.0, 20.0), uniform(rng, -20.0, 20.0));
    CAPTURE(i);
    const Vec2 e = pointObservationErrorSE2(x, l, z);
    CHECK(maxAbsDiff(e, referenceLocal(x, l) - z) < 1e-12);
  }
}

TEST_CASE("pointObservationErrorSE2 on a case worked by hand") {
  // The robot at (1, 2) faces +y; the landmark at (0, 5) is 3 m ahead and 1 m to the right.
  const SE2 x(1.0, 2.0, 0.5 * kPi);
  const Point2 l(2.0, 5.0);
  const Vec2 e = pointObservationErrorSE2(x, l, Vec2(2.5, -1.0));
  CHECK(e(0) == doctest::Approx(0.5).epsilon(1e-14));  // 3 m ahead, measured 2.5 m
  CHECK(std::abs(e(1)) < 1e-15);                       // 1 m to the right, measured so
}

TEST_CASE("pointObservationErrorSE2 Jacobians match central differences") {
  std::mt19937 rng(kSeed + 1);
  for (int i = 0; i < kCases; ++i) {
    const SE2 x = randomPose(rng, i);
    const Point2 l = landmarkNear(rng, x, i);
    const Vec2 z(uniform(rng, -20.0, 20.0), uniform(rng, -20.0, 20.0));
    CAPTURE(i);
    Mat23 J_e_x;
    Mat2 J_e_l;
    const Vec2 e = pointObservationErrorSE2(x, l, z, &J_e_x, &J_e_l);
    CHECK(maxAbsDiff(e, pointObservationErrorSE2(x, l, z)) == 0.0);
    Mat23 only_x;
    Mat2 only_l;
    (void)pointObservationErrorSE2(x, l, z, &only_x, nullptr);
    (void)pointObservationErrorSE2(x, l, z, nullptr, &only_l);
    CHECK(maxAbsDiff(only_x, J_e_x) == 0.0);
    CHECK(maxAbsDiff(only_l, J_e_l) == 0.0);
    CHECK_JACOBIAN(J_e_x,
                   numericalJacobianSE2(
                       [&](const SE2& p) -> Vec2 { return pointObservationErrorSE2(p, l, z); }, x));
    CHECK_JACOBIAN(
        J_e_l, numericalJacobian(
                   [&](const Vec2& p) -> Vec2 { return pointObservationErrorSE2(x, Point2(p), z); },
                   l.vector()));
  }
}

TEST_CASE("landmarkFromPointObservationSE2 is T z and zeroes the error") {
  std::mt19937 rng(kSeed + 2);
  for (int i = 0; i < kCases; ++i) {
    const SE2 x = randomPose(rng, i);
    const Vec2 z(uniform(rng, -30.0, 30.0), uniform(rng, -30.0, 30.0));
    CAPTURE(i);
    const Point2 l = landmarkFromPointObservationSE2(x, z);
    CHECK(maxAbsDiff(l.vector(), referenceWorld(x, z)) < 1e-12);
    CHECK(pointObservationErrorSE2(x, l, z).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("validatePointObservationSE2 checks the measurement and the information") {
  std::mt19937 rng(kSeed + 3);
  for (int i = 0; i < 100; ++i) {
    const Vec2 z(uniform(rng, -1e3, 1e3), uniform(rng, -1e3, 1e3));
    CHECK(name(validatePointObservationSE2(z, randomInformation(rng))) == name(Status::Ok));
  }
  CHECK(name(validatePointObservationSE2(Vec2::Zero(), Mat2::Identity())) == name(Status::Ok));
  const double bad[] = {kNaN, kInf, -kInf};
  for (const double v : bad) {
    for (int k = 0; k < 2; ++k) {
      Vec2 z(1.0, -2.0);
      z(k) = v;
      CAPTURE(k);
      CHECK(name(validatePointObservationSE2(z, Mat2::Identity())) == name(Status::NonFiniteInput));
    }
    Mat2 information = Mat2::Identity();
    information(0, 1) = v;
    CHECK(name(validatePointObservationSE2(Vec2(1.0, 2.0), information)) ==
          name(Status::NonFiniteInput));
  }
  Mat2 indefinite;
  indefinite << 1.0, 2.0, 2.0, 1.0;
  CHECK(name(validatePointObservationSE2(Vec2(1.0, 2.0), indefinite)) ==
        name(Status::InformationNotPositiveDefinite));
  CHECK(name(validatePointObservationSE2(Vec2(1.0, 2.0), Mat2::Zero())) ==
        name(Status::InformationNotPositiveDefinite));
  Mat2 asymmetric;
  asymmetric << 1.0, 0.3, -0.3, 1.0;
  CHECK(name(validatePointObservationSE2(Vec2(1.0, 2.0), asymmetric)) ==
        name(Status::InformationNotPositiveDefinite));
}

// ---- Range and bearing -----------------------------------------------------------------------

TEST_CASE("rangeBearingErrorSE2 is (|T^-1 l| - range, wrapped bearing difference)") {
  std::mt19937 rng(kSeed + 4);
  for (int i = 0; i < kCases; ++i) {
    const SE2 x = randomPose(rng, i);
    const Point2 l = landmarkNear(rng, x, i);
    const Vec2 z(uniform(rng, 0.01, 50.0), uniform(rng, -10.0, 10.0));
    CAPTURE(i);
    const Vec2 e = rangeBearingErrorSE2(x, l, z);
    const Vec2 p = referenceLocal(x, l);
    const double range = std::hypot(p(0), p(1));
    CHECK(std::abs(e(0) - (range - z(0))) < 1e-12 * std::max(1.0, range));
    // The bearing's rounding scales as |t| / range (the landmark's position relative to a
    // distant origin): 1e-14 at 5 cm from a robot 14 m out.
    CHECK(angleDistance(e(1), std::atan2(p(1), p(0)) - z(1)) < 1e-11);
    CHECK(e(1) > -kPi);
    CHECK(e(1) <= kPi);
  }
}

TEST_CASE("rangeBearingErrorSE2 on cases worked by hand") {
  // The robot at (1, 2) faces +y.
  const SE2 x(1.0, 2.0, 0.5 * kPi);
  // 3 m straight ahead, measured 2.5 m at 0.1 rad to the left.
  Vec2 e = rangeBearingErrorSE2(x, Point2(1.0, 5.0), Vec2(2.5, 0.1));
  CHECK(e(0) == doctest::Approx(0.5).epsilon(1e-14));
  CHECK(e(1) == doctest::Approx(-0.1).epsilon(1e-14));
  // 1 m to the left (-x in the world): bearing +pi/2.
  e = rangeBearingErrorSE2(x, Point2(0.0, 2.0), Vec2(1.0, 0.5 * kPi));
  CHECK(std::abs(e(0)) < 1e-15);
  CHECK(std::abs(e(1)) < 1e-15);
  // 2 m behind: bearing pi. Measured as -3.1 rad, the error wraps to pi - (-3.1) - 2 pi.
  e = rangeBearingErrorSE2(x, Point2(1.0, 0.0), Vec2(2.0, -3.1));
  CHECK(std::abs(e(0)) < 1e-15);
  CHECK(e(1) == doctest::Approx(kPi - 2.0 * kPi + 3.1).epsilon(1e-13));
  // A measured bearing given beyond 2 pi means the same direction.
  e = rangeBearingErrorSE2(x, Point2(0.0, 2.0), Vec2(1.0, 0.5 * kPi + 4.0 * kPi));
  CHECK(std::abs(e(1)) < 1e-14);
}

TEST_CASE("rangeBearingErrorSE2 Jacobians match central differences") {
  std::mt19937 rng(kSeed + 5);
  int checked = 0;
  int behind = 0;
  for (int i = 0; i < kCases; ++i) {
    const SE2 x = randomPose(rng, i);
    const Point2 l = landmarkNear(rng, x, i);
    const Vec2 p = referenceLocal(x, l);
    // Half of the measurements agree with the landmark up to noise (the wrapped error is then
    // small even where atan2 jumps, straight behind the robot); half are arbitrary.
    const Vec2 z = i % 2 == 0 ? Vec2(std::hypot(p(0), p(1)) + uniform(rng, -0.1, 0.1),
                                     std::atan2(p(1), p(0)) + uniform(rng, -0.1, 0.1))
                              : Vec2(uniform(rng, 0.01, 50.0), uniform(rng, -kPi, kPi));
    CAPTURE(i);
    Mat23 J_e_x;
    Mat2 J_e_l;
    const Vec2 e = rangeBearingErrorSE2(x, l, z, &J_e_x, &J_e_l);
    CHECK(maxAbsDiff(e, rangeBearingErrorSE2(x, l, z)) == 0.0);
    Mat23 only_x;
    Mat2 only_l;
    (void)rangeBearingErrorSE2(x, l, z, &only_x, nullptr);
    (void)rangeBearingErrorSE2(x, l, z, nullptr, &only_l);
    CHECK(maxAbsDiff(only_x, J_e_x) == 0.0);
    CHECK(maxAbsDiff(only_l, J_e_l) == 0.0);
    // Within 1e-4 of the wrap's cut a central difference would straddle the jump.
    if (std::abs(e(1)) > kPi - 1e-4) continue;
    ++checked;
    if (p(0) < 0.0 && std::abs(p(1)) < 1e-6 * std::abs(p(0))) ++behind;
    CHECK_JACOBIAN(J_e_x,
                   numericalJacobianSE2(
                       [&](const SE2& q) -> Vec2 { return rangeBearingErrorSE2(q, l, z); }, x));
    CHECK_JACOBIAN(J_e_l,
                   numericalJacobian(
                       [&](const Vec2& q) -> Vec2 { return rangeBearingErrorSE2(x, Point2(q), z); },
                       l.vector()));
  }
  CHECK(checked > kCases * 9 / 10);
  CHECK(behind > kCases / 10);  // the atan2 cut is exercised
}

TEST_CASE("rangeBearingErrorSE2 with the landmark on the robot: finite, zero Jacobians") {
  const SE2 x(3.0, -4.0, 0.7);
  Mat23 J_e_x = Mat23::Constant(7.0);
  Mat2 J_e_l = Mat2::Constant(7.0);
  const Vec2 e = rangeBearingErrorSE2(x, Point2(3.0, -4.0), Vec2(2.0, 0.5), &J_e_x, &J_e_l);
  CHECK(e(0) == -2.0);
  CHECK(e(1) == -0.5);
  CHECK(J_e_x.cwiseAbs().maxCoeff() == 0.0);
  CHECK(J_e_l.cwiseAbs().maxCoeff() == 0.0);
  // Very close but not on it (|d|^2 in the subnormals): finite Jacobians.
  const SE2 origin;
  (void)rangeBearingErrorSE2(origin, Point2(1e-160, 0.0), Vec2(1.0, 0.0), &J_e_x, &J_e_l);
  CHECK(J_e_x.allFinite());
  CHECK(J_e_l.allFinite());
  // |d|^2 = 1e-320 keeps about four digits.
  CHECK(J_e_x(0, 0) == doctest::Approx(-1.0).epsilon(1e-3));
  CHECK(J_e_l(1, 1) == doctest::Approx(1e160).epsilon(1e-3));
}

TEST_CASE("landmarkFromRangeBearingSE2 is T (r cos b, r sin b) and zeroes the error") {
  std::mt19937 rng(kSeed + 6);
  for (int i = 0; i < kCases; ++i) {
    const SE2 x = randomPose(rng, i);
    const double r = randomRange(rng, i);
    const double b = i % 3 == 0 ? randomDirection(rng, i) : uniform(rng, -10.0, 10.0);
    CAPTURE(i);
    const Point2 l = landmarkFromRangeBearingSE2(x, Vec2(r, b));
    CHECK(maxAbsDiff(l.vector(), referenceWorld(x, Vec2(r * std::cos(b), r * std::sin(b)))) <
          1e-12 * std::max(1.0, r));
    const Vec2 e = rangeBearingErrorSE2(x, l, Vec2(r, b));
    CHECK(std::abs(e(0)) < 1e-12 * std::max(1.0, r));
    CHECK(std::abs(e(1)) < 1e-11);
  }
}

TEST_CASE("validateRangeBearingSE2 rejects non-finite input and ranges that are not positive") {
  std::mt19937 rng(kSeed + 7);
  for (int i = 0; i < 100; ++i) {
    const Vec2 z(uniform(rng, 1e-6, 1e3), uniform(rng, -10.0, 10.0));
    CHECK(name(validateRangeBearingSE2(z, randomInformation(rng))) == name(Status::Ok));
  }
  const double tiny = std::numeric_limits<double>::denorm_min();
  CHECK(name(validateRangeBearingSE2(Vec2(tiny, 0.0), Mat2::Identity())) == name(Status::Ok));

  const double bad[] = {kNaN, kInf, -kInf};
  for (const double v : bad) {
    for (int k = 0; k < 2; ++k) {
      Vec2 z(1.0, 0.5);
      z(k) = v;
      CAPTURE(k);
      CHECK(name(validateRangeBearingSE2(z, Mat2::Identity())) == name(Status::NonFiniteInput));
    }
    Mat2 information = Mat2::Identity();
    information(1, 1) = v;
    CHECK(name(validateRangeBearingSE2(Vec2(1.0, 0.5), information)) ==
          name(Status::NonFiniteInput));
  }
  CHECK(name(validateRangeBearingSE2(Vec2(-1.0, 0.5), Mat2::Identity())) ==
        name(Status::InvalidArgument));
  CHECK(name(validateRangeBearingSE2(Vec2(-tiny, 0.5), Mat2::Identity())) ==
        name(Status::InvalidArgument));
  CHECK(name(validateRangeBearingSE2(Vec2(0.0, 0.5), Mat2::Identity())) ==
        name(Status::InvalidArgument));
  CHECK(name(validateRangeBearingSE2(Vec2(-0.0, 0.5), Mat2::Identity())) ==
        name(Status::InvalidArgument));

  Mat2 indefinite;
  indefinite << 1.0, 2.0, 2.0, 1.0;
  CHECK(name(validateRangeBearingSE2(Vec2(1.0, 0.5), indefinite)) ==
        name(Status::InformationNotPositiveDefinite));
  Mat2 negative = -Mat2::Identity();
  CHECK(name(validateRangeBearingSE2(Vec2(1.0, 0.5), negative)) ==
        name(Status::InformationNotPositiveDefinite));
}
