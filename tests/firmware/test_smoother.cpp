// Smoother<Model> against the independent host batch solver (solveModelBatch) on random Slam2D and
// Slam3D streams fed online, and the rejection contract: a rejected update changes no bit, and the
// next valid update gives what it gives without the rejected one.
#include <doctest/doctest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "host_sim/model_batch_solver.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"
#include "lslam/solver/smoother.h"

namespace {

using lslam::Index;
using lslam::Mat2;
using lslam::Mat3;
using lslam::Mat6;
using lslam::Point2;
using lslam::Point3;
using lslam::PoseSlam2D;
using lslam::PoseSlam3D;
using lslam::SE2;
using lslam::SE3;
using lslam::Slam2D;
using lslam::Slam3D;
using lslam::Status;
using lslam::Vec2;
using lslam::Vec3;
namespace sim = lslam::sim;

template <class Model>
struct Step {
  std::vector<lslam::ModelVariableInput<Model>> variables;
  std::vector<lslam::ModelFactorInput<Model>> factors;
};

// A stream of updates and the same problem as a host dataset (G2o convention), with the initial
// values the stream gives its variables.
template <class Model>
struct Stream {
  std::vector<Step<Model>> steps;
  sim::ModelDataset dataset;
  sim::ModelEstimate initial;
};

sim::VariableKey poseKey(std::int64_t id) {
  return {sim::VariableRole::Pose, id};
}
sim::VariableKey landmarkKey(std::int64_t id) {
  return {sim::VariableRole::Landmark, id};
}

template <class Model>
void addFactor(Stream<Model>& s, sim::FactorKind kind, sim::VariableKey a, sim::VariableKey b,
               const Eigen::VectorXd& z, const Eigen::MatrixXd& info) {
  sim::ModelFactor f;
  f.kind = kind;
  f.first = a;
  f.second = b;
  f.measurement = z;
  f.information = info;
  s.dataset.factors.push_back(f);
}

// ---- 2D: odometry, loop closures, landmarks seen by position and by range-bearing
// ----------------

Eigen::Vector3d vec(const SE2& x) {
  return Eigen::Vector3d(x.x(), x.y(), x.theta());
}

// Slam2D, or PoseSlam2D (the same poses and pose factors; landmarks must be 0).
template <class Model = Slam2D>
Stream<Model> stream2D(unsigned seed, int poses, int landmarks) {
  using Var = lslam::ModelVariableInput<Model>;
  using Fac = lslam::ModelFactorInput<Model>;
  constexpr bool kLandmarks = Model::Variables::kSize == 2;
  REQUIRE((kLandmarks || landmarks == 0));
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Stream<Model> s;
  s.dataset.name = "random 2D";
  s.dataset.dimension = 2;
  std::vector<SE2> truth;
  std::vector<SE2> initial;
  std::vector<Vec2> marks;
  for (int l = 0; l < landmarks; ++l)
    marks.push_back(Vec2(uniform(rng) * 24 - 4, uniform(rng) * 24 - 4));
  std::vector<bool> seen(landmarks, false);
  const Mat3 odo_info = Eigen::Vector3d(100.0, 100.0, 400.0).asDiagonal();
  const Mat2 xy_info = Mat2::Identity() * 50.0;
  const Mat2 rb_info = Eigen::Vector2d(50.0, 200.0).asDiagonal();
  const auto noisy = [&](const SE2& z) {
    return SE2(z.x() + 0.1 * noise(rng), z.y() + 0.1 * noise(rng), z.theta() + 0.05 * noise(rng));
  };
  for (int k = 0; k < poses; ++k) {
    Step<Model> step;
    if (k == 0) {
      truth.push_back(SE2(0.0, 0.0, 0.0));
      initial.push_back(truth[0]);
    } else {
      // A square-ish loop: forward with turns, so that loop closures and revisited landmarks come.
      const double turn = (k % 10 == 0) ? 1.5707963 : 0.05 * noise(rng);
      const SE2 move(1.0, 0.0, turn);
      truth.push_back(truth[k - 1].compose(move));
      const SE2 z = noisy(move);
      initial.push_back(initial[k - 1].compose(z));
      step.factors.push_back(Fac::template make<lslam::BetweenSE2Factor>(k - 1, k, z, odo_info));
      addFactor(s, sim::FactorKind::BetweenSE2, poseKey(k - 1), poseKey(k), vec(z), odo_info);
      // A loop closure to an earlier pose nearby in space.
      for (int j = 0; j + 8 < k; ++j) {
        const SE2 rel = truth[j].between(truth[k]);
        if (std::hypot(rel.x(), rel.y()) < 2.0 && uniform(rng) < 0.3) {
          const SE2 zl = noisy(rel);
          step.factors.push_back(Fac::template make<lslam::BetweenSE2Factor>(j, k, zl, odo_info));
          addFactor(s, sim::FactorKind::BetweenSE2, poseKey(j), poseKey(k), vec(zl), odo_info);
          break;
        }
      }
    }
    step.variables.push_back(Var::make(k, initial[k]));
    s.initial[poseKey(k)] = vec(initial[k]);
    if constexpr (kLandmarks) {
      // Landmarks within 4 m: odd ids by range-bearing, even ids by position.
      for (int l = 0; l < landmarks; ++l) {
        const Vec2 d = marks[l] - truth[k].translation();
        if (d.norm() > 4.0) continue;
        const double c = std::cos(truth[k].theta());
        const double sn = std::sin(truth[k].theta());
        const Vec2 local(c * d.x() + sn * d.y(), -sn * d.x() + c * d.y());
        Vec2 z;
        Vec2 local_measured;
        if (l % 2 == 1) {
          z = Vec2(local.norm() + 0.05 * noise(rng),
                   std::atan2(local.y(), local.x()) + 0.02 * noise(rng));
          local_measured = Vec2(z(0) * std::cos(z(1)), z(0) * std::sin(z(1)));
          step.factors.push_back(
              Fac::template make<lslam::RangeBearingSE2Factor>(k, l, z, rb_info));
          addFactor(s, sim::FactorKind::RangeBearing2, poseKey(k), landmarkKey(l), z, rb_info);
        } else {
          z = local + 0.05 * Vec2(noise(rng), noise(rng));
          local_measured = z;
          step.factors.push_back(
              Fac::template make<lslam::PointObservationSE2Factor>(k, l, z, xy_info));
          addFactor(s, sim::FactorKind::PointXY2, poseKey(k), landmarkKey(l), z, xy_info);
        }
        if (!seen[l]) {
          // Initialised from this observation at the dead-reckoned pose.
          seen[l] = true;
          const SE2& p = initial[k];
          const double ci = std::cos(p.theta());
          const double si = std::sin(p.theta());
          const Vec2 w(p.x() + ci * local_measured.x() - si * local_measured.y(),
                       p.y() + si * local_measured.x() + ci * local_measured.y());
          step.variables.push_back(Var::make(l, Point2(w)));
          s.initial[landmarkKey(l)] = w;
        }
      }
    }
    s.steps.push_back(step);
  }
  return s;
}

// ---- 3D: SE3 odometry and loop closures, point observations
// --------------------------------------

Eigen::Quaterniond smallRotation(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> noise(0.0, sigma);
  const Eigen::Vector3d w(noise(rng), noise(rng), noise(rng));
  if (w.norm() == 0.0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized()));
}

