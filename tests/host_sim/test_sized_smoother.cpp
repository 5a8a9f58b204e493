// Tests of the run-time sized smoother (host_sim/sized_smoother.h) and of the capacities the host
// gives it (model_run.h, modelCapacities): the same estimates, bit for bit, as a StaticSmoother of
// the same model fed the same stream; capacities that hold what a run uses, the graph's exactly;
// and a block pool too small for a run named in its rejection.
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "host_sim/model_dataset_io.h"
#include "host_sim/model_run.h"
#include "host_sim/model_steps.h"
#include "host_sim/sized_smoother.h"
#include "host_sim/worlds.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"

namespace sim = lslam::sim;
using lslam::Index;
using lslam::Status;

namespace {

// A world of `steps` poses (and, if landmarks >= 0, that many landmarks instead of its default).
sim::ModelDataset smallWorld(sim::WorldKind kind, int steps, std::uint32_t seed,
                             int landmarks = -1) {
  sim::WorldOptions options = sim::defaultWorldOptions(kind);
  options.steps = steps;
  options.seed = seed;
  if (landmarks >= 0) options.landmarks = landmarks;
  return sim::simulateWorld(kind, options).dataset;
}

// A value's parameters, to compare bit for bit.
Eigen::VectorXd parameters(const lslam::SE2& x) {
  return x.vector();
}
Eigen::VectorXd parameters(const lslam::SE3& x) {
  Eigen::VectorXd p(7);
  p << x.translation(), x.rotation().quaternion().coeffs();
  return p;
}
template <int N>
Eigen::VectorXd parameters(const lslam::Point<N>& l) {
  return l.vector();
}

// Feeds `d` online, from its vertices' initial values, to a StaticSmoother `Static` and to a
// SizedSmoother of modelCapacities(d): every update, and the estimates after each, must agree
// exactly.
template <class Model, class Static>
void checkSameAsStatic(const sim::ModelDataset& d) {
  using Pose = lslam::TypeAtT<0, typename Model::Variables>;
  using Landmark = lslam::TypeAtT<Model::Variables::kSize - 1, typename Model::Variables>;
  REQUIRE(sim::hasLandmarks(d) == (Model::Variables::kSize == 2));
  const lslam::SolverOptions options = sim::defaultModelOptions(d);
  const auto fixed = std::make_unique<Static>(options);
  const sim::SmootherCapacities capacities = sim::modelCapacities(d, sim::StepOrder::Online);
  REQUIRE(capacities.poses <= Static::max_poses);
  REQUIRE(capacities.landmarks <= Static::max_landmarks);
  REQUIRE(capacities.factors <= Static::max_factors);
  sim::SizedSmoother<Model> sized(capacities, options);
  CHECK(sized.bytes() > sizeof(lslam::Smoother<Model>));

  std::unordered_map<sim::VariableKey, Eigen::VectorXd, sim::VariableKeyHash> initial;
  for (const sim::ModelVertex& v : d.vertices) initial[v.key] = v.value;
  const std::vector<sim::ModelStep> steps = sim::buildModelSteps(d, sim::StepOrder::Online);
  REQUIRE(steps.size() > 50);
  for (std::size_t s = 0; s < steps.size(); ++s) {
    CAPTURE(s);
    const sim::ModelStep& step = steps[s];
    std::vector<lslam::ModelVariableInput<Model>> variables;
    if (step.new_pose.id >= 0) {
      variables.push_back(sim::modelVariableInput<Model>(step.new_pose, initial.at(step.new_pose)));
    }
    for (const sim::VariableKey& key : step.new_landmarks) {
      variables.push_back(sim::modelVariableInput<Model>(key, initial.at(key)));
    }
    std::vector<lslam::ModelFactorInput<Model>> factors;
    for (const std::size_t k : step.factors) {
      factors.push_back(sim::modelFactorInput<Model>(d, d.factors[k]));
    }
    lslam::UpdateResult a, b;
    REQUIRE(fixed->update(variables.data(), static_cast<Index>(variables.size()), factors.data(),
                          static_cast<Index>(factors.size()), &a) == Status::Ok);
    REQUIRE(sized.update(variables.data(), static_cast<Index>(variables.size()), factors.data(),
                         static_cast<Index>(factors.size()), &b) == Status::Ok);
    REQUIRE(a.reordered == b.reordered);
    REQUIRE(a.factor_blocks == b.factor_blocks);
    REQUIRE(a.block_products == b.block_products);
    REQUIRE(fixed->chi2() == sized.chi2());
  }
  REQUIRE(fixed->variables() == sized.variables());
  CHECK(sized.poses() == capacities.poses);
  CHECK(sized.landmarks() == capacities.landmarks);
  CHECK(sized.factors() == capacities.factors);
  for (Index v = 0; v < sized.variables(); ++v) {
    CAPTURE(v);
    REQUIRE(fixed->idAt(v) == sized.idAt(v));
    REQUIRE(fixed->kindAt(v) == sized.kindAt(v));
    const Eigen::VectorXd x = fixed->kindAt(v) == 0
                                  ? parameters(fixed->template estimateAt<Pose>(v))
                                  : parameters(fixed->template estimateAt<Landmark>(v));
    const Eigen::VectorXd y = sized.kindAt(v) == 0
                                  ? parameters(sized.template estimateAt<Pose>(v))
                                  : parameters(sized.template estimateAt<Landmark>(v));
    CHECK(x == y);
  }
}

}  // namespace

