// Point2 / Point3, the landmark variable kinds: sizes, retract and localCoordinates against
// coordinate-wise arithmetic written out here, and their Jacobians against central differences.
#include <doctest/doctest.h>

#include <random>

#include "lie_3d_test_util.h"
#include "lslam/geometry/point.h"
#include "lslam/geometry/se2.h"
#include "lslam/geometry/se3.h"
#include "numerical_diff.h"

using lslam::Mat2;
using lslam::Mat3;
using lslam::Point2;
using lslam::Point3;
using lslam::SE2;
using lslam::SE3;
using lslam::Vec2;
using lslam::Vec3;
using namespace lslam::test;

namespace {

constexpr int kCases = 500;
constexpr unsigned kSeed = 4242u;

Vec2 randomVector2(std::mt19937& rng, double half_width) {
  std::uniform_real_distribution<double> coordinate(-half_width, half_width);
  const double x = coordinate(rng);
  const double y = coordinate(rng);
  return Vec2(x, y);
}

// Every variable kind's size, read through the type as a generic model would.
template <class X>
int dofOf() {
  return X::kDof;
}

}  // namespace

TEST_CASE("every variable kind exposes its tangent size as X::kDof") {
  CHECK(dofOf<Point2>() == 2);
  CHECK(dofOf<Point3>() == 3);
  CHECK(dofOf<SE2>() == 3);
  CHECK(dofOf<SE3>() == 6);
}

TEST_CASE("Point2 and Point3 store their coordinates; the default is the origin") {
  const Point2 p(1.5, -2.0);
  CHECK(p.x() == 1.5);
  CHECK(p.y() == -2.0);
  CHECK(p.vector()(0) == 1.5);
  CHECK(p.vector()(1) == -2.0);
  const Point2 q(Vec2(3.0, 4.0));
  CHECK(q.x() == 3.0);
  CHECK(q.y() == 4.0);
  const Point2 origin2;
  CHECK(origin2.x() == 0.0);
  CHECK(origin2.y() == 0.0);

  const Point3 a(1.0, -2.0, 3.5);
  CHECK(a.x() == 1.0);
  CHECK(a.y() == -2.0);
  CHECK(a.z() == 3.5);
  CHECK(a.vector()(2) == 3.5);
  const Point3 b(Vec3(-1.0, 0.25, 7.0));
  CHECK(b.x() == -1.0);
  CHECK(b.y() == 0.25);
  CHECK(b.z() == 7.0);
  const Point3 origin3;
  CHECK(origin3.vector().cwiseAbs().maxCoeff() == 0.0);
}

TEST_CASE("Point2 retract adds and localCoordinates subtracts, coordinate by coordinate") {
  std::mt19937 rng(kSeed);
  for (int i = 0; i < kCases; ++i) {
    const Vec2 pa = randomVector2(rng, 100.0);
    const Vec2 pb = randomVector2(rng, 100.0);
    const Vec2 tau = randomVector2(rng, 5.0);
    const Point2 a(pa(0), pa(1));
    const Point2 b(pb(0), pb(1));
    CAPTURE(i);
    const Point2 moved = a.retract(tau);
    CHECK(moved.x() == pa(0) + tau(0));
    CHECK(moved.y() == pa(1) + tau(1));
    const Vec2 t = a.localCoordinates(b);
    CHECK(t(0) == pb(0) - pa(0));
    CHECK(t(1) == pb(1) - pa(1));
    // The two are inverses of each other.
    CHECK(maxAbsDiff(a.retract(a.localCoordinates(b)).vector(), pb) < 1e-13);
    CHECK(maxAbsDiff(a.localCoordinates(a.retract(tau)), tau) < 1e-13);
  }
}

TEST_CASE("Point3 retract adds and localCoordinates subtracts, coordinate by coordinate") {
  std::mt19937 rng(kSeed + 1);
  for (int i = 0; i < kCases; ++i) {
    const Vec3 pa = randomVector(rng, 100.0);
    const Vec3 pb = randomVector(rng, 100.0);
    const Vec3 tau = randomVector(rng, 5.0);
    const Point3 a(pa(0), pa(1), pa(2));
    const Point3 b(pb(0), pb(1), pb(2));
    CAPTURE(i);
    const Point3 moved = a.retract(tau);
    CHECK(moved.x() == pa(0) + tau(0));
    CHECK(moved.y() == pa(1) + tau(1));
    CHECK(moved.z() == pa(2) + tau(2));
    const Vec3 t = a.localCoordinates(b);
    CHECK(t(0) == pb(0) - pa(0));
    CHECK(t(1) == pb(1) - pa(1));
    CHECK(t(2) == pb(2) - pa(2));
    CHECK(maxAbsDiff(a.retract(a.localCoordinates(b)).vector(), pb) < 1e-13);
    CHECK(maxAbsDiff(a.localCoordinates(a.retract(tau)), tau) < 1e-13);
  }
}

