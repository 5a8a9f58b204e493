// Tests of the trajectory-error scoring (host_sim/trajectory_error.h): estimates built from random
// truths by a known rigid motion (with and without noise), mirrored truths, the optimum checked
// against Eigen::umeyama and a search over angles, degenerate inputs, orientation errors of known
// angles, ground truth from vertices and chained from iSAM edges (poses composed here with
// homogeneous matrices), the sphere2500 ground truth, and the error cases.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "dataset_files.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/trajectory_error.h"
#include "model_test_support.h"

using namespace lslam::sim;
using namespace lslam::sim::test;

namespace {

using Kinds = std::unordered_map<VariableKey, VariableKind, VariableKeyHash>;

constexpr double kPi = 3.14159265358979323846;

// A problem: values and kinds, in `dimension`.
struct Problem {
  int dimension = 2;
  ModelEstimate values;
  Kinds kinds;
};

Eigen::Quaterniond randomQuaternion(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

Eigen::VectorXd randomValue(std::mt19937& rng, VariableKind kind) {
  std::uniform_real_distribution<double> u(-50.0, 50.0);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  if (kind == VariableKind::SE2) return Eigen::Vector3d(u(rng), u(rng), angle(rng));
  if (kind == VariableKind::Point2) return Eigen::Vector2d(u(rng), u(rng));
  if (kind == VariableKind::Point3) return Eigen::Vector3d(u(rng), u(rng), u(rng));
  const Eigen::Quaterniond q = randomQuaternion(rng);
  Vector7d p;
  p << u(rng), u(rng), u(rng), q.x(), q.y(), q.z(), q.w();
  return p;
}

Problem randomProblem(std::mt19937& rng, int dimension, int poses, int landmarks) {
  Problem p;
  p.dimension = dimension;
  const VariableKind pose_kind = dimension == 2 ? VariableKind::SE2 : VariableKind::SE3;
  const VariableKind point_kind = dimension == 2 ? VariableKind::Point2 : VariableKind::Point3;
  for (int i = 0; i < poses; ++i) {
    p.values[pose(i)] = randomValue(rng, pose_kind);
    p.kinds[pose(i)] = pose_kind;
  }
  for (int i = 0; i < landmarks; ++i) {
    p.values[landmark(i)] = randomValue(rng, point_kind);
    p.kinds[landmark(i)] = point_kind;
  }
  return p;
}

// A random rigid motion as a homogeneous matrix of size dimension + 1.
Eigen::MatrixXd randomMotion(std::mt19937& rng, int dimension) {
  std::uniform_real_distribution<double> u(-100.0, 100.0);
  std::uniform_real_distribution<double> angle(-kPi, kPi);
  Eigen::MatrixXd m = Eigen::MatrixXd::Identity(dimension + 1, dimension + 1);
  if (dimension == 2) {
    m.topLeftCorner(2, 2) = Eigen::Rotation2Dd(angle(rng)).matrix();
  } else {
    m.topLeftCorner(3, 3) = randomQuaternion(rng).matrix();
  }
  for (int k = 0; k < dimension; ++k) m(k, dimension) = u(rng);
  return m;
}

// `motion` applied to a value: a pose M X (position and orientation), a point M p.
Eigen::VectorXd moved(const Eigen::MatrixXd& motion, VariableKind kind, const Eigen::VectorXd& v) {
  if (kind == VariableKind::SE2) return fromH2(Eigen::Matrix3d(motion) * h2(v));
  if (kind == VariableKind::SE3) return fromH3(Eigen::Matrix4d(motion) * h3(v));
  const int d = static_cast<int>(v.size());
  return motion.topLeftCorner(d, d) * v + motion.topRightCorner(d, 1);
}

ModelEstimate movedValues(const Eigen::MatrixXd& motion, const Problem& p) {
  ModelEstimate out;
  for (const auto& [key, value] : p.values) out[key] = moved(motion, p.kinds.at(key), value);
  return out;
}

// Gaussian noise of standard deviation `sigma` added to every position; returns the RMSE of the
// noise over the keys of `role`.
double addPositionNoise(std::mt19937& rng, double sigma, int dimension, VariableRole role,
                        ModelEstimate& values) {
  std::normal_distribution<double> n(0.0, sigma);
  double sum = 0.0;
  std::size_t count = 0;
  for (auto& [key, value] : values) {
    Eigen::VectorXd noise(dimension);
    for (int k = 0; k < dimension; ++k) noise[k] = n(rng);
    value.head(dimension) += noise;
    if (key.role == role) {
      sum += noise.squaredNorm();
      ++count;
    }
  }
  return std::sqrt(sum / static_cast<double>(count));
}

// The RMSE of the positions of `role` in `estimate` after `a`, against `truth`.
double positionRmse(const RigidAlignment& a, const ModelEstimate& estimate,
                    const ModelEstimate& truth, int dimension, VariableRole role) {
  double sum = 0.0;
  std::size_t count = 0;
  for (const auto& [key, value] : estimate) {
    if (key.role != role || truth.count(key) == 0) continue;
    const Eigen::VectorXd p = value.head(dimension);
    sum += (a.rotation * p + a.translation - truth.at(key).head(dimension)).squaredNorm();
    ++count;
  }
  return std::sqrt(sum / static_cast<double>(count));
}

std::vector<Eigen::VectorXd> posePositions(const ModelEstimate& values, int poses, int dimension) {
  std::vector<Eigen::VectorXd> out;
  for (int i = 0; i < poses; ++i) out.push_back(values.at(pose(i)).head(dimension));
  return out;
}

// The inverse of `motion` must be the alignment taking the moved estimate back onto the truth.
void checkInverseOfMotion(const RigidAlignment& a, const Eigen::MatrixXd& motion, int dimension) {
  const Eigen::MatrixXd inverse = motion.inverse();
  CHECK((a.rotation - inverse.topLeftCorner(dimension, dimension)).norm() < 1e-9);
  CHECK((a.translation - inverse.topRightCorner(dimension, 1)).norm() < 1e-9);
}

void exactMisalignmentCases(int dimension) {
  std::mt19937 rng(20240601 + dimension);
  std::uniform_int_distribution<int> poses(3, 30);
  std::uniform_int_distribution<int> landmarks(0, 10);
  for (int trial = 0; trial < 300; ++trial) {
    const Problem truth = randomProblem(rng, dimension, poses(rng), landmarks(rng));
    const Eigen::MatrixXd motion = randomMotion(rng, dimension);
    const ModelEstimate estimate = movedValues(motion, truth);
    const TrajectoryError e = trajectoryError(estimate, truth.values, dimension, truth.kinds);
    INFO("trial " << trial);
    CHECK(e.ate_position_rmse < 1e-9);
    CHECK(e.ate_rotation_rmse_deg < 1e-9);
    CHECK(e.landmark_rmse < 1e-9);
    checkInverseOfMotion(e.alignment, motion, dimension);
    // The truth carried back into the estimate's frame is the estimate.
    const ModelEstimate back = inEstimateFrame(truth.values, e.alignment);
    REQUIRE(back.size() == estimate.size());
    for (const auto& [key, value] : estimate) {
      const Eigen::VectorXd& b = back.at(key);
      CHECK((b.head(dimension) - value.head(dimension)).norm() < 1e-9);
      if (key.role == VariableRole::Landmark) continue;
      if (dimension == 2) {
        CHECK(std::abs(std::remainder(b[2] - value[2], 2.0 * kPi)) < 1e-9);
      } else {  // the same rotation: q or -q
        CHECK(std::abs(std::abs(b.tail<4>().dot(value.tail<4>())) - 1.0) < 1e-9);
      }
    }
  }
}

// The truth moved by a random motion, then noise of `sigma` on every position; the noise's RMSE
// over the poses and over the landmarks (through the exact inverse motion) are returned too.
TrajectoryError scoreAgainstMovedNoisyCopy(std::mt19937& rng, const Problem& truth, double sigma,
                                           double& noise_rmse, double& landmark_noise_rmse) {
  const Eigen::MatrixXd motion = randomMotion(rng, truth.dimension);
  ModelEstimate estimate = movedValues(motion, truth);
  noise_rmse = addPositionNoise(rng, sigma, truth.dimension, VariableRole::Pose, estimate);
  RigidAlignment inverse;
  const Eigen::MatrixXd m = motion.inverse();
  inverse.rotation = m.topLeftCorner(truth.dimension, truth.dimension);
  inverse.translation = m.topRightCorner(truth.dimension, 1);
  landmark_noise_rmse =
      positionRmse(inverse, estimate, truth.values, truth.dimension, VariableRole::Landmark);
  return trajectoryError(estimate, truth.values, truth.dimension, truth.kinds);
}

// Orientation of a value rotated by `angle` about `axis` in its own frame.
Eigen::VectorXd turned(const Eigen::VectorXd& v, double angle, const Eigen::Vector3d& axis) {
  if (v.size() == 3) return Eigen::Vector3d(v[0], v[1], v[2] + angle);
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = Eigen::AngleAxisd(angle, axis.normalized()).matrix();
  return fromH3(h3(v) * t);
}

std::string tempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("lslam_test_trajectory_error_" + name))
      .string();
}