SE3 toSE3(const Eigen::Isometry3d& x) {
  return SE3(lslam::SO3(Eigen::Quaterniond(x.linear()).normalized()), x.translation());
}
Eigen::Isometry3d toIso(const SE3& x) {
  Eigen::Isometry3d r = Eigen::Isometry3d::Identity();
  r.linear() = x.rotation().quaternion().toRotationMatrix();
  r.translation() = x.translation();
  return r;
}
Eigen::VectorXd vec(const SE3& x) {
  const Eigen::Quaterniond& q = x.rotation().quaternion();
  Eigen::VectorXd v(7);
  v << x.translation(), q.x(), q.y(), q.z(), q.w();
  return v;
}

// Slam3D, or PoseSlam3D (the same poses and pose factors; landmarks must be 0).
template <class Model = Slam3D>
Stream<Model> stream3D(unsigned seed, int poses, int landmarks) {
  using Var = lslam::ModelVariableInput<Model>;
  using Fac = lslam::ModelFactorInput<Model>;
  constexpr bool kLandmarks = Model::Variables::kSize == 2;
  REQUIRE((kLandmarks || landmarks == 0));
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Stream<Model> s;
  s.dataset.name = "random 3D";
  s.dataset.dimension = 3;
  std::vector<Eigen::Isometry3d> truth;
  std::vector<SE3> initial;
  std::vector<Vec3> marks;
  for (int l = 0; l < landmarks; ++l)
    marks.push_back(Vec3(uniform(rng) * 20 - 4, uniform(rng) * 20 - 4, uniform(rng) * 4 - 2));
  std::vector<bool> seen(landmarks, false);
  Mat6 odo_info = Mat6::Identity() * 100.0;
  odo_info.bottomRightCorner<3, 3>() *= 4.0;
  const Mat3 obs_info = Mat3::Identity() * 50.0;
  const auto noisy = [&](const Eigen::Isometry3d& z) {
    Eigen::Isometry3d n = Eigen::Isometry3d::Identity();
    n.linear() = smallRotation(rng, 0.02).toRotationMatrix();
    n.translation() = 0.05 * Vec3(noise(rng), noise(rng), noise(rng));
    return toSE3(z * n);
  };
  for (int k = 0; k < poses; ++k) {
    Step<Model> step;
    if (k == 0) {
      truth.push_back(Eigen::Isometry3d::Identity());
      initial.push_back(SE3());
    } else {
      Eigen::Isometry3d move = Eigen::Isometry3d::Identity();
      const double yaw = (k % 10 == 0) ? 1.5707963 : 0.05 * noise(rng);
      move.linear() =
          (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * smallRotation(rng, 0.02)).toRotationMatrix();
      move.translation() = Vec3(1.0, 0.0, 0.05 * noise(rng));
      truth.push_back(truth[k - 1] * move);
      const SE3 z = noisy(move);
      initial.push_back(toSE3(toIso(initial[k - 1]) * toIso(z)));
      step.factors.push_back(Fac::template make<lslam::BetweenSE3Factor>(k - 1, k, z, odo_info));
      addFactor(s, sim::FactorKind::BetweenSE3, poseKey(k - 1), poseKey(k), vec(z), odo_info);
      for (int j = 0; j + 8 < k; ++j) {
        const Eigen::Isometry3d rel = truth[j].inverse() * truth[k];
        if (rel.translation().norm() < 2.0 && uniform(rng) < 0.3) {
          const SE3 zl = noisy(rel);
          step.factors.push_back(Fac::template make<lslam::BetweenSE3Factor>(j, k, zl, odo_info));
          addFactor(s, sim::FactorKind::BetweenSE3, poseKey(j), poseKey(k), vec(zl), odo_info);
          break;
        }
      }
    }
    step.variables.push_back(Var::make(k, initial[k]));
    s.initial[poseKey(k)] = vec(initial[k]);
    for (int l = 0; l < landmarks; ++l) {
      const Vec3 local = truth[k].inverse() * marks[l];
      if (local.norm() > 4.0) continue;
      const Vec3 z = local + 0.05 * Vec3(noise(rng), noise(rng), noise(rng));
      if constexpr (kLandmarks) {
        step.factors.push_back(
            Fac::template make<lslam::PointObservationSE3Factor>(k, l, z, obs_info));
        addFactor(s, sim::FactorKind::PointXYZ3, poseKey(k), landmarkKey(l), z, obs_info);
        if (!seen[l]) {
          seen[l] = true;
          const Vec3 w = toIso(initial[k]) * z;
          step.variables.push_back(Var::make(l, Point3(w)));
          s.initial[landmarkKey(l)] = w;
        }
      }
    }
    s.steps.push_back(step);
  }
  return s;
}

// ---- Reading a smoother
// --------------------------------------------------------------------------

// Every estimate (StoredValue doubles, by variable) and chi2, for bitwise comparisons.
template <class Model>
std::vector<double> snapshot(const lslam::Smoother<Model>& s) {
  using Pose = lslam::TypeAtT<0, typename Model::Variables>;
  using Landmark = lslam::TypeAtT<Model::Variables::kSize - 1, typename Model::Variables>;
  std::vector<double> out;
  out.push_back(static_cast<double>(s.variables()));
  out.push_back(static_cast<double>(s.factors()));
  for (Index v = 0; v < s.variables(); ++v) {
    double values[7] = {};
    if (s.kindAt(v) == 0) {
      lslam::StoredValue<Pose>::store(s.template estimateAt<Pose>(v), values);
    } else {
      lslam::StoredValue<Landmark>::store(s.template estimateAt<Landmark>(v), values);
    }
    out.push_back(static_cast<double>(s.idAt(v)));
    out.insert(out.end(), values, values + 7);
  }
  out.push_back(s.chi2());
  return out;
}

