// The models' compile-time lists: block sizes, kind indices, the run-time dispatch over a list,
// and that every factor kind of both models has the shape the solver relies on (its variables,
// error dimension, error, Jacobians and input check) with consistent sizes.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <type_traits>

#include "lslam/factors/landmark_2d_factors.h"
#include "lslam/factors/point_observation_3d.h"
#include "lslam/factors/point_priors.h"
#include "lslam/factors/se2_factors.h"
#include "lslam/factors/se3_factors.h"
#include "lslam/geometry/coordinate_range.h"
#include "lslam/models/model_traits.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"

namespace {

using lslam::Slam2D;
using lslam::Slam3D;

static_assert(std::is_same_v<lslam::ModelBlockSizes<Slam2D>, lslam::BlockSizes<3, 2>>);
static_assert(std::is_same_v<lslam::ModelBlockSizes<Slam3D>, lslam::BlockSizes<6, 3>>);
static_assert(lslam::kVariableKind<Slam2D, lslam::Point2> == 1);
static_assert(lslam::kFactorKind<Slam3D, lslam::PointObservationSE3Factor> == 3);
static_assert(lslam::BlockSizes<6, 3>::kMax == 6 && !lslam::BlockSizes<6, 3>::kUniform);
static_assert(lslam::BlockSizes<3>::kUniform && lslam::BlockSizes<3, 2>::sizeOfKind(1) == 2);

// The error of every factor kind, its Jacobians' sizes (error dimension x variable size) and its
// input check, at the identity/origin: a kind whose declared sizes disagree does not compile.
template <class F>
void checkFactorShape() {
  using Error = Eigen::Matrix<double, F::kErrorDim, 1>;
  using Information = Eigen::Matrix<double, F::kErrorDim, F::kErrorDim>;
  using A = lslam::TypeAtT<0, typename F::Variables>;
  typename F::Measurement z{};
  using Z = typename F::Measurement;
  if constexpr (std::is_base_of_v<Eigen::MatrixBase<Z>, Z>) z.setOnes();  // a valid range too
  Eigen::Matrix<double, F::kErrorDim, A::kDof> j_a;
  Error e;
  if constexpr (F::Variables::kSize == 1) {
    e = F::error(A{}, z, &j_a);
  } else {
    using B = lslam::TypeAtT<1, typename F::Variables>;
    Eigen::Matrix<double, F::kErrorDim, B::kDof> j_b;
    e = F::error(A{}, B{}, z, &j_a, &j_b);
    CHECK(j_b.allFinite());
  }
  CHECK(e.allFinite());
  CHECK(j_a.allFinite());
  CHECK(F::validate(z, Information::Identity()) == lslam::Status::Ok);
  CHECK(F::validate(z, -Information::Identity()) == lslam::Status::InformationNotPositiveDefinite);
}

template <class Model>
void checkEveryFactor() {
  int visited = 0;
  for (int kind = 0; kind < Model::Factors::kSize; ++kind) {
    CHECK(lslam::visitKind<typename Model::Factors>(kind, [&](auto* tag) {
      using F = std::remove_pointer_t<decltype(tag)>;
      CHECK(lslam::kFactorKind<Model, F> == kind);
      checkFactorShape<F>();
      ++visited;
    }));
  }
  CHECK(visited == Model::Factors::kSize);
  CHECK_FALSE(lslam::visitKind<typename Model::Factors>(Model::Factors::kSize, [](auto*) {}));
  CHECK_FALSE(lslam::visitKind<typename Model::Factors>(-1, [](auto*) {}));
}

TEST_CASE("every factor kind of the 2D and 3D models has a consistent shape") {
  checkEveryFactor<Slam2D>();
  checkEveryFactor<Slam3D>();
}

TEST_CASE("withSize turns each size of a list into its compile-time constant") {
  for (int size : {3, 2}) {
    int seen = 0;
    lslam::withSize<3, 2>(size, [&](auto s) { seen = decltype(s)::value; });
    CHECK(seen == size);
  }
  int calls = 0;
  lslam::withSize<6, 3>(5, [&](auto) { ++calls; });
  CHECK(calls == 0);
}

}  // namespace

namespace {

TEST_CASE("validateValue rejects what no variable kind can hold") {
  using lslam::Status;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK(lslam::validateValue(lslam::SE2(1.0, 2.0, 0.5)) == Status::Ok);
  CHECK(lslam::validateValue(lslam::SE2(nan, 2.0, 0.5)) == Status::NonFiniteInput);
  CHECK(lslam::validateValue(lslam::Point2(1.0, 2.0)) == Status::Ok);
  CHECK(lslam::validateValue(lslam::Point3(1.0, nan, 2.0)) == Status::NonFiniteInput);
  const Eigen::Quaterniond unit(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()));
  CHECK(lslam::validateValue(lslam::SE3(lslam::SO3(unit), lslam::Vec3(1, 2, 3))) == Status::Ok);
  const Eigen::Quaterniond long_q(1.0, 0.1, 0.0, 0.0);  // |q| = 1.005
  CHECK(lslam::validateValue(lslam::SE3(lslam::SO3(long_q), lslam::Vec3::Zero())) ==
        Status::InvalidArgument);
  CHECK(lslam::validateValue(lslam::SE3(lslam::SO3(unit), lslam::Vec3(0, nan, 0))) ==
        Status::NonFiniteInput);
  const Eigen::Quaterniond nan_q(nan, 0.0, 0.0, 0.0);
  CHECK(lslam::validateValue(lslam::SE3(lslam::SO3(nan_q), lslam::Vec3::Zero())) ==
        Status::NonFiniteInput);
  // A measurement goes through the same check inside its factor kind's validate.
  CHECK(lslam::BetweenSE3Factor::validate(lslam::SE3(lslam::SO3(long_q), lslam::Vec3::Zero()),
                                          lslam::Mat6::Identity()) == Status::InvalidArgument);
}