// iSAM's EDGE3 rotation from the file's roll, pitch, yaw: Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Matrix4d isamPose3(double x, double y, double z, double roll, double pitch, double yaw) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                .matrix();
  t.topRightCorner<3, 1>() = Eigen::Vector3d(x, y, z);
  return t;
}

}  // namespace

TEST_CASE("alignment of a truth moved by a known rigid motion: zero errors, the inverse motion") {
  SUBCASE("2D") {
    exactMisalignmentCases(2);
  }
  SUBCASE("3D") {
    exactMisalignmentCases(3);
  }
}

TEST_CASE("noise after the motion: the aligned RMSE is at most the noise's, and close to it") {
  for (int dimension = 2; dimension <= 3; ++dimension) {
    std::mt19937 rng(777 + dimension);
    for (int trial = 0; trial < 40; ++trial) {
      const Problem truth = randomProblem(rng, dimension, 400, 100);
      double noise = 0.0;
      double landmark_noise = 0.0;
      const TrajectoryError e = scoreAgainstMovedNoisyCopy(rng, truth, 0.5, noise, landmark_noise);
      INFO("dimension " << dimension << " trial " << trial);
      CHECK(e.poses == 400);
      CHECK(e.landmarks == 100);
      CHECK(e.ate_position_rmse <= noise + 1e-12);
      // Fitting dimension + dimension(dimension - 1)/2 parameters to 400 points removes a few
      // of the 400 * dimension residual degrees of freedom: well under 5 % of the RMSE.
      CHECK(e.ate_position_rmse >= 0.95 * noise);
      // Landmarks do not enter the fit: their RMSE stays near their own noise.
      CHECK(std::abs(e.landmark_rmse - landmark_noise) < 0.1 * landmark_noise);
    }
  }
}