TEST_CASE("SizedSmoother: bit-identical to a StaticSmoother of the same model") {
  using lslam::PoseSlam2D;
  using lslam::PoseSlam3D;
  using lslam::Slam2D;
  using lslam::Slam3D;
  using lslam::StaticSmoother;
  constexpr Index kBlocks = 1 << 15;
  SUBCASE("Slam2D: grid2d with landmarks") {
    checkSameAsStatic<Slam2D,
                      StaticSmoother<Slam2D, 256, 512, 8192, 8192 * 12, kBlocks, kBlocks * 9>>(
        smallWorld(sim::WorldKind::Grid2D, 150, 11));
  }
  SUBCASE("PoseSlam2D: grid2d without landmarks") {
    checkSameAsStatic<PoseSlam2D, StaticSmoother<PoseSlam2D, 256, 0, 1024, 1024 * 12, kBlocks, 0>>(
        smallWorld(sim::WorldKind::Grid2D, 200, 3, 0));
  }
  SUBCASE("PoseSlam3D: sphere3d") {
    checkSameAsStatic<PoseSlam3D, StaticSmoother<PoseSlam3D, 256, 0, 1024, 1024 * 43, kBlocks, 0>>(
        smallWorld(sim::WorldKind::Sphere3D, 150, 5));
  }
  SUBCASE("Slam3D: points3d") {
    checkSameAsStatic<Slam3D,
                      StaticSmoother<Slam3D, 256, 256, 8192, 8192 * 43, kBlocks, kBlocks * 36>>(
        smallWorld(sim::WorldKind::Points3D, 120, 7));
  }
}

TEST_CASE("modelCapacities: the run's exact variables and factors, and room for its blocks") {
  std::vector<sim::ModelDataset> datasets;
  datasets.push_back(
      sim::readModelDataset(std::string(LSLAM_DATA_DIR) + "/manhattan_world_500.g2o"));
  datasets.push_back(smallWorld(sim::WorldKind::Grid2D, 300, 2));
  datasets.push_back(smallWorld(sim::WorldKind::Points3D, 200, 4));
  for (const sim::ModelDataset& d : datasets) {
    CAPTURE(d.name);
    sim::IncrementalOptions options;
    options.solver = sim::defaultModelOptions(d);
    const sim::ModelRun run = sim::runModelIncremental(d, options);
    const sim::SmootherCapacities& c = run.capacities;
    // The dataset's own counts.
    Index poses = 0, landmarks = 0;
    for (const sim::ModelVertex& v : d.vertices) {
      (v.key.role == sim::VariableRole::Pose ? poses : landmarks) += 1;
    }
    CHECK(c.poses == poses);
    CHECK(c.landmarks == landmarks);
    CHECK(c.factors == static_cast<Index>(d.factors.size()) + 1);  // and the anchor
    // What the run used.
    CHECK(run.poses == c.poses);
    CHECK(run.landmarks == c.landmarks);
    CHECK(run.factors == c.factors);
    CHECK(run.peak_factor_blocks <= c.factor_blocks);
    CHECK(c.factor_blocks >= sim::batchFactorBlocks(d));
    CHECK(c.factor_values > 0);
    CHECK(run.solver_bytes > 0);
    CHECK(c == sim::modelCapacities(d, sim::StepOrder::Online));
    // An explicit pool replaces the rule, and nothing else.
    sim::SmootherCapacities sized = sim::modelCapacities(d, sim::StepOrder::Online, 12345);
    CHECK(sized.factor_blocks == 12345);
    sized.factor_blocks = c.factor_blocks;
    sized.factor_block_values = c.factor_block_values;
    CHECK(sized == c);
  }
}

