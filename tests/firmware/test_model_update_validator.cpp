// The checks before a model's update: statuses for bad inputs, capacities per kind, ids per id
// space, and the rule that every added variable is held (a landmark by its observation, a pose by a
// between factor or a prior, not by landmarks alone); a rejected update leaves the id maps as they
// were.
#include <doctest/doctest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "lslam/graph/factor_graph.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"
#include "lslam/solver/model_update_validator.h"

namespace {

using lslam::Index;
using lslam::Status;

template <class Model, Index MaxPoses, Index MaxLandmarks>
struct Fixture {
  using Var = lslam::ModelVariableInput<Model>;
  using Fac = lslam::ModelFactorInput<Model>;
  lslam::StaticFactorGraphStorage<Model, MaxPoses, MaxLandmarks, 32, 32 * 50> storage;
  lslam::FactorGraph<Model> graph{storage.arrays()};
  lslam::StaticIdMapStorage<MaxPoses> pose_ids_storage;
  lslam::StaticIdMapStorage<MaxLandmarks> landmark_ids_storage;
  lslam::IdMap pose_ids{pose_ids_storage.arrays()};
  lslam::IdMap landmark_ids{landmark_ids_storage.arrays()};
  lslam::IdMap* maps[2] = {&pose_ids, &landmark_ids};
  std::uint8_t held[MaxPoses + MaxLandmarks + 1] = {};
  lslam::ModelUpdateValidator<Model> validator{held, graph, maps};