TEST_CASE("alignRigid is the least-squares optimum: Eigen::umeyama and small perturbations") {
  std::mt19937 rng(4242);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int dimension = 2; dimension <= 3; ++dimension) {
    for (int trial = 0; trial < 200; ++trial) {
      const int count = 3 + trial % 20;
      Eigen::MatrixXd est(dimension, count);
      Eigen::MatrixXd truth(dimension, count);
      for (int c = 0; c < count; ++c) {
        for (int r = 0; r < dimension; ++r) {
          est(r, c) = 10.0 * n(rng);
          truth(r, c) = 10.0 * n(rng);  // unrelated points: a large residual to minimise
        }
      }
      std::vector<Eigen::VectorXd> est_list;
      std::vector<Eigen::VectorXd> truth_list;
      for (int c = 0; c < count; ++c) {
        est_list.push_back(est.col(c));
        truth_list.push_back(truth.col(c));
      }
      const RigidAlignment a = alignRigid(est_list, truth_list);
      const Eigen::MatrixXd reference = Eigen::umeyama(est, truth, false);
      INFO("dimension " << dimension << " trial " << trial);
      CHECK(a.rotation.determinant() == doctest::Approx(1.0));
      CHECK((a.rotation - reference.topLeftCorner(dimension, dimension)).norm() < 1e-9);
      CHECK((a.translation - reference.topRightCorner(dimension, 1)).norm() < 1e-9);
      const auto cost = [&](const Eigen::MatrixXd& r, const Eigen::VectorXd& t) {
        return ((r * est).colwise() + t - truth).squaredNorm();
      };
      Eigen::MatrixXd turn = Eigen::MatrixXd::Identity(dimension, dimension);
      if (dimension == 2) {
        turn = Eigen::Rotation2Dd(1e-3 * n(rng)).matrix();
      } else {
        turn =
            Eigen::AngleAxisd(1e-3, Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized()).matrix();
      }
      const Eigen::VectorXd shift = Eigen::VectorXd::Constant(dimension, 1e-3 * n(rng));
      CHECK(cost(a.rotation, a.translation) <= cost(turn * a.rotation, a.translation) + 1e-9);
      CHECK(cost(a.rotation, a.translation) <= cost(a.rotation, a.translation + shift) + 1e-9);
    }
  }
}