TEST_CASE("runModelIncremental: a block pool too small is named, with the option that sets it") {
  const sim::ModelDataset d = smallWorld(sim::WorldKind::Grid2D, 200, 9);
  sim::IncrementalOptions options;
  options.solver = sim::defaultModelOptions(d);
  options.factor_blocks = 600;
  try {
    (void)sim::runModelIncremental(d, options);
    FAIL("the run fit in 600 blocks");
  } catch (const sim::DatasetError& e) {
    const std::string what = e.what();
    CAPTURE(what);
    CHECK(what.find("capacity exhausted") != std::string::npos);
    CHECK(what.find("block pool, 600 blocks") != std::string::npos);
    CHECK(what.find("--factor-blocks 1200") != std::string::npos);
  }
}

TEST_CASE("SizedSmoother with a spread factor: bit-identical to a StaticSmoother with one") {
  using lslam::PoseSlam2D;
  using Static = lslam::StaticSmoother<PoseSlam2D, 256, 0, 1024, 1024 * 12, 1 << 15, 0, 64>;
  const sim::ModelDataset d = smallWorld(sim::WorldKind::Grid2D, 250, 3, 0);
  lslam::SolverOptions options = sim::defaultModelOptions(d);
  options.spread_reorder_products = 300;
  options.relinearize_defer_products = 1;  // relinearizations wait for the (spread) reorderings
  const auto fixed = std::make_unique<Static>(options);
  const sim::SmootherCapacities capacities =
      sim::modelCapacities(d, sim::StepOrder::Online, 1 << 15, options.spread_reorder_products);
  REQUIRE(capacities.spread_factor_blocks == capacities.factor_blocks);
  REQUIRE(capacities.spread_updates >= 64);
  sim::SizedSmoother<PoseSlam2D> sized(capacities, options);
  std::unordered_map<sim::VariableKey, Eigen::VectorXd, sim::VariableKeyHash> initial;
  for (const sim::ModelVertex& v : d.vertices) initial[v.key] = v.value;
  int swapped = 0;
  for (const sim::ModelStep& step : sim::buildModelSteps(d, sim::StepOrder::Online)) {
    std::vector<lslam::ModelVariableInput<PoseSlam2D>> variables;
    variables.push_back(
        sim::modelVariableInput<PoseSlam2D>(step.new_pose, initial.at(step.new_pose)));
    std::vector<lslam::ModelFactorInput<PoseSlam2D>> factors;
    for (const std::size_t k : step.factors) {
      factors.push_back(sim::modelFactorInput<PoseSlam2D>(d, d.factors[k]));
    }
    lslam::UpdateResult a, b;
    REQUIRE(fixed->update(variables.data(), 1, factors.data(), static_cast<Index>(factors.size()),
                          &a) == Status::Ok);
    REQUIRE(sized.update(variables.data(), 1, factors.data(), static_cast<Index>(factors.size()),
                         &b) == Status::Ok);
    REQUIRE(a.spread_swapped == b.spread_swapped);
    REQUIRE(a.spread_products == b.spread_products);
    REQUIRE(fixed->chi2() == sized.chi2());
    swapped += b.spread_swapped ? 1 : 0;
  }
  CHECK(swapped >= 3);
}

TEST_CASE("modelCapacities: a second factor for spread reorderings when the batch one is dear") {
  const sim::ModelDataset d =
      sim::readModelDataset(std::string(LSLAM_DATA_DIR) + "/manhattan_world_500.g2o");
  const sim::BatchFill fill = sim::batchFactorFill(d);
  CHECK(fill.blocks == sim::batchFactorBlocks(d));
  // At least one product per column below the diagonal, at most a dense factor's.
  const auto n = static_cast<std::int64_t>(d.vertices.size());
  CHECK(fill.products >= fill.blocks - n);
  CHECK(fill.products <= n * (n - 1) / 2);
  const sim::SmootherCapacities none = sim::modelCapacities(d, sim::StepOrder::Online);
  CHECK(none.spread_factor_blocks == 0);
  CHECK(none.spread_updates == 0);
  const sim::SmootherCapacities at =
      sim::modelCapacities(d, sim::StepOrder::Online, 0, fill.products);
  CHECK(at == none);  // only a dearer factorization gets the second factor
  const sim::SmootherCapacities below =
      sim::modelCapacities(d, sim::StepOrder::Online, 0, fill.products - 1);
  CHECK(below.spread_factor_blocks == below.factor_blocks);
  CHECK(below.spread_updates > 0);
}