TEST_CASE("validateValue and the factors' checks bound every position coordinate") {
  using lslam::Status;
  constexpr double kMax = lslam::kMaxCoordinate;
  const double inf = std::numeric_limits<double>::infinity();
  const double beyond = std::nextafter(kMax, inf);
  const lslam::SO3 unit;
  const lslam::Mat2 i2 = lslam::Mat2::Identity();
  const lslam::Mat3 i3 = lslam::Mat3::Identity();
  // At the bound, each sign, each coordinate: accepted; one ulp beyond: InvalidArgument.
  for (const double sign : {1.0, -1.0}) {
    for (int axis = 0; axis < 3; ++axis) {
      CAPTURE(sign);
      CAPTURE(axis);
      lslam::Vec3 at = lslam::Vec3::Zero();
      lslam::Vec3 past = lslam::Vec3::Zero();
      at[axis] = sign * kMax;
      past[axis] = sign * beyond;
      const bool planar = axis < 2;
      if (planar) {
        CHECK(lslam::validateValue(lslam::SE2(at.x(), at.y(), 0.0)) == Status::Ok);
        CHECK(lslam::validateValue(lslam::SE2(past.x(), past.y(), 0.0)) == Status::InvalidArgument);
        CHECK(lslam::validateValue(lslam::Point2(at.head<2>())) == Status::Ok);
        CHECK(lslam::validateValue(lslam::Point2(past.head<2>())) == Status::InvalidArgument);
        CHECK(lslam::validatePointObservationSE2(at.head<2>(), i2) == Status::Ok);
        CHECK(lslam::validatePointObservationSE2(past.head<2>(), i2) == Status::InvalidArgument);
        CHECK(lslam::validatePriorPoint2(lslam::Point2(past.head<2>()), i2) ==
              Status::InvalidArgument);
        CHECK(lslam::BetweenSE2Factor::validate(lslam::SE2(past.x(), past.y(), 0.0), i3) ==
              Status::InvalidArgument);
      }
      CHECK(lslam::validateValue(lslam::SE3(unit, at)) == Status::Ok);
      CHECK(lslam::validateValue(lslam::SE3(unit, past)) == Status::InvalidArgument);
      CHECK(lslam::validateValue(lslam::Point3(at)) == Status::Ok);
      CHECK(lslam::validateValue(lslam::Point3(past)) == Status::InvalidArgument);
      CHECK(lslam::validatePointObservationSE3(at, i3) == Status::Ok);
      CHECK(lslam::validatePointObservationSE3(past, i3) == Status::InvalidArgument);
      CHECK(lslam::validatePriorPoint3(lslam::Point3(past), i3) == Status::InvalidArgument);
      CHECK(lslam::BetweenSE3Factor::validate(lslam::SE3(unit, past), lslam::Mat6::Identity()) ==
            Status::InvalidArgument);
    }
  }
  // An angle is only wrapped, not bounded; a range is a distance, bounded as a coordinate.
  CHECK(lslam::validateValue(lslam::SE2(0.0, 0.0, 1e300)) == Status::Ok);
  CHECK(lslam::validateRangeBearingSE2(lslam::Vec2(kMax, 0.5), i2) == Status::Ok);
  CHECK(lslam::validateRangeBearingSE2(lslam::Vec2(beyond, 0.5), i2) == Status::InvalidArgument);
  // Non-finite stays NonFiniteInput, also next to a coordinate beyond the bound.
  CHECK(lslam::validateValue(lslam::SE3(unit, lslam::Vec3(2.0 * kMax, inf, 0.0))) ==
        Status::NonFiniteInput);
  CHECK(lslam::validateValue(lslam::Point2(2.0 * kMax, -inf)) == Status::NonFiniteInput);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  CHECK(lslam::validateValue(lslam::SE2(2.0 * kMax, 0.0, nan)) == Status::NonFiniteInput);
  CHECK(lslam::validateRangeBearingSE2(lslam::Vec2(2.0 * kMax, nan), i2) == Status::NonFiniteInput);
  CHECK(lslam::validatePointObservationSE2(lslam::Vec2(nan, 2.0 * kMax), i2) ==
        Status::NonFiniteInput);
  CHECK(lslam::validatePointObservationSE3(lslam::Vec3(2.0 * kMax, 0.0, inf), i3) ==
        Status::NonFiniteInput);
}

}  // namespace