TEST_CASE("a mirrored truth: a proper rotation, a clearly nonzero RMSE") {
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> u(-20.0, 20.0);
  for (int dimension = 2; dimension <= 3; ++dimension) {
    for (int trial = 0; trial < 50; ++trial) {
      std::vector<Eigen::VectorXd> est;
      std::vector<Eigen::VectorXd> truth;
      for (int i = 0; i < 10; ++i) {
        Eigen::VectorXd p(dimension);
        for (int k = 0; k < dimension; ++k) p[k] = u(rng);
        est.push_back(p);
        p[1] = -p[1];  // y -> -y: the reflection would fit exactly
        truth.push_back(p);
      }
      const RigidAlignment a = alignRigid(est, truth);
      double sum = 0.0;
      for (std::size_t i = 0; i < est.size(); ++i) {
        sum += (a.rotation * est[i] + a.translation - truth[i]).squaredNorm();
      }
      const double rmse = std::sqrt(sum / static_cast<double>(est.size()));
      INFO("dimension " << dimension << " trial " << trial << " rmse " << rmse);
      CHECK(a.rotation.determinant() == doctest::Approx(1.0).epsilon(1e-12));
      CHECK((a.rotation.transpose() * a.rotation - Eigen::MatrixXd::Identity(dimension, dimension))
                .norm() < 1e-12);
      CHECK(rmse > 1.0);  // points spread over +-20 m; the reflection's residual is 0
      if (dimension == 2) {
        // The 2D optimum by search over the angle (the translation is the centroids' then).
        double best = 1e300;
        for (int s = 0; s < 36000; ++s) {
          const Eigen::Matrix2d r = Eigen::Rotation2Dd(2.0 * kPi * s / 36000.0).matrix();
          Eigen::Vector2d me = Eigen::Vector2d::Zero();
          Eigen::Vector2d mt = Eigen::Vector2d::Zero();
          for (std::size_t i = 0; i < est.size(); ++i) {
            me += est[i];
            mt += truth[i];
          }
          const Eigen::Vector2d t = (mt - r * me) / static_cast<double>(est.size());
          double sq = 0.0;
          for (std::size_t i = 0; i < est.size(); ++i) {
            sq += (r * est[i] + t - truth[i]).squaredNorm();
          }
          best = std::min(best, std::sqrt(sq / static_cast<double>(est.size())));
        }
        CHECK(rmse <= best + 1e-9);
        CHECK(rmse >= best - 1e-2);  // the search's step, 1e-2 degrees, over +-20 m
      }
    }
  }
}

