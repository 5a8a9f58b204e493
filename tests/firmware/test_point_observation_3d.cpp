// The 3D point observation factor: the error against 4x4 homogeneous matrices built here,
// Jacobians against central differences (the pose perturbed by matrix exponential), the
// landmark initialization, and the input checks.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "lie_3d_test_util.h"
#include "lslam/factors/point_observation_3d.h"
#include "lslam/geometry/point.h"
#include "lslam/geometry/se3.h"
#include "lslam/status.h"
#include "numerical_diff.h"

using lslam::landmarkFromPointObservationSE3;
using lslam::Mat3;
using lslam::Mat36;
using lslam::Mat4;
using lslam::Point3;
using lslam::pointObservationErrorSE3;
using lslam::SE3;
using lslam::SO3;
using lslam::Status;
using lslam::validatePointObservationSE3;
using lslam::Vec3;
using namespace lslam::test;
using Quat = Eigen::Quaterniond;

namespace {

constexpr int kCases = 900;
constexpr unsigned kSeed = 5550123u;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string name(Status status) {
  return lslam::toString(status);
}

// ---- References from homogeneous matrices ----------------------------------------------------

// The landmark in the pose's frame: the first three rows of T^-1 (l, 1).
Vec3 referenceLocal(const SE3& x, const Point3& l) {
  const Eigen::Vector4d h(l.x(), l.y(), l.z(), 1.0);
  return (inverseMatrix(poseMatrix(x)) * h).head<3>();
}

// T (p, 1) for a point p given in the pose's frame.
Vec3 referenceWorld(const SE3& x, const Vec3& p) {
  const Eigen::Vector4d h(p(0), p(1), p(2), 1.0);
  return (poseMatrix(x) * h).head<3>();
}

// ---- Random cases ----------------------------------------------------------------------------

// A pose with a random translation and the rotation by randomAngle's regimes (near and at zero,
// near +-pi, generic) about a random axis; the stored quaternion's sign is chosen at random.
SE3 randomPose3(std::mt19937& rng, int case_index) {
  const double angle = randomAngle(rng, case_index);
  const Vec3 t = randomVector(rng, 10.0);
  const Vec3 axis = randomAxis(rng);
  Quat q = angleAxisRotation(angle, axis).quaternion();
  if (std::bernoulli_distribution(0.5)(rng)) q.coeffs() = -q.coeffs();
  return SE3(SO3(q), t);
}

// A landmark at 5 cm to 50 m from the pose, in a random direction.
Point3 landmarkNear(std::mt19937& rng, const SE3& x, int case_index) {
  const double r = case_index % 4 == 0 ? std::uniform_real_distribution<double>(0.05, 0.5)(rng)
                                       : std::uniform_real_distribution<double>(0.5, 50.0)(rng);
  return Point3(referenceWorld(x, r * randomAxis(rng)));
}

Mat3 randomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> entry(-1.0, 1.0);
  Mat3 a;
  for (int k = 0; k < 9; ++k) a(k) = entry(rng);
  return a * a.transpose() + 0.1 * Mat3::Identity();
}

SE3 negatedQuaternion(const SE3& x) {
  Quat q = x.rotation().quaternion();
  q.coeffs() = -q.coeffs();
  return SE3(SO3(q), x.translation());
}

}  // namespace

TEST_CASE("pointObservationErrorSE3 is T^-1 l - z") {
  std::mt19937 rng(kSeed);
  for (int i = 0; i < kCases; ++i) {
    const SE3 x = randomPose3(rng, i);
    const Point3 l = i % 2 == 0 ? landmarkNear(rng, x, i) : Point3(randomVector(rng, 30.0));
    const Vec3 z = randomVector(rng, 20.0);
    CAPTURE(i);
    const Vec3 e = pointObservationErrorSE3(x, l, z);
    CHECK(maxAbsDiff(e, referenceLocal(x, l) - z) < 1e-12);
    // q and -q are the same rotation: the same error.
    CHECK(maxAbsDiff(pointObservationErrorSE3(negatedQuaternion(x), l, z), e) < 1e-14);
  }
}

TEST_CASE("pointObservationErrorSE3 on a case worked by hand") {
  // The robot at (1, 2, 3) turned a quarter turn about z: its x axis is the world's +y. The
  // landmark 2 m along world +y and 1 m up is 2 m ahead and 1 m up in the robot frame.
  const SE3 x(SO3(Quat(Eigen::AngleAxisd(0.5 * kPi, Vec3::UnitZ()))), Vec3(1.0, 2.0, 3.0));
  const Point3 l(1.0, 4.0, 4.0);
  const Vec3 e = pointObservationErrorSE3(x, l, Vec3(2.0, 0.5, 1.0));
  CHECK(std::abs(e(0)) < 1e-15);
  CHECK(e(1) == doctest::Approx(-0.5).epsilon(1e-14));
  CHECK(std::abs(e(2)) < 1e-15);
}