bool sameBits(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

template <class Model>
Status feed(lslam::Smoother<Model>& s, const Step<Model>& step,
            lslam::UpdateResult* result = nullptr) {
  return s.update(step.variables.data(), static_cast<Index>(step.variables.size()),
                  step.factors.data(), static_cast<Index>(step.factors.size()), result);
}

bool allFinite(const std::vector<double>& v) {
  for (double x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

// The batch optimum with pose 0 fixed at its initial value (the smoother's anchor holds it there).
sim::ModelBatchResult batch(const sim::ModelDataset& d, const sim::ModelEstimate& initial) {
  sim::BatchOptions options;
  options.fixed = {0};
  return sim::solveModelBatch(d, initial, options);
}

using Smoother2D = lslam::StaticSmoother<Slam2D, 160, 40, 1600, 1600 * 12, 24000, 24000 * 9>;
using Smoother3D = lslam::StaticSmoother<Slam3D, 130, 40, 1600, 1600 * 43, 20000, 20000 * 36>;
using SmootherPoses3D = lslam::StaticSmoother<PoseSlam3D, 200, 0, 1600, 1600 * 43, 20000, 0>;
using SmootherPoses2D = lslam::StaticSmoother<PoseSlam2D, 400, 0, 1600, 1600 * 12, 24000, 0>;

// Online, then optimize(): chi2 within 1e-6 relative of the batch optimum; every estimate within
// 1e-6 (pose translation and landmark coordinates, m; angle or quaternion coefficients) of the
// batch's.
template <class Model, class S>
void checkAgainstBatch(const Stream<Model>& stream, S& smoother, int kPoseParams) {
  using Pose = lslam::TypeAtT<0, typename Model::Variables>;
  using Landmark = lslam::TypeAtT<Model::Variables::kSize - 1, typename Model::Variables>;
  int reordered = 0;
  for (std::size_t k = 0; k < stream.steps.size(); ++k) {
    CAPTURE(k);
    lslam::UpdateResult r;
    const Step<Model>& st = stream.steps[k];
    REQUIRE(smoother.update(st.variables.data(), static_cast<Index>(st.variables.size()),
                            st.factors.data(), static_cast<Index>(st.factors.size()),
                            &r) == Status::Ok);
    reordered += r.reordered ? 1 : 0;
    REQUIRE(allFinite(snapshot(smoother)));
  }
  MESSAGE(reordered << " reorderings online");
  // The stream holds loop closures (between factors to a pose before the previous one).
  int loop_closures = 0;
  for (const sim::ModelFactor& f : stream.dataset.factors) {
    const bool between =
        f.kind == sim::FactorKind::BetweenSE2 || f.kind == sim::FactorKind::BetweenSE3;
    loop_closures += between && f.second.id - f.first.id > 1 ? 1 : 0;
  }
  CHECK(loop_closures > 3);
  const sim::ModelBatchResult reference = batch(stream.dataset, stream.initial);
  REQUIRE(reference.converged);
  REQUIRE(smoother.optimize(50, 1e-10) == Status::Ok);
  const double chi2 = smoother.chi2();
  MESSAGE("poses " << smoother.poses() << ", landmarks " << smoother.landmarks() << ", factors "
                   << stream.dataset.factors.size() << ": chi2 " << chi2 << ", batch "
                   << reference.chi2);
  CHECK(std::abs(chi2 - reference.chi2) <= 1e-6 * reference.chi2);
  double worst = 0.0;
  for (Index v = 0; v < smoother.variables(); ++v) {
    const bool pose = smoother.kindAt(v) == 0;
    const sim::VariableKey key = pose ? poseKey(smoother.idAt(v)) : landmarkKey(smoother.idAt(v));
    const Eigen::VectorXd& ref = reference.values.at(key);
    Eigen::VectorXd mine;
    if (pose) {
      mine = vec(smoother.template estimateAt<Pose>(v));
      if (kPoseParams == 7 && mine(6) * ref(6) < 0.0) mine.tail<4>() *= -1.0;  // q and -q
    } else if constexpr (Model::Variables::kSize == 2) {
      mine = smoother.template estimateAt<Landmark>(v).vector();
    }
    REQUIRE(mine.size() == ref.size());
    worst = std::max(worst, (mine - ref).cwiseAbs().maxCoeff());
  }
  MESSAGE("largest difference from the batch estimate " << worst);
  CHECK(worst < 1e-6);
  // estimate<V> by id agrees with estimateAt.
  Pose p;
  REQUIRE(smoother.estimate(lslam::VariableId{3}, &p) == Status::Ok);
  const Eigen::VectorXd by_id = vec(p);
  Index index3 = 0;
  while (smoother.kindAt(index3) != 0 || smoother.idAt(index3) != 3) ++index3;
  const Eigen::VectorXd by_index = vec(smoother.template estimateAt<Pose>(index3));
  CHECK((by_id.array() == by_index.array()).all());
  CHECK(smoother.estimate(lslam::VariableId{100000}, &p) == Status::UnknownVariable);
  Landmark l;
  CHECK(smoother.estimate(lslam::VariableId{100000}, &l) == Status::UnknownVariable);
}

TEST_CASE("Slam2D streams: online estimates finite, optimize() reaches the batch optimum") {
  const unsigned seeds[] = {1, 7, 42};
  const int poses[] = {60, 100, 150};
  for (int i = 0; i < 3; ++i) {
    CAPTURE(seeds[i]);
    const Stream<Slam2D> stream = stream2D(seeds[i], poses[i], 40);
    auto smoother = std::make_unique<Smoother2D>();
    checkAgainstBatch(stream, *smoother, 3);
    CHECK(smoother->landmarks() > 10);
    CHECK(smoother->anchorFactor() != lslam::kNoIndex);
  }
}

TEST_CASE("Slam3D streams: online estimates finite, optimize() reaches the batch optimum") {
  const unsigned seeds[] = {3, 11};
  const int poses[] = {70, 120};
  for (int i = 0; i < 2; ++i) {
    CAPTURE(seeds[i]);
    const Stream<Slam3D> stream = stream3D(seeds[i], poses[i], 40);
    auto smoother = std::make_unique<Smoother3D>();
    checkAgainstBatch(stream, *smoother, 7);
    CHECK(smoother->landmarks() > 10);
  }
}

// Each step's factors in reverse order: a step's point observations come before its odometry, so
// the row update meets an added pose through a factor of fewer rows than the pose is wide, which
// must not be the first rotated into its column (see FactorizationDriver::seedAddedColumns).
TEST_CASE("Slam2D and Slam3D streams with observations before odometry: the same optimum") {
  auto reversed = [](auto stream) {
    for (auto& step : stream.steps) std::reverse(step.factors.begin(), step.factors.end());
    return stream;
  };
  auto smoother3 = std::make_unique<Smoother3D>();
  checkAgainstBatch(reversed(stream3D(31, 90, 40)), *smoother3, 7);
  CHECK(smoother3->landmarks() > 10);
  auto smoother2 = std::make_unique<Smoother2D>();
  checkAgainstBatch(reversed(stream2D(37, 90, 40)), *smoother2, 3);
  CHECK(smoother2->landmarks() > 10);
}

// An update that adds two poses with its factors listed [between(x1, x2), between(x0, x1), a loop
// closure] takes the row update. Rotated in that order, the first factor would give x1 full rank
// and x2 none: exactly none with exact measurements and identity information, which would reject
// a valid update. Against a twin fed the same factors in a friendly order.
template <class Model, class S>
void checkTwoAddedPoses() {
  using Var = lslam::ModelVariableInput<Model>;
  using Fac = lslam::ModelFactorInput<Model>;
  lslam::SolverOptions options = lslam::defaultSolverOptions<Model>();
  options.reorder_min_variables = 1000;  // no reordering: the update must take the row update
  auto adverse = std::make_unique<S>(options);
  auto friendly = std::make_unique<S>(options);
  const SE2 move(1.0, 0.0, 0.0);
  const Mat3 identity = Mat3::Identity();
  for (Index k = 0; k < 40; ++k) {
    const std::vector<Var> variables = {Var::make(k, SE2(static_cast<double>(k), 0.0, 0.0))};
    std::vector<Fac> factors;
    if (k > 0)
      factors.push_back(Fac::template make<lslam::BetweenSE2Factor>(k - 1, k, move, identity));
    for (S* s : {adverse.get(), friendly.get()}) {
      REQUIRE(s->update(variables.data(), 1, factors.data(), static_cast<Index>(factors.size())) ==
              Status::Ok);
    }
  }
  const std::vector<Var> variables = {Var::make(40, SE2(40.0, 0.0, 0.0)),
                                      Var::make(41, SE2(41.0, 0.0, 0.0))};
  const Fac between_new = Fac::template make<lslam::BetweenSE2Factor>(40, 41, move, identity);
  const Fac odometry = Fac::template make<lslam::BetweenSE2Factor>(39, 40, move, identity);
  const Fac closure =
      Fac::template make<lslam::BetweenSE2Factor>(0, 41, SE2(41.0, 0.0, 0.0), identity);
  const std::vector<Fac> adverse_order = {between_new, odometry, closure};
  const std::vector<Fac> friendly_order = {odometry, between_new, closure};
  lslam::UpdateResult r;
  REQUIRE(adverse->update(variables.data(), 2, adverse_order.data(), 3, &r) == Status::Ok);
  CHECK(r.reordered == false);
  CHECK(r.variables_relinearized == 0);
  REQUIRE(friendly->update(variables.data(), 2, friendly_order.data(), 3) == Status::Ok);
  for (Index v = 0; v < adverse->variables(); ++v) {
    const Eigen::Vector3d a = vec(adverse->template estimateAt<SE2>(v));
    const Eigen::Vector3d b = vec(friendly->template estimateAt<SE2>(v));
    CHECK((a - b).cwiseAbs().maxCoeff() < 1e-9);
  }
  CHECK(std::abs(adverse->chi2() - friendly->chi2()) < 1e-9);
}

TEST_CASE("two poses added in one update, their factors in an adverse order (one and two sizes)") {
  checkTwoAddedPoses<PoseSlam2D, SmootherPoses2D>();
  checkTwoAddedPoses<Slam2D, Smoother2D>();
}

TEST_CASE(
    "PoseSlam3D streams (one block size, row updates): optimize() reaches the batch optimum") {
  const unsigned seeds[] = {5, 13};
  const int poses[] = {90, 180};
  for (int i = 0; i < 2; ++i) {
    CAPTURE(seeds[i]);
    const Stream<PoseSlam3D> stream = stream3D<PoseSlam3D>(seeds[i], poses[i], 0);
    auto smoother = std::make_unique<SmootherPoses3D>();
    checkAgainstBatch(stream, *smoother, 7);
    CHECK(smoother->landmarks() == 0);
  }
}

TEST_CASE(
    "PoseSlam2D streams (one block size: supernodes, 3x3 kernels): optimize() reaches the batch "
    "optimum") {
  const unsigned seeds[] = {17, 29};
  const int poses[] = {120, 300};
  for (int i = 0; i < 2; ++i) {
    CAPTURE(seeds[i]);
    const Stream<PoseSlam2D> stream = stream2D<PoseSlam2D>(seeds[i], poses[i], 0);
    auto smoother = std::make_unique<SmootherPoses2D>();
    checkAgainstBatch(stream, *smoother, 3);
    CHECK(smoother->landmarks() == 0);
  }
}

// urgent_iterations: with every bar near zero, each update iterates Gauss-Newton within itself,
// so the estimate after the last update, with no optimize(), is the batch optimum already.
template <class Model, class S>
void checkConvergedOnline(const Stream<Model>& stream, S& smoother) {
  int iterated = 0;
  for (const Step<Model>& st : stream.steps) {
    lslam::UpdateResult r;
    REQUIRE(smoother.update(st.variables.data(), static_cast<Index>(st.variables.size()),
                            st.factors.data(), static_cast<Index>(st.factors.size()),
                            &r) == Status::Ok);
    iterated += r.iterations > 0 ? 1 : 0;
  }
  const sim::ModelBatchResult reference = batch(stream.dataset, stream.initial);
  REQUIRE(reference.converged);
  MESSAGE(iterated << " of " << stream.steps.size() << " updates iterated; chi2 " << smoother.chi2()
                   << ", batch " << reference.chi2);
  CHECK(iterated > 0);
  CHECK(std::abs(smoother.chi2() - reference.chi2) <= 1e-6 * reference.chi2);
}

TEST_CASE("urgent_iterations: every update converged within itself (2D landmarks, 3D poses)") {
  lslam::SolverOptions options;
  options.relinearize_threshold = 1e-9;
  options.relinearize_urgent_threshold = 1e-9;
  options.relinearize_partial_threshold = 0.0;
  options.backsubstitution_tolerance = 0.0;
  options.urgent_iterations = 30;
  auto smoother2 = std::make_unique<Smoother2D>(options);
  checkConvergedOnline(stream2D(21, 60, 20), *smoother2);
  auto smoother3 = std::make_unique<SmootherPoses3D>(options);
  checkConvergedOnline(stream3D<PoseSlam3D>(23, 80, 0), *smoother3);
}

// With the default options a graph below converge_below_variables converges within each update:
// the last update's estimate is at the optimum up to the relinearization threshold's share, and
// nearer it than the same updates taken one step each.
template <class Model, class S>
void checkSmallGraphConverges(const Stream<Model>& stream, S& smoother, S& one_step) {
  REQUIRE(static_cast<Index>(stream.initial.size()) < smoother.options().converge_below_variables);
  int iterated = 0;
  for (const Step<Model>& st : stream.steps) {
    lslam::UpdateResult r;
    REQUIRE(feed(smoother, st, &r) == Status::Ok);
    REQUIRE(feed(one_step, st) == Status::Ok);
    iterated += r.iterations > 0 ? 1 : 0;
  }
  const sim::ModelBatchResult reference = batch(stream.dataset, stream.initial);
  REQUIRE(reference.converged);
  const double excess = smoother.chi2() / reference.chi2 - 1.0;
  const double one_step_excess = one_step.chi2() / reference.chi2 - 1.0;
  MESSAGE(iterated << " of " << stream.steps.size() << " updates iterated; chi2 excess " << excess
                   << ", one step per update " << one_step_excess);
  CHECK(iterated > 0);
  CHECK(excess >= -1e-9);
  CHECK(excess <= 1e-4);
  CHECK(excess < one_step_excess);
}

TEST_CASE("a graph below converge_below_variables converges within each update (defaults)") {
  lslam::SolverOptions off = lslam::defaultSolverOptions<PoseSlam3D>();
  off.converge_below_variables = 0;
  auto smoother3 = std::make_unique<SmootherPoses3D>();
  auto one_step3 = std::make_unique<SmootherPoses3D>(off);
  checkSmallGraphConverges(stream3D<PoseSlam3D>(23, 80, 0), *smoother3, *one_step3);
  lslam::SolverOptions off2 = lslam::defaultSolverOptions<Slam2D>();
  off2.converge_below_variables = 0;
  auto smoother2 = std::make_unique<Smoother2D>();
  auto one_step2 = std::make_unique<Smoother2D>(off2);
  checkSmallGraphConverges(stream2D(21, 60, 20), *smoother2, *one_step2);
}

// Per variable kind, each relinearization takes exactly the variables whose delta (the solve's
// before it) is past their kind's relinearize_threshold_of_kind: the taken ones restart at zero,
// the others keep their delta bit for bit. With the partial bar off every relinearizing update
// takes its kind's threshold. Returns how many of each kind were relinearized.
std::array<int, 2> relinearizedByKind(const Stream<Slam2D>& stream, double pose_threshold,
                                      double landmark_threshold) {
  lslam::SolverOptions o = lslam::defaultSolverOptions<Slam2D>();
  o.relinearize_threshold_of_kind[0] = pose_threshold;
  o.relinearize_threshold_of_kind[1] = landmark_threshold;
  o.relinearize_partial_threshold = 0.0;
  o.converge_below_variables = 0;  // one relinearization at most per update
  o.solve_after_update = false;
  auto solver = std::make_unique<Smoother2D>(o);
  const double bar[2] = {pose_threshold, landmark_threshold};
  const int size[2] = {3, 2};
  std::array<int, 2> relinearized = {0, 0};
  for (std::size_t k = 0; k < stream.steps.size(); ++k) {
    CAPTURE(k);
    std::vector<Vec3> before;
    for (Index v = 0; v < solver->variables(); ++v) before.push_back(solver->deltaAt(v));
    lslam::UpdateResult r;
    REQUIRE(feed(*solver, stream.steps[k], &r) == Status::Ok);
    Index expected = 0;
    bool past = false;
    for (Index v = 0; v < static_cast<Index>(before.size()); ++v) {
      CAPTURE(v);
      const int kind = solver->kindAt(v);
      const Eigen::VectorXd was = before[static_cast<std::size_t>(v)].head(size[kind]);
      const Eigen::VectorXd now = solver->deltaAt(v).head(size[kind]);
      past = past || was.cwiseAbs().maxCoeff() > bar[kind];
      if (r.variables_relinearized > 0 && was.cwiseAbs().maxCoeff() > bar[kind]) {
        CHECK(now.isZero(0.0));
        ++expected;
        ++relinearized[static_cast<std::size_t>(kind)];
      } else {
        CHECK(std::equal(now.data(), now.data() + now.size(), was.data()));
      }
    }
    CHECK(r.variables_relinearized == expected);
    if (r.reordered && past) CHECK(r.variables_relinearized > 0);  // a reordering takes them all
    solver->solve(false);
  }
  return relinearized;
}

TEST_CASE("relinearize_threshold_of_kind: each kind is relinearized past its own threshold") {
  const Stream<Slam2D> stream = stream2D(41, 150, 30);
  const std::array<int, 2> poses_only = relinearizedByKind(stream, 0.01, 1e9);
  CHECK(poses_only[0] > 0);
  CHECK(poses_only[1] == 0);
  const std::array<int, 2> landmarks_only = relinearizedByKind(stream, 1e9, 0.01);
  CHECK(landmarks_only[0] == 0);
  CHECK(landmarks_only[1] > 0);
  // Both kinds, landmarks at a finer bar than poses: more landmarks are taken than at 0.01.
  const std::array<int, 2> both = relinearizedByKind(stream, 0.01, 0.001);
  MESSAGE("relinearized (poses, landmarks): " << poses_only[0] << ", " << poses_only[1] << "; "
                                              << landmarks_only[0] << ", " << landmarks_only[1]
                                              << "; " << both[0] << ", " << both[1]);
  CHECK(both[0] > 0);
  CHECK(both[1] > landmarks_only[1]);
}

// ---- Rejections ---------------------------------------------------------------------------------

// Each rejected call changes no bit, and the valid step after it gives the bits a twin fed only
// the valid steps has.
template <class Model, class S, class MakeRejected>
void checkRejections(const Stream<Model>& stream, S& solver, S& twin, int kinds,
                     MakeRejected make_rejected) {
  int tested = 0;
  for (std::size_t k = 0; k < stream.steps.size(); ++k) {
    CAPTURE(k);
    if (k >= 5) {
      const int kind = static_cast<int>(k % static_cast<std::size_t>(kinds));
      CAPTURE(kind);
      Status expected = Status::Ok;
      const Step<Model> bad = make_rejected(kind, k, &expected);
      const std::vector<double> before = snapshot(solver);
      lslam::UpdateResult r;
      const Status got =
          solver.update(bad.variables.data(), static_cast<Index>(bad.variables.size()),
                        bad.factors.data(), static_cast<Index>(bad.factors.size()), &r);
      CHECK(got == expected);
      CHECK(r.status == got);
      CHECK(sameBits(before, snapshot(solver)));
      ++tested;
    }
    REQUIRE(feed(solver, stream.steps[k]) == Status::Ok);
    REQUIRE(feed(twin, stream.steps[k]) == Status::Ok);
    CHECK(sameBits(snapshot(solver), snapshot(twin)));
  }
  CHECK(tested > 3 * kinds);
}

TEST_CASE("Slam2D: a rejected update of each kind changes nothing") {
  using Var = lslam::ModelVariableInput<Slam2D>;
  using Fac = lslam::ModelFactorInput<Slam2D>;
  const Stream<Slam2D> stream = stream2D(5, 70, 40);
  auto solver = std::make_unique<Smoother2D>();
  auto twin = std::make_unique<Smoother2D>();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto make = [&](int kind, std::size_t k, Status* expected) {
    Step<Slam2D> bad = stream.steps[k];  // the next step, spoiled
    const auto n = static_cast<lslam::VariableId>(k);
    switch (kind) {
      case 0:  // a NaN initial value
        bad.variables[0] = Var::make(n, SE2(nan, 0.0, 0.0));
        *expected = Status::NonFiniteInput;
        break;
      case 1:  // an unknown pose id
        bad.factors.push_back(
            Fac::make<lslam::BetweenSE2Factor>(n + 500, n, SE2(), Mat3::Identity()));
        *expected = Status::UnknownVariable;
        break;
      case 2:  // a landmark no factor observes
        bad.variables.push_back(Var::make(1000, Point2(Vec2(1.0, 2.0))));
        *expected = Status::UnconstrainedVariable;
        break;
      case 3:  // a pose seen only through landmarks
        bad.variables.push_back(Var::make(n + 1000, SE2()));
        bad.variables.push_back(Var::make(1001, Point2(Vec2(1.0, 2.0))));
        bad.factors.push_back(
            Fac::make<lslam::PointObservationSE2Factor>(n, 1001, Vec2(1.0, 0.0), Mat2::Identity()));
        bad.factors.push_back(Fac::make<lslam::PointObservationSE2Factor>(
            n + 1000, 1001, Vec2(1.0, 0.0), Mat2::Identity()));
        *expected = Status::UnconstrainedVariable;
        break;
      case 4:  // more landmarks than the capacity, each observed
        for (int l = 0; l <= Smoother2D::max_landmarks; ++l) {
          bad.variables.push_back(Var::make(2000 + l, Point2(Vec2(1.0, 0.0))));
          bad.factors.push_back(Fac::make<lslam::PointObservationSE2Factor>(
              n, 2000 + l, Vec2(1.0, 0.0), Mat2::Identity()));
        }
        *expected = Status::CapacityExhausted;
        break;
      case 5:  // a landmark placed beyond kMaxCoordinate (finite, absurd)
        bad.variables.push_back(Var::make(4000, Point2(Vec2(0.0, 2.0 * lslam::kMaxCoordinate))));
        bad.factors.push_back(Fac::make<lslam::PointObservationSE2Factor>(
            n - 1, 4000, Vec2(1.0, 0.0), Mat2::Identity()));
        *expected = Status::InvalidArgument;
        break;
      default:  // information not positive definite
        bad.factors[0] = Fac::make<lslam::BetweenSE2Factor>(n - 1, n, SE2(), -Mat3::Identity());
        *expected = Status::InformationNotPositiveDefinite;
        break;
    }
    return bad;
  };
  checkRejections(stream, *solver, *twin, 7, make);
}

TEST_CASE("Slam3D: a rejected update of each kind changes nothing") {
  using Var = lslam::ModelVariableInput<Slam3D>;
  using Fac = lslam::ModelFactorInput<Slam3D>;
  const Stream<Slam3D> stream = stream3D(9, 60, 40);
  auto solver = std::make_unique<Smoother3D>();
  auto twin = std::make_unique<Smoother3D>();
  const SE3 long_q(lslam::SO3(Eigen::Quaterniond(1.0, 0.1, 0.0, 0.0)), Vec3::Zero());
  const auto make = [&](int kind, std::size_t k, Status* expected) {
    Step<Slam3D> bad = stream.steps[k];
    const auto n = static_cast<lslam::VariableId>(k);
    switch (kind) {
      case 0:  // a non-unit quaternion in an initial value
        bad.variables[0] = Var::make(n, long_q);
        *expected = Status::InvalidArgument;
        break;
      case 1:  // ...and in a measurement
        bad.factors[0] = Fac::make<lslam::BetweenSE3Factor>(n - 1, n, long_q, Mat6::Identity());
        *expected = Status::InvalidArgument;
        break;
      case 2:  // a NaN measurement
        bad.factors[0] = Fac::make<lslam::BetweenSE3Factor>(
            n - 1, n, SE3(lslam::SO3(), Vec3(std::nan(""), 0.0, 0.0)), Mat6::Identity());
        *expected = Status::NonFiniteInput;
        break;
      case 3:  // an unknown landmark id
        bad.factors.push_back(
            Fac::make<lslam::PointObservationSE3Factor>(n, 777, Vec3(1, 0, 0), Mat3::Identity()));
        *expected = Status::UnknownVariable;
        break;
      case 4:  // a pose seen only through a landmark (which the step's pose holds)
        bad.variables.push_back(Var::make(n + 1000, SE3()));
        bad.variables.push_back(Var::make(3001, Point3(Vec3(1, 0, 0))));
        bad.factors.push_back(
            Fac::make<lslam::PointObservationSE3Factor>(n, 3001, Vec3(1, 0, 0), Mat3::Identity()));
        bad.factors.push_back(Fac::make<lslam::PointObservationSE3Factor>(
            n + 1000, 3001, Vec3(1, 0, 0), Mat3::Identity()));
        *expected = Status::UnconstrainedVariable;
        break;
      case 5:  // a translation beyond kMaxCoordinate (finite, absurd)
        bad.factors[0] = Fac::make<lslam::BetweenSE3Factor>(
            n - 1, n, SE3(lslam::SO3(), Vec3(0.0, 0.0, -1.5 * lslam::kMaxCoordinate)),
            Mat6::Identity());
        *expected = Status::InvalidArgument;
        break;
      case 6: {  // a 6x6 information with one negative eigenvalue (symmetric, finite)
        Mat6 indefinite = Mat6::Identity();
        indefinite(1, 4) = indefinite(4, 1) = 2.0;
        bad.factors[0] = Fac::make<lslam::BetweenSE3Factor>(n - 1, n, SE3(), indefinite);
        *expected = Status::InformationNotPositiveDefinite;
        break;
      }
      case 7:  // a NaN quaternion coefficient in a measurement
        bad.factors[0] = Fac::make<lslam::BetweenSE3Factor>(
            n - 1, n,
            SE3(lslam::SO3(Eigen::Quaterniond(1.0, std::nan(""), 0.0, 0.0)), Vec3::Zero()),
            Mat6::Identity());
        *expected = Status::NonFiniteInput;
        break;
      case 8: {  // an observation's 3x3 information that is singular
        Mat3 singular = Mat3::Identity();
        singular(2, 2) = 0.0;
        bad.factors.push_back(
            Fac::make<lslam::PointObservationSE3Factor>(n, 3001, Vec3(1, 0, 0), singular));
        bad.variables.push_back(Var::make(3001, Point3(Vec3(1, 0, 0))));
        *expected = Status::InformationNotPositiveDefinite;
        break;
      }
      default:  // more poses than the capacity
        for (int p = 0; p < Smoother3D::max_poses; ++p) {
          bad.variables.push_back(Var::make(5000 + p, SE3()));
          bad.factors.push_back(
              Fac::make<lslam::BetweenSE3Factor>(n - 1, 5000 + p, SE3(), Mat6::Identity()));
        }
        *expected = Status::CapacityExhausted;
        break;
    }
    return bad;
  };
  checkRejections(stream, *solver, *twin, 10, make);
}

// ---- reorder() ----------------------------------------------------------------------------------

// Options under which only the caller reorders and nothing relinearizes: the solution is then that
// of one linear system whatever the order.
lslam::SolverOptions linearInCallersOrder() {
  lslam::SolverOptions o = lslam::defaultSolverOptions<PoseSlam2D>();
  o.relinearize_threshold = 1e9;
  o.relinearize_urgent_threshold = 1e9;
  o.converge_below_variables = 0;
  o.reorder_min_variables = 1000000;
  return o;
}

TEST_CASE("reorder(): a fresh order gives the same solution in less fill") {
  const Stream<PoseSlam2D> stream = stream2D<PoseSlam2D>(31, 160, 0);
  auto solver = std::make_unique<SmootherPoses2D>(linearInCallersOrder());
  auto twin = std::make_unique<SmootherPoses2D>(linearInCallersOrder());
  int reorders = 0;
  int less_fill = 0;
  for (std::size_t k = 0; k < stream.steps.size(); ++k) {
    CAPTURE(k);
    REQUIRE(feed(*solver, stream.steps[k]) == Status::Ok);
    REQUIRE(feed(*twin, stream.steps[k]) == Status::Ok);
    if (k < 20 || k % 30 != 0) continue;
    const Index chronological = twin->factorBlocks();
    lslam::UpdateResult r;
    REQUIRE(solver->reorder(&r) == Status::Ok);
    CHECK(r.status == Status::Ok);
    CHECK(r.reordered);
    CHECK(r.refactored_fully);
    CHECK(r.variables_added == 0);
    CHECK(solver->blocksAtLastOrder() == solver->factorBlocks());
    // The twin never reorders (reorder_min_variables): its order is the chronological one, whose
    // fill COLAMD undercuts once the graph has loop closures far apart in time.
    CHECK(solver->factorBlocks() <= chronological);
    less_fill += solver->factorBlocks() < chronological ? 1 : 0;
    ++reorders;
    solver->solve(true);
    twin->solve(true);
    for (Index v = 0; v < solver->variables(); ++v) {
      CAPTURE(v);
      CHECK((solver->deltaAt(v) - twin->deltaAt(v)).cwiseAbs().maxCoeff() < 1e-9);
    }
  }
  CHECK(reorders >= 4);
  CHECK(less_fill >= 3);
}

TEST_CASE("reorder() that finds no room for the new factor beside the live one changes nothing") {
  // A chain with short loop closures: an update stages a few columns, a reordering a whole factor.
  // The pool holds the live factor and an update's columns, not a second factor.
  using Tight = lslam::StaticSmoother<PoseSlam2D, 128, 0, 256, 256 * 12, 400, 0>;
  using Var = lslam::ModelVariableInput<PoseSlam2D>;
  using Fac = lslam::ModelFactorInput<PoseSlam2D>;
  auto solver = std::make_unique<Tight>(linearInCallersOrder());
  auto twin = std::make_unique<Tight>(linearInCallersOrder());
  const Mat3 info = Eigen::Vector3d(400.0, 400.0, 10000.0).asDiagonal();
  int refused = 0;
  for (lslam::VariableId i = 0; i < 120; ++i) {
    CAPTURE(i);
    const SE2 z(1.0, 0.01 * static_cast<double>(i % 5), 0.05);
    Var v = Var::make(i, SE2());
    std::vector<Fac> f;
    if (i > 0) {
      v = Var::make(i, solver->estimateAt<SE2>(static_cast<Index>(i - 1)).compose(z));
      f.push_back(Fac::make<lslam::BetweenSE2Factor>(i - 1, i, z, info));
    }
    if (i >= 3 && i % 4 == 0)
      f.push_back(Fac::make<lslam::BetweenSE2Factor>(i - 3, i, SE2(2.9, 0.1, 0.15), info));
    for (auto* s : {static_cast<lslam::Smoother<PoseSlam2D>*>(solver.get()),
                    static_cast<lslam::Smoother<PoseSlam2D>*>(twin.get())}) {
      REQUIRE(s->update(&v, 1, f.data(), static_cast<Index>(f.size())) == Status::Ok);
    }
    if (2 * solver->factorBlocks() <= Tight::max_factor_blocks) continue;
    const std::vector<double> before = snapshot(*solver);
    const Index blocks = solver->factorBlocks();
    lslam::UpdateResult r;
    CHECK(solver->reorder(&r) == Status::CapacityExhausted);
    CHECK(r.status == Status::CapacityExhausted);
    CHECK(sameBits(before, snapshot(*solver)));
    CHECK(solver->factorBlocks() == blocks);
    ++refused;
  }
  CHECK(refused > 5);
  // ... and the steps after each refusal went on exactly as the twin's, which was never asked.
  CHECK(sameBits(snapshot(*solver), snapshot(*twin)));
}

TEST_CASE("the caller's first pose prior takes the anchor out") {
  using Var = lslam::ModelVariableInput<Slam2D>;
  using Fac = lslam::ModelFactorInput<Slam2D>;
  auto s = std::make_unique<Smoother2D>();
  // A landmark input first: the anchor holds the first pose input, not input 0.
  const std::vector<Var> first = {Var::make(0, Point2(Vec2(1.0, 0.0))), Var::make(0, SE2())};
  const std::vector<Fac> obs = {
      Fac::make<lslam::PointObservationSE2Factor>(0, 0, Vec2(1.0, 0.0), Mat2::Identity())};
  REQUIRE(s->update(first.data(), 2, obs.data(), 1) == Status::Ok);
  CHECK(s->anchorFactor() == 1);
  CHECK(s->chi2() == 0.0);
  const std::vector<Var> second = {Var::make(1, SE2(1.0, 0.0, 0.0))};
  const std::vector<Fac> prior = {
      Fac::make<lslam::BetweenSE2Factor>(0, 1, SE2(1.0, 0.0, 0.0), Mat3::Identity()),
      Fac::make<lslam::PriorSE2Factor>(1, SE2(3.0, 0.0, 0.0), Mat3::Identity())};
  lslam::UpdateResult r;
  REQUIRE(s->update(second.data(), 1, prior.data(), 2, &r) == Status::Ok);
  CHECK(r.refactored_fully);
  CHECK(s->anchorFactor() == lslam::kNoIndex);
  REQUIRE(s->optimize(20, 1e-12) == Status::Ok);
  // Without the anchor the prior is met exactly: every factor at zero error.
  SE2 x1;
  REQUIRE(s->estimate(lslam::VariableId{1}, &x1) == Status::Ok);
  CHECK(x1.x() == doctest::Approx(3.0).epsilon(1e-9));
  CHECK(s->chi2() < 1e-16);
}

}  // namespace

// ---- A reordering spread over updates
// -------------------------------------------------------------

namespace {

using SpreadPoses2D = lslam::StaticSmoother<PoseSlam2D, 400, 0, 1600, 1600 * 12, 24000, 0, 64>;

// Reorderings dearer than a few hundred block products spread over the next updates.
lslam::SolverOptions spreadEarly(lslam::SolverOptions o) {
  o.spread_reorder_products = 300;
  o.reorder_min_variables = 20;
  return o;
}

// A spread smoother and a twin that reorders in one update, fed `stream` with nothing
// relinearizing: every factorization, in any order, solves the same linear system, so the twin's
// solution is the reference at every step. Returns the reorderings swapped in.
template <class Model, class S>
int checkSpreadAgainstOneUpdate(const Stream<Model>& stream) {
  lslam::SolverOptions linear = spreadEarly(linearInCallersOrder());
  linear.partial_backsubstitution = false;
  lslam::SolverOptions at_once = linear;
  at_once.spread_reorder_products = 0;
  auto solver = std::make_unique<S>(linear);
  auto twin = std::make_unique<S>(at_once);
  int started = 0;
  int swapped = 0;
  int steps_building = 0;
  bool building = false;
  for (std::size_t k = 0; k < stream.steps.size(); ++k) {
    CAPTURE(k);
    lslam::UpdateResult r;
    REQUIRE(feed(*solver, stream.steps[k], &r) == Status::Ok);
    REQUIRE(feed(*twin, stream.steps[k]) == Status::Ok);
    CHECK_FALSE(r.spread_abandoned);
    started += r.spread_started ? 1 : 0;
    swapped += r.spread_swapped ? 1 : 0;
    steps_building += building ? 1 : 0;
    building = (building || r.spread_started) && !r.spread_swapped;
    for (Index v = 0; v < solver->variables(); ++v) {
      CAPTURE(v);
      REQUIRE((solver->deltaAt(v) - twin->deltaAt(v)).cwiseAbs().maxCoeff() < 1e-9);
    }
  }
  MESSAGE(started << " spread reorderings, " << swapped << " swapped in, over " << steps_building
                  << " updates");
  CHECK(started - swapped <= 1);         // the last may still be building
  CHECK(steps_building >= 2 * swapped);  // spread indeed: several updates each
  return swapped;
}

}  // namespace

TEST_CASE("a spread reordering gives the solution of the factor it replaces (a linear problem)") {
  using SpreadSlam2D =
      lslam::StaticSmoother<Slam2D, 160, 40, 1600, 1600 * 12, 24000, 24000 * 9, 64>;
  using SpreadSlam3D =
      lslam::StaticSmoother<Slam3D, 130, 40, 1600, 1600 * 43, 20000, 20000 * 36, 64>;
  for (const unsigned seed : {31u, 32u, 33u}) {
    CAPTURE(seed);
    const int swapped =
        checkSpreadAgainstOneUpdate<PoseSlam2D, SpreadPoses2D>(stream2D<PoseSlam2D>(seed, 160, 0));
    CHECK(swapped >= 3);
  }
  // Mixed block sizes: landmarks in 2D and 3D.
  CHECK(checkSpreadAgainstOneUpdate<Slam2D, SpreadSlam2D>(stream2D<Slam2D>(35, 150, 40)) >= 1);
  CHECK(checkSpreadAgainstOneUpdate<Slam3D, SpreadSlam3D>(stream3D<Slam3D>(36, 120, 40)) >= 1);
}

TEST_CASE(
    "spread reorderings: the batch optimum, and a rejected update mid-build changes nothing") {
  using Var = lslam::ModelVariableInput<PoseSlam2D>;
  using Fac = lslam::ModelFactorInput<PoseSlam2D>;
  // Every relinearization waits for a reordering (as on a revisit-heavy map, where each costs
  // about a refactorization): the spread reorderings relinearize.
  lslam::SolverOptions options = spreadEarly(lslam::defaultSolverOptions<PoseSlam2D>());
  options.relinearize_defer_products = 1;
  const Stream<PoseSlam2D> stream = stream2D<PoseSlam2D>(34, 160, 0);
  auto solver = std::make_unique<SpreadPoses2D>(options);
  auto twin = std::make_unique<SpreadPoses2D>(options);
  bool building = false;
  int swapped = 0;
  int rejected_mid_build = 0;
  for (std::size_t k = 0; k < stream.steps.size(); ++k) {
    CAPTURE(k);
    if (building) {
      // An odometry factor from an unknown pose, then a pose that is not finite: each rejected.
      const Step<PoseSlam2D>& step = stream.steps[k];
      Step<PoseSlam2D> bad = step;
      bad.factors.push_back(Fac::make<lslam::BetweenSE2Factor>(
          static_cast<lslam::VariableId>(100000), step.variables[0].id, SE2(1.0, 0.0, 0.0),
          Mat3::Identity()));
      const std::vector<double> before = snapshot(*solver);
      CHECK(feed(*solver, bad) == Status::UnknownVariable);
      CHECK(sameBits(before, snapshot(*solver)));
      const Var nan_pose = Var::make(step.variables[0].id, SE2(std::nan(""), 0.0, 0.0));
      CHECK(solver->update(&nan_pose, 1, step.factors.data(),
                           static_cast<Index>(step.factors.size())) == Status::NonFiniteInput);
      CHECK(sameBits(before, snapshot(*solver)));
      ++rejected_mid_build;
    }
    lslam::UpdateResult r;
    REQUIRE(feed(*solver, stream.steps[k], &r) == Status::Ok);
    REQUIRE(feed(*twin, stream.steps[k]) == Status::Ok);
    CHECK(sameBits(snapshot(*solver), snapshot(*twin)));
    swapped += r.spread_swapped ? 1 : 0;
    building = (building || r.spread_started) && !r.spread_swapped && !r.spread_abandoned;
  }
  CHECK(swapped >= 3);
  CHECK(rejected_mid_build >= 6);
  // Gauss-Newton (which gives up a build in progress) reaches the batch optimum. (Online, this
  // stream's chi2 swings with each relinearization, whose updates a spread reordering moves.)
  const sim::ModelBatchResult reference = batch(stream.dataset, stream.initial);
  REQUIRE(reference.converged);
  REQUIRE(solver->optimize(50, 1e-10) == Status::Ok);
  CHECK(std::abs(solver->chi2() - reference.chi2) <= 1e-6 * reference.chi2);
}