TEST_CASE("orientation errors of known angles, tiny and near pi") {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> angle(0.0, kPi);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int dimension = 2; dimension <= 3; ++dimension) {
    for (int trial = 0; trial < 50; ++trial) {
      const Problem truth = randomProblem(rng, dimension, 12, 0);
      const Eigen::MatrixXd motion = randomMotion(rng, dimension);
      ModelEstimate estimate = movedValues(motion, truth);
      std::vector<double> angles = {1e-7, 3.1415, 1e-12};
      while (angles.size() < 12) angles.push_back(angle(rng));
      double sum = 0.0;
      for (int i = 0; i < 12; ++i) {
        const Eigen::Vector3d axis(n(rng), n(rng), n(rng));
        estimate[pose(i)] = turned(estimate.at(pose(i)), angles[i], axis);
        sum += angles[i] * angles[i];
      }
      const double expected_deg = std::sqrt(sum / 12.0) * 180.0 / kPi;
      const TrajectoryError e = trajectoryError(estimate, truth.values, dimension, truth.kinds);
      INFO("dimension " << dimension << " trial " << trial);
      CHECK(e.ate_position_rmse < 1e-9);  // positions untouched
      CHECK(e.ate_rotation_rmse_deg == doctest::Approx(expected_deg).epsilon(1e-9));
    }
    // A single tiny error: atan2 of the sine and cosine parts keeps its relative accuracy.
    const Problem one = randomProblem(rng, dimension, 1, 0);
    ModelEstimate estimate = one.values;
    estimate[pose(0)] = turned(estimate.at(pose(0)), 1e-7, Eigen::Vector3d(1.0, 2.0, 3.0));
    const TrajectoryError e = trajectoryError(estimate, one.values, dimension, one.kinds);
    const double tiny_deg = 1e-7 * 180.0 / kPi;
    CHECK(std::abs(e.ate_rotation_rmse_deg - tiny_deg) < 1e-6 * tiny_deg);  // relative
  }
}

TEST_CASE("landmarks do not move the alignment") {
  std::mt19937 rng(5);
  for (int dimension = 2; dimension <= 3; ++dimension) {
    const Problem truth = randomProblem(rng, dimension, 20, 15);
    ModelEstimate estimate = movedValues(randomMotion(rng, dimension), truth);
    addPositionNoise(rng, 0.3, dimension, VariableRole::Pose, estimate);
    ModelEstimate poses_only = estimate;
    for (int i = 0; i < 15; ++i) {
      poses_only.erase(landmark(i));
      estimate[landmark(i)].head(dimension) += Eigen::VectorXd::Constant(dimension, 40.0);
    }
    const TrajectoryError with = trajectoryError(estimate, truth.values, dimension, truth.kinds);
    const TrajectoryError without =
        trajectoryError(poses_only, truth.values, dimension, truth.kinds);
    CHECK(with.landmarks == 15);
    CHECK(without.landmarks == 0);
    CHECK(without.landmark_rmse == 0.0);
    CHECK(with.alignment.rotation == without.alignment.rotation);
    CHECK(with.alignment.translation == without.alignment.translation);
    CHECK(with.ate_position_rmse == without.ate_position_rmse);
    CHECK(with.landmark_rmse == doctest::Approx(positionRmse(with.alignment, estimate, truth.values,
                                                             dimension, VariableRole::Landmark)));
    CHECK(with.landmark_rmse > 30.0);
  }
}