TEST_CASE("pointObservationErrorSE3 Jacobians match central differences") {
  std::mt19937 rng(kSeed + 1);
  int near_half_turn = 0;
  for (int i = 0; i < kCases; ++i) {
    const SE3 x = randomPose3(rng, i);
    const Point3 l = i % 2 == 0 ? landmarkNear(rng, x, i) : Point3(randomVector(rng, 30.0));
    const Vec3 z = randomVector(rng, 20.0);
    CAPTURE(i);
    Mat36 J_e_x;
    Mat3 J_e_l;
    const Vec3 e = pointObservationErrorSE3(x, l, z, &J_e_x, &J_e_l);
    CHECK(maxAbsDiff(e, pointObservationErrorSE3(x, l, z)) == 0.0);
    Mat36 only_x;
    Mat3 only_l;
    (void)pointObservationErrorSE3(x, l, z, &only_x, nullptr);
    (void)pointObservationErrorSE3(x, l, z, nullptr, &only_l);
    CHECK(maxAbsDiff(only_x, J_e_x) == 0.0);
    CHECK(maxAbsDiff(only_l, J_e_l) == 0.0);
    if (nearHalfTurn(referenceAngle(x))) ++near_half_turn;
    CHECK_JACOBIAN(J_e_x,
                   centralJacobian(
                       [&](const SE3& p) -> Vec3 { return pointObservationErrorSE3(p, l, z); }, x));
    CHECK_JACOBIAN(
        J_e_l, centralJacobian(
                   [&](const Vec3& p) -> Vec3 { return pointObservationErrorSE3(x, Point3(p), z); },
                   l.vector()));
  }
  CHECK(near_half_turn > kCases / 10);  // poses rotated by about pi are in the mix
}

TEST_CASE("landmarkFromPointObservationSE3 is T z and zeroes the error") {
  std::mt19937 rng(kSeed + 2);
  for (int i = 0; i < kCases; ++i) {
    const SE3 x = randomPose3(rng, i);
    const Vec3 z = i % 3 == 0 ? 0.05 * randomAxis(rng) : randomVector(rng, 30.0);
    CAPTURE(i);
    const Point3 l = landmarkFromPointObservationSE3(x, z);
    CHECK(maxAbsDiff(l.vector(), referenceWorld(x, z)) < 1e-12);
    CHECK(pointObservationErrorSE3(x, l, z).cwiseAbs().maxCoeff() < 1e-12);
  }
}

TEST_CASE("validatePointObservationSE3 checks the measurement and the information") {
  std::mt19937 rng(kSeed + 3);
  for (int i = 0; i < 100; ++i) {
    const Vec3 z = randomVector(rng, 1e3);
    CHECK(name(validatePointObservationSE3(z, randomInformation(rng))) == name(Status::Ok));
  }
  CHECK(name(validatePointObservationSE3(Vec3::Zero(), Mat3::Identity())) == name(Status::Ok));
  const double bad[] = {kNaN, kInf, -kInf};
  for (const double v : bad) {
    for (int k = 0; k < 3; ++k) {
      Vec3 z(1.0, -2.0, 3.0);
      z(k) = v;
      CAPTURE(k);
      CHECK(name(validatePointObservationSE3(z, Mat3::Identity())) == name(Status::NonFiniteInput));
    }
    Mat3 information = Mat3::Identity();
    information(2, 2) = v;
    CHECK(name(validatePointObservationSE3(Vec3(1.0, 2.0, 3.0), information)) ==
          name(Status::NonFiniteInput));
  }
  Mat3 indefinite;
  indefinite << 1.0, 0.0, 2.0, 0.0, 1.0, 0.0, 2.0, 0.0, 1.0;
  CHECK(name(validatePointObservationSE3(Vec3(1.0, 2.0, 3.0), indefinite)) ==
        name(Status::InformationNotPositiveDefinite));
  Mat3 singular = Mat3::Identity();
  singular(1, 1) = 0.0;
  CHECK(name(validatePointObservationSE3(Vec3(1.0, 2.0, 3.0), singular)) ==
        name(Status::InformationNotPositiveDefinite));
  Mat3 asymmetric = Mat3::Identity();
  asymmetric(0, 1) = 0.5;
  CHECK(name(validatePointObservationSE3(Vec3(1.0, 2.0, 3.0), asymmetric)) ==
        name(Status::InformationNotPositiveDefinite));
}
