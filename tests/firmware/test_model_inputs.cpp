// A model's inputs: every kind of both models round-trips through its fixed-size input, and the
// input check reports each kind of bad input with its status.
#include <doctest/doctest.h>

#include <limits>

#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"
#include "lslam/solver/model_inputs.h"

namespace {

using lslam::Status;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

lslam::SE3 poseAbout(double angle, const lslam::Vec3& axis, const lslam::Vec3& t) {
  return lslam::SE3(lslam::SO3(Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis.normalized()))), t);
}

TEST_CASE("variable inputs round-trip every kind and check their values") {
  using In2 = lslam::ModelVariableInput<lslam::Slam2D>;
  using In3 = lslam::ModelVariableInput<lslam::Slam3D>;
  static_assert(In2::kValueSize == 3 && In3::kValueSize == 7);
  const In2 pose = In2::make(4, lslam::SE2(1.0, -2.0, 3.0));
  CHECK(pose.kind == 0);
  CHECK(pose.get<lslam::SE2>().vector() == lslam::SE2(1.0, -2.0, 3.0).vector());
  CHECK(pose.check() == Status::Ok);
  const In2 point = In2::make(4, lslam::Point2(5.0, 6.0));
  CHECK(point.kind == 1);
  CHECK(point.get<lslam::Point2>().vector() == lslam::Vec2(5.0, 6.0));
  CHECK(In2::make(1, lslam::Point2(kNan, 0.0)).check() == Status::NonFiniteInput);
  CHECK(In2::make(-1, lslam::SE2()).check() == Status::InvalidArgument);
  In2 bad_kind = pose;
  bad_kind.kind = 2;
  CHECK(bad_kind.check() == Status::InvalidArgument);

  const lslam::SE3 x = poseAbout(0.7, lslam::Vec3(1, 2, 3), lslam::Vec3(4, 5, 6));
  const In3 pose3 = In3::make(9, x);
  const lslam::SE3 back = pose3.get<lslam::SE3>();
  CHECK(back.translation() == x.translation());
  CHECK(back.rotation().quaternion().coeffs() == x.rotation().quaternion().coeffs());
  CHECK(pose3.check() == Status::Ok);
  const lslam::SE3 long_q(lslam::SO3(Eigen::Quaterniond(1.0, 0.1, 0.0, 0.0)), lslam::Vec3::Zero());
  CHECK(In3::make(9, long_q).check() == Status::InvalidArgument);
  CHECK(In3::make(2, lslam::Point3(1.0, 2.0, kNan)).check() == Status::NonFiniteInput);
}

TEST_CASE("factor inputs round-trip every kind and check their measurements and information") {
  using F2 = lslam::ModelFactorInput<lslam::Slam2D>;
  using F3 = lslam::ModelFactorInput<lslam::Slam3D>;
  static_assert(F2::kMaxErrorDim == 3 && F3::kMaxErrorDim == 6 && F3::kMeasurementSize == 7);
  const lslam::Mat3 info3 = lslam::Vec3(4.0, 5.0, 6.0).asDiagonal();
  const F2 between = F2::make<lslam::BetweenSE2Factor>(1, 2, lslam::SE2(1.0, 0.0, 0.1), info3);
  CHECK(between.kind == 1);
  CHECK(between.arity() == 2);
  CHECK(between.ids[0] == 1);
  CHECK(between.ids[1] == 2);
  CHECK(between.informationAs<lslam::BetweenSE2Factor>() == info3);
  CHECK(between.measurementAs<lslam::BetweenSE2Factor>().vector() ==
        lslam::SE2(1.0, 0.0, 0.1).vector());
  CHECK(between.check() == Status::Ok);
  // Two poses with one id: one variable, not a between factor.
  CHECK(F2::make<lslam::BetweenSE2Factor>(3, 3, lslam::SE2(), info3).check() ==
        Status::InvalidArgument);
  // Pose 3 and landmark 3 are two variables of two id spaces.
  const lslam::Mat2 info2 = lslam::Mat2::Identity();
  CHECK(F2::make<lslam::PointObservationSE2Factor>(3, 3, lslam::Vec2(1.0, 2.0), info2).check() ==
        Status::Ok);
  CHECK(F2::make<lslam::RangeBearingSE2Factor>(3, 4, lslam::Vec2(0.0, 1.0), info2).check() ==
        Status::InvalidArgument);
  CHECK(F2::make<lslam::PriorPoint2Factor>(7, lslam::Point2(kNan, 1.0), info2).check() ==
        Status::NonFiniteInput);
  const F2 prior = F2::make<lslam::PriorSE2Factor>(5, lslam::SE2(), -info3);
  CHECK(prior.arity() == 1);
  CHECK(prior.ids[1] == 5);
  CHECK(prior.check() == Status::InformationNotPositiveDefinite);
  F2 outside = between;
  outside.kind = 5;
  CHECK(outside.arity() == 0);
  CHECK(outside.check() == Status::InvalidArgument);

  const lslam::Mat6 info6 = lslam::Mat6::Identity() * 3.0;
  const lslam::SE3 z = poseAbout(0.2, lslam::Vec3(0, 0, 1), lslam::Vec3(1, 0, 0));
  const F3 between3 = F3::make<lslam::BetweenSE3Factor>(0, 1, z, info6);
  CHECK(between3.check() == Status::Ok);
  CHECK(between3.informationAs<lslam::BetweenSE3Factor>() == info6);
  const lslam::SE3 long_q(lslam::SO3(Eigen::Quaterniond(1.0, 0.1, 0.0, 0.0)), lslam::Vec3::Zero());
  CHECK(F3::make<lslam::BetweenSE3Factor>(0, 1, long_q, info6).check() == Status::InvalidArgument);
  CHECK(F3::make<lslam::PointObservationSE3Factor>(0, 0, lslam::Vec3(1, 2, 3),
                                                   lslam::Mat3::Identity())
            .check() == Status::Ok);
  CHECK(F3::make<lslam::PointObservationSE3Factor>(-1, 0, lslam::Vec3(1, 2, 3),
                                                   lslam::Mat3::Identity())
            .check() == Status::InvalidArgument);
}

}  // namespace