// One pose: the identity rotation and the difference of the positions; the orientation error is
// the whole relative orientation. Two poses: exact in 2D; in 3D the positions fit but the rotation
// about their line is the SVD's choice (finite, proper). Equal positions: like one pose.
TEST_CASE("degenerate inputs: one pose, two poses, coincident positions: no NaN") {
  std::mt19937 rng(8);
  for (int dimension = 2; dimension <= 3; ++dimension) {
    INFO("dimension " << dimension);
    const Problem one = randomProblem(rng, dimension, 1, 0);
    const Problem other = randomProblem(rng, dimension, 1, 0);
    const TrajectoryError e1 = trajectoryError(other.values, one.values, dimension, one.kinds);
    const Eigen::MatrixXd identity = Eigen::MatrixXd::Identity(dimension, dimension);
    CHECK(e1.alignment.rotation == identity);
    CHECK((e1.alignment.translation -
           (one.values.at(pose(0)).head(dimension) - other.values.at(pose(0)).head(dimension)))
              .norm() < 1e-12);
    CHECK(e1.ate_position_rmse < 1e-12);
    const Eigen::MatrixXd relative =
        dimension == 2
            ? Eigen::MatrixXd(h2(one.values.at(pose(0))).inverse() * h2(other.values.at(pose(0))))
            : Eigen::MatrixXd(h3(one.values.at(pose(0))).inverse() * h3(other.values.at(pose(0))));
    const double relative_angle =
        dimension == 2 ? std::abs(std::atan2(relative(1, 0), relative(0, 0)))
                       : Eigen::AngleAxisd(Eigen::Matrix3d(relative.topLeftCorner(3, 3))).angle();
    CHECK(e1.ate_rotation_rmse_deg == doctest::Approx(relative_angle * 180.0 / kPi));

    const Problem two = randomProblem(rng, dimension, 2, 0);
    const Eigen::MatrixXd motion = randomMotion(rng, dimension);
    const TrajectoryError e2 =
        trajectoryError(movedValues(motion, two), two.values, dimension, two.kinds);
    CHECK(std::isfinite(e2.ate_rotation_rmse_deg));
    CHECK(e2.ate_position_rmse < 1e-9);
    CHECK(e2.alignment.rotation.determinant() == doctest::Approx(1.0));
    if (dimension == 2) {
      CHECK(e2.ate_rotation_rmse_deg < 1e-9);
      checkInverseOfMotion(e2.alignment, motion, dimension);
    }

    std::vector<Eigen::VectorXd> same(4, Eigen::VectorXd::Constant(dimension, 3.0));
    std::vector<Eigen::VectorXd> targets(4, Eigen::VectorXd::Constant(dimension, -1.0));
    const RigidAlignment a = alignRigid(same, targets);
    CHECK(a.rotation == identity);
    CHECK(a.translation == Eigen::VectorXd::Constant(dimension, -4.0));
  }
}

TEST_CASE("readGroundTruth: a vertices-only g2o file reads back as its values") {
  std::mt19937 rng(12);
  for (int dimension = 2; dimension <= 3; ++dimension) {
    const Problem truth = randomProblem(rng, dimension, 7, 4);
    ModelDataset d;
    d.dimension = dimension;
    for (int i = 0; i < 7; ++i) {
      d.vertices.push_back(ModelVertex{pose(i), truth.kinds.at(pose(i)), truth.values.at(pose(i))});
    }
    for (int i = 0; i < 4; ++i) {  // g2o shares one id space: landmark ids after the poses'
      const Eigen::VectorXd value = truth.values.at(landmark(i));
      d.vertices.push_back(ModelVertex{landmark(10 + i), truth.kinds.at(landmark(i)), value});
    }
    const std::string path = tempPath(std::to_string(dimension) + "d.truth.g2o");
    writeModelG2oFile(path, d);
    const ModelEstimate read = readGroundTruth(path);
    std::filesystem::remove(path);
    REQUIRE(read.size() == 11);
    for (const ModelVertex& v : d.vertices) {
      REQUIRE(read.count(v.key) == 1);
      CHECK(read.at(v.key) == v.value);
    }
  }
}