  // anchored: the input the solver anchors (kNoIndex: none).
  Status validate(const std::vector<Var>& vars, const std::vector<Fac>& facs,
                  Index anchored = lslam::kNoIndex, bool drop_anchor = false) {
    Index priors = 0;
    return validator.validate(vars.data(), static_cast<Index>(vars.size()), facs.data(),
                              static_cast<Index>(facs.size()), anchored, 12, drop_anchor, &priors);
  }
  // Adds the variables to the graph (as a solver would after an Ok), committed.
  void commit(const std::vector<Var>& vars) {
    graph.beginUpdate();
    for (const Var& v : vars) {
      if (v.kind == 0) {
        static_cast<void>(graph.template addVariable<lslam::TypeAtT<0, typename Model::Variables>>(
            v.template get<lslam::TypeAtT<0, typename Model::Variables>>()));
      } else {
        static_cast<void>(graph.template addVariable<lslam::TypeAtT<1, typename Model::Variables>>(
            v.template get<lslam::TypeAtT<1, typename Model::Variables>>()));
      }
    }
    graph.commit();
  }
};

using Var2 = lslam::ModelVariableInput<lslam::Slam2D>;
using Fac2 = lslam::ModelFactorInput<lslam::Slam2D>;
const lslam::Mat3 kInfo3 = lslam::Mat3::Identity();
const lslam::Mat2 kInfo2 = lslam::Mat2::Identity();

Fac2 between(lslam::VariableId a, lslam::VariableId b) {
  return Fac2::make<lslam::BetweenSE2Factor>(a, b, lslam::SE2(1.0, 0.0, 0.0), kInfo3);
}
Fac2 seen(lslam::VariableId pose, lslam::VariableId landmark) {
  return Fac2::make<lslam::PointObservationSE2Factor>(pose, landmark, lslam::Vec2(2.0, 1.0),
                                                      kInfo2);
}

TEST_CASE("a landmark enters with its observation; a pose needs a between factor or a prior") {
  auto fx = std::make_unique<Fixture<lslam::Slam2D, 8, 4>>();
  // The first pose, held by the anchor, and landmark 0 seen from it.
  const std::vector<Var2> first = {Var2::make(0, lslam::SE2()), Var2::make(0, lslam::Point2())};
  REQUIRE(fx->validate(first, {seen(0, 0)}, 0) == Status::Ok);
  CHECK(fx->validator.find(0, 0) == 0);
  CHECK(fx->validator.find(1, 0) == 1);  // pose 0 and landmark 0: two id spaces
  fx->commit(first);

  // A landmark with no observation, and a pose seen only through a landmark: not held, and the
  // maps keep only the committed ids.
  CHECK(fx->validate({Var2::make(1, lslam::Point2())}, {}) == Status::UnconstrainedVariable);
  CHECK(fx->validator.find(1, 1) == lslam::kNoIndex);
  CHECK(fx->validate({Var2::make(1, lslam::SE2())}, {seen(1, 0)}) == Status::UnconstrainedVariable);
  CHECK(fx->validator.find(0, 1) == lslam::kNoIndex);
  // Two landmarks would fix it, but the rule asks for a between factor or a prior.
  CHECK(fx->validate({Var2::make(1, lslam::SE2()), Var2::make(1, lslam::Point2())},
                     {seen(0, 1), seen(1, 0), seen(1, 1)}) == Status::UnconstrainedVariable);
  // With odometry the pose is held, and its landmark with it (in either factor order).
  CHECK(fx->validate({Var2::make(1, lslam::SE2()), Var2::make(1, lslam::Point2())},
                     {seen(1, 1), between(0, 1)}) == Status::Ok);
  CHECK(fx->validator.find(0, 1) == 2);
  CHECK(fx->validator.find(1, 1) == 3);
}

TEST_CASE(
    "ids, kinds, inputs and capacities are checked per kind, and a rejection undoes its ids") {
  auto fx = std::make_unique<Fixture<lslam::Slam2D, 4, 2>>();
  const std::vector<Var2> first = {Var2::make(0, lslam::SE2())};
  REQUIRE(fx->validate(first, {}, 0) == Status::Ok);
  fx->commit(first);
  CHECK(fx->validate({Var2::make(0, lslam::SE2())}, {}) == Status::DuplicateVariable);
  CHECK(fx->validate({Var2::make(7, lslam::Point2())}, {seen(0, 8)}) == Status::UnknownVariable);
  CHECK(fx->validator.find(1, 7) == lslam::kNoIndex);
  CHECK(fx->validate({Var2::make(1, lslam::SE2())}, {between(0, 1), between(1, 1)}) ==
        Status::InvalidArgument);
  CHECK(fx->validate({Var2::make(1, lslam::SE2(std::nan(""), 0.0, 0.0))}, {between(0, 1)}) ==
        Status::NonFiniteInput);
  CHECK(fx->validate({Var2::make(1, lslam::SE2())},
                     {Fac2::make<lslam::BetweenSE2Factor>(0, 1, lslam::SE2(), -kInfo3)}) ==
        Status::InformationNotPositiveDefinite);
  // Landmark capacity 2: a third is CapacityExhausted before any id enters.
  CHECK(fx->validate({Var2::make(1, lslam::Point2()), Var2::make(2, lslam::Point2()),
                      Var2::make(3, lslam::Point2())},
                     {seen(0, 1), seen(0, 2), seen(0, 3)}) == Status::CapacityExhausted);
  CHECK(fx->validator.find(1, 1) == lslam::kNoIndex);
  Fac2 outside = between(0, 1);
  outside.kind = 9;
  CHECK(fx->validate({Var2::make(1, lslam::SE2())}, {outside}) == Status::InvalidArgument);
  CHECK(fx->validator.find(0, 1) == lslam::kNoIndex);
}

TEST_CASE("the anchor holds the input it names") {
  auto fx = std::make_unique<Fixture<lslam::Slam2D, 4, 2>>();
  // Landmark first, pose second: anchoring input 1 (the pose) holds both; input 0 (the landmark)
  // holds the landmark alone, which cannot hold the pose.
  const std::vector<Var2> first = {Var2::make(0, lslam::Point2()), Var2::make(0, lslam::SE2())};
  CHECK(fx->validate(first, {seen(0, 0)}, 0) == Status::UnconstrainedVariable);
  CHECK(fx->validate(first, {seen(0, 0)}, 2) == Status::InvalidArgument);
  CHECK(fx->validate(first, {seen(0, 0)}) == Status::UnconstrainedVariable);
  CHECK(fx->validator.find(0, 0) == lslam::kNoIndex);
  CHECK(fx->validate(first, {seen(0, 0)}, 1) == Status::Ok);
  CHECK(fx->validator.find(0, 0) == 1);
  CHECK(fx->validator.find(1, 0) == 0);
}

TEST_CASE("taking the anchor out needs a prior that holds the committed graph") {
  auto fx = std::make_unique<Fixture<lslam::Slam2D, 4, 2>>();
  const std::vector<Var2> first = {Var2::make(0, lslam::SE2()), Var2::make(1, lslam::SE2())};
  REQUIRE(fx->validate(first, {between(0, 1)}, 0) == Status::Ok);
  fx->commit(first);
  const Fac2 prior_on_2 = Fac2::make<lslam::PriorSE2Factor>(2, lslam::SE2(), kInfo3);
  // Pose 2 held by its own prior, but nothing ties it to the map: the map would float.
  CHECK(fx->validate({Var2::make(2, lslam::SE2())}, {prior_on_2}, lslam::kNoIndex, true) ==
        Status::UnconstrainedVariable);
  CHECK(fx->validate({Var2::make(2, lslam::SE2())}, {prior_on_2, between(1, 2)}, lslam::kNoIndex,
                     true) == Status::Ok);
}

TEST_CASE("3D: a point observation holds its point, not its pose; quaternions are checked") {
  using Var3 = lslam::ModelVariableInput<lslam::Slam3D>;
  using Fac3 = lslam::ModelFactorInput<lslam::Slam3D>;
  auto fx = std::make_unique<Fixture<lslam::Slam3D, 4, 2>>();
  const auto obs = [](lslam::VariableId p, lslam::VariableId l) {
    return Fac3::make<lslam::PointObservationSE3Factor>(p, l, lslam::Vec3(1, 2, 3),
                                                        lslam::Mat3::Identity());
  };
  const std::vector<Var3> first = {Var3::make(0, lslam::SE3()), Var3::make(0, lslam::Point3())};
  REQUIRE(fx->validate(first, {obs(0, 0)}, 0) == Status::Ok);
  fx->commit(first);
  CHECK(fx->validate({Var3::make(1, lslam::SE3())}, {obs(1, 0)}) == Status::UnconstrainedVariable);
  const lslam::SE3 long_q(lslam::SO3(Eigen::Quaterniond(1.0, 0.1, 0.0, 0.0)), lslam::Vec3::Zero());
  CHECK(fx->validate({Var3::make(1, long_q)}, {Fac3::make<lslam::BetweenSE3Factor>(
                                                  0, 1, lslam::SE3(), lslam::Mat6::Identity())}) ==
        Status::InvalidArgument);
  CHECK(fx->validate({Var3::make(1, lslam::SE3())}, {Fac3::make<lslam::BetweenSE3Factor>(
                                                        0, 1, long_q, lslam::Mat6::Identity())}) ==
        Status::InvalidArgument);
  CHECK(fx->validate({Var3::make(1, lslam::SE3())},
                     {Fac3::make<lslam::BetweenSE3Factor>(0, 1, lslam::SE3(),
                                                          lslam::Mat6::Identity())}) == Status::Ok);
}

}  // namespace