TEST_CASE("Point2 retract and localCoordinates Jacobians match central differences") {
  std::mt19937 rng(kSeed + 2);
  for (int i = 0; i < kCases; ++i) {
    const Vec2 pa = randomVector2(rng, 100.0);
    const Vec2 pb = randomVector2(rng, 100.0);
    const Vec2 tau = randomVector2(rng, 5.0);
    const Point2 a(pa);
    const Point2 b(pb);
    CAPTURE(i);
    Mat2 J_x_a;
    Mat2 J_x_tau;
    const Point2 moved = a.retract(tau, &J_x_a, &J_x_tau);
    CHECK(maxAbsDiff(moved.vector(), a.retract(tau).vector()) == 0.0);
    CHECK_JACOBIAN(J_x_a,
                   centralJacobian(
                       [&](const Vec2& p) -> Vec2 { return Point2(p).retract(tau).vector(); }, pa));
    CHECK_JACOBIAN(J_x_tau, centralJacobian(
                                [&](const Vec2& d) -> Vec2 { return a.retract(d).vector(); }, tau));
    Mat2 J_t_a;
    Mat2 J_t_b;
    const Vec2 t = a.localCoordinates(b, &J_t_a, &J_t_b);
    CHECK(maxAbsDiff(t, a.localCoordinates(b)) == 0.0);
    CHECK_JACOBIAN(
        J_t_a,
        centralJacobian([&](const Vec2& p) -> Vec2 { return Point2(p).localCoordinates(b); }, pa));
    CHECK_JACOBIAN(
        J_t_b,
        centralJacobian([&](const Vec2& p) -> Vec2 { return a.localCoordinates(Point2(p)); }, pb));
  }
}

TEST_CASE("Point3 retract and localCoordinates Jacobians match central differences") {
  std::mt19937 rng(kSeed + 3);
  for (int i = 0; i < kCases; ++i) {
    const Vec3 pa = randomVector(rng, 100.0);
    const Vec3 pb = randomVector(rng, 100.0);
    const Vec3 tau = randomVector(rng, 5.0);
    const Point3 a(pa);
    const Point3 b(pb);
    CAPTURE(i);
    Mat3 J_x_a;
    Mat3 J_x_tau;
    const Point3 moved = a.retract(tau, &J_x_a, &J_x_tau);
    CHECK(maxAbsDiff(moved.vector(), a.retract(tau).vector()) == 0.0);
    CHECK_JACOBIAN(J_x_a,
                   centralJacobian(
                       [&](const Vec3& p) -> Vec3 { return Point3(p).retract(tau).vector(); }, pa));
    CHECK_JACOBIAN(J_x_tau, centralJacobian(
                                [&](const Vec3& d) -> Vec3 { return a.retract(d).vector(); }, tau));
    Mat3 J_t_a;
    Mat3 J_t_b;
    const Vec3 t = a.localCoordinates(b, &J_t_a, &J_t_b);
    CHECK(maxAbsDiff(t, a.localCoordinates(b)) == 0.0);
    CHECK_JACOBIAN(
        J_t_a,
        centralJacobian([&](const Vec3& p) -> Vec3 { return Point3(p).localCoordinates(b); }, pa));
    CHECK_JACOBIAN(
        J_t_b,
        centralJacobian([&](const Vec3& p) -> Vec3 { return a.localCoordinates(Point3(p)); }, pb));
  }
}

TEST_CASE("each Jacobian of Point2 and Point3 may be asked for alone") {
  const Point2 a(1.0, 2.0);
  const Point2 b(-3.0, 5.0);
  const Vec2 tau(0.5, -0.25);
  Mat2 only_a = Mat2::Constant(7.0);
  Mat2 only_tau = Mat2::Constant(7.0);
  a.retract(tau, &only_a, nullptr);
  a.retract(tau, nullptr, &only_tau);
  CHECK(maxAbsDiff(only_a, Mat2::Identity()) == 0.0);
  CHECK(maxAbsDiff(only_tau, Mat2::Identity()) == 0.0);
  Mat2 t_a = Mat2::Constant(7.0);
  Mat2 t_b = Mat2::Constant(7.0);
  a.localCoordinates(b, &t_a, nullptr);
  a.localCoordinates(b, nullptr, &t_b);
  CHECK(maxAbsDiff(t_a, -Mat2::Identity()) == 0.0);
  CHECK(maxAbsDiff(t_b, Mat2::Identity()) == 0.0);

  const Point3 c(1.0, 2.0, 3.0);
  const Point3 d(-3.0, 5.0, 0.5);
  Mat3 m = Mat3::Constant(7.0);
  c.localCoordinates(d, &m, nullptr);
  CHECK(maxAbsDiff(m, -Mat3::Identity()) == 0.0);
  m = Mat3::Constant(7.0);
  c.retract(Vec3(1.0, 1.0, 1.0), nullptr, &m);
  CHECK(maxAbsDiff(m, Mat3::Identity()) == 0.0);
}