TEST_CASE("readGroundTruth: an iSAM EDGE2 file chains its odometry, landmarks skipped") {
  const Eigen::Vector3d z01(1.0, 0.5, 0.3);
  const Eigen::Vector3d z12(2.0, -0.25, -1.2);
  const Eigen::Vector3d z32(0.75, 1.5, 2.5);  // pose 2 in pose 3's frame: 3 from 2 by Z^-1
  const std::string text =
      "LANDMARK 2 7 1.0 2.0 1 0 1\n"
      "EDGE2 0 1 1.0 0.5 0.3 1 0 0 1 0 1\n"
      "EDGE2 1 2 2.0 -0.25 -1.2 1 0 0 1 0 1\n"
      "EDGE2 2 0 9.0 9.0 1.0 1 0 0 1 0 1\n"  // a loop closure between known poses: unused
      "EDGE2 3 2 0.75 1.5 2.5 1 0 0 1 0 1\n";
  const std::string path = tempPath("odometry.txt");
  std::ofstream(path) << text;
  const ModelEstimate read = readGroundTruth(path);
  std::filesystem::remove(path);
  const Eigen::Matrix3d x0 = Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d x1 = x0 * h2(z01);
  const Eigen::Matrix3d x2 = x1 * h2(z12);
  const Eigen::Matrix3d x3 = x2 * h2(z32).inverse();
  REQUIRE(read.size() == 4);  // no landmark 7
  CHECK((read.at(pose(0)) - fromH2(x0)).norm() < 1e-12);
  CHECK((read.at(pose(1)) - fromH2(x1)).norm() < 1e-12);
  CHECK((read.at(pose(2)) - fromH2(x2)).norm() < 1e-12);
  CHECK((read.at(pose(3)) - fromH2(x3)).norm() < 1e-12);
}

TEST_CASE("groundTruthValues: iSAM EDGE3 chained through a turned-around edge") {
  // EDGE3 2 1: pose 1 in pose 2's frame; the reader stores 1 -> 2 with Z^-1.
  std::istringstream in(
      "EDGE3 0 1 1 2 3 0.1 0.2 0.3\n"
      "EDGE3 2 1 -1 0.5 2 -0.4 0.7 2.0\n");
  const ModelDataset d = parseModelDataset(in, "edges.txt");
  const ModelEstimate truth = groundTruthValues(d);
  const Eigen::Matrix4d x0 = Eigen::Matrix4d::Identity();
  const Eigen::Matrix4d x1 = x0 * isamPose3(1, 2, 3, 0.1, 0.2, 0.3);
  const Eigen::Matrix4d x2 = x1 * isamPose3(-1, 0.5, 2, -0.4, 0.7, 2.0).inverse();
  REQUIRE(truth.size() == 3);
  CHECK((h3(truth.at(pose(0))) - x0).norm() < 1e-12);
  CHECK((h3(truth.at(pose(1))) - x1).norm() < 1e-12);
  CHECK((h3(truth.at(pose(2))) - x2).norm() < 1e-12);
}

TEST_CASE("groundTruthValues: errors") {
  std::istringstream unchained(
      "EDGE2 0 1 1 0 0 1 0 0 1 0 1\n"
      "EDGE2 2 3 1 0 0 1 0 0 1 0 1\n"
      "EDGE2 1 2 1 0 0 1 0 0 1 0 1\n");
  CHECK_THROWS_AS(groundTruthValues(parseModelDataset(unchained, "unchained.txt")),
                  std::invalid_argument);
  std::istringstream landmarks_only("LANDMARK 0 1 1.0 2.0 1 0 1\n");
  CHECK_THROWS_AS(groundTruthValues(parseModelDataset(landmarks_only, "landmarks.txt")),
                  std::invalid_argument);
}

TEST_CASE("trajectoryError: errors") {
  std::mt19937 rng(1);
  const Problem p2 = randomProblem(rng, 2, 5, 3);
  const Problem p3 = randomProblem(rng, 3, 5, 3);
  // No common pose: only landmarks, or poses of other ids.
  ModelEstimate landmarks_only;
  for (int i = 0; i < 3; ++i) landmarks_only[landmark(i)] = p2.values.at(landmark(i));
  CHECK_THROWS_AS(trajectoryError(p2.values, landmarks_only, 2, p2.kinds), std::invalid_argument);
  ModelEstimate shifted;
  for (int i = 0; i < 5; ++i) shifted[pose(100 + i)] = p2.values.at(pose(i));
  CHECK_THROWS_AS(trajectoryError(p2.values, shifted, 2, p2.kinds), std::invalid_argument);
  // Dimensions: a 2D SE2 estimate against 3D truth and the reverse; a wrong dimension argument.
  CHECK_THROWS_AS(trajectoryError(p2.values, p3.values, 2, p2.kinds), std::invalid_argument);
  CHECK_THROWS_AS(trajectoryError(p3.values, p2.values, 3, p3.kinds), std::invalid_argument);
  CHECK_THROWS_AS(trajectoryError(p2.values, p2.values, 3, p2.kinds), std::invalid_argument);
  CHECK_THROWS_AS(trajectoryError(p2.values, p2.values, 4, p2.kinds), std::invalid_argument);
  // A matched key whose estimate kind is not the truth's (a pose declared as a point).
  Kinds wrong = p3.kinds;
  wrong[pose(0)] = VariableKind::Point3;
  ModelEstimate as_point = p3.values;
  as_point[pose(0)] = Eigen::VectorXd(p3.values.at(pose(0)).head(3));  // a copy: no aliasing
  CHECK_THROWS_AS(trajectoryError(as_point, p3.values, 3, wrong), std::invalid_argument);
  // An estimate key without a kind.
  Kinds missing = p2.kinds;
  missing.erase(pose(1));
  CHECK_THROWS_AS(trajectoryError(p2.values, p2.values, 2, missing), std::invalid_argument);
  // alignRigid's own checks.
  const std::vector<Eigen::VectorXd> none;
  CHECK_THROWS_AS(alignRigid(none, none), std::invalid_argument);
  const std::vector<Eigen::VectorXd> a2 = posePositions(p2.values, 5, 2);
  const std::vector<Eigen::VectorXd> a3 = posePositions(p3.values, 5, 3);
  CHECK_THROWS_AS(alignRigid(a2, a3), std::invalid_argument);
  CHECK_THROWS_AS(alignRigid(a2, std::vector<Eigen::VectorXd>(a2.begin(), a2.end() - 1)),
                  std::invalid_argument);
}

// The noise-free iSAM sphere2500 measurements: chained along the odometry, the poses reproduce
// every loop closure (non-consecutive EDGE3) to the file's print precision; their ids are those
// of 3d/sphere2500.g2o, whose initial estimate they score.
TEST_CASE("readGroundTruth: groundtruth/sphere2500 chains 2500 poses matching its loop closures") {
  const std::string path = datasetPath("groundtruth/sphere2500_groundtruth.txt");
  if (!present(path)) return;
  const ModelEstimate truth = readGroundTruth(path);
  REQUIRE(truth.size() == 2500);
  const ModelDataset d = readModelDataset(path);
  // The iSAM error of each loop closure at the chained poses (translation in the first pose's
  // frame, yaw pitch roll differences): zero up to the file's print precision.
  double max_translation = 0.0;
  double max_angle = 0.0;
  std::size_t loops = 0;
  for (const ModelFactor& f : d.factors) {
    if (f.second.id == f.first.id + 1) continue;
    const Eigen::VectorXd e = factorError(d.convention, f, truth);
    max_translation = std::max(max_translation, e.head<3>().norm());
    max_angle = std::max(max_angle, e.tail<3>().cwiseAbs().maxCoeff());
    ++loops;
  }
  CHECK(loops == 2450);
  MESSAGE("sphere2500 ground truth loop closures: max residual " << max_translation << " m, "
                                                                 << max_angle << " rad");
  CHECK(max_translation < 1e-3);
  CHECK(max_angle < 1e-4);

  const std::string noisy = datasetPath("3d/sphere2500.g2o");
  if (!present(noisy)) return;
  const ModelDataset problem = readModelDataset(noisy);
  const TrajectoryError e =
      trajectoryError(initialEstimate(problem), truth, 3, variableKinds(problem));
  MESSAGE("sphere2500.g2o initial estimate vs ground truth: ATE "
          << e.ate_position_rmse << " m, " << e.ate_rotation_rmse_deg << " deg");
  CHECK(e.poses == 2500);
  CHECK(std::isfinite(e.ate_position_rmse));
  CHECK(e.alignment.rotation.determinant() == doctest::Approx(1.0));
}
