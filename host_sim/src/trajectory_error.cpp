#include "host_sim/trajectory_error.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_set>

#include "host_sim/model_dataset_io.h"
#include "model_geometry.h"

namespace lslam::sim {
namespace {

using Kinds = std::unordered_map<VariableKey, VariableKind, VariableKeyHash>;

constexpr double kDegreesPerRadian = 57.29577951308232;

bool isPose(VariableKind kind) {
  return kind == VariableKind::SE2 || kind == VariableKind::SE3;
}

int kindDimension(VariableKind kind) {
  return kind == VariableKind::SE2 || kind == VariableKind::Point2 ? 2 : 3;
}

std::string keyName(const VariableKey& k) {
  return std::string(k.role == VariableRole::Pose ? "pose " : "landmark ") + std::to_string(k.id);
}

[[noreturn]] void fail(const std::string& reason) {
  throw std::invalid_argument("trajectoryError: " + reason);
}

// The matched keys, each list in (role, id) order so that the sums do not depend on hashing.
struct Matches {
  std::vector<VariableKey> poses;
  std::vector<VariableKey> landmarks;
};

void checkEstimateValue(const VariableKey& key, const Eigen::VectorXd& value, int dimension,
                        const Kinds& kinds) {
  const auto kind = kinds.find(key);
  if (kind == kinds.end()) fail(keyName(key) + " of the estimate has no kind");
  if (kindDimension(kind->second) != dimension) {
    fail(keyName(key) + " is " + variableKindName(kind->second) + " in a " +
         std::to_string(dimension) + "D estimate");
  }
  if (value.size() != parameterCount(kind->second)) {
    fail(keyName(key) + " of the estimate has " + std::to_string(value.size()) + " parameters");
  }
}

void checkTruthValue(const VariableKey& key, const Eigen::VectorXd& value, int dimension) {
  const VariableKind kind = kindOfRole(key.role, dimension);
  if (value.size() != parameterCount(kind)) {
    fail(keyName(key) + " of the truth has " + std::to_string(value.size()) + " parameters, a " +
         std::to_string(dimension) + "D " + variableKindName(kind) + " has " +
         std::to_string(parameterCount(kind)));
  }
}

Matches matchKeys(const ModelEstimate& estimate, const ModelEstimate& truth, int dimension,
                  const Kinds& kinds) {
  if (dimension != 2 && dimension != 3) fail("dimension " + std::to_string(dimension));
  for (const auto& [key, value] : truth) checkTruthValue(key, value, dimension);
  Matches m;
  for (const auto& [key, value] : estimate) {
    checkEstimateValue(key, value, dimension, kinds);
    if (truth.count(key) == 0) continue;
    const VariableKind kind = kinds.at(key);
    if (kind != kindOfRole(key.role, dimension)) {
      fail(keyName(key) + " is " + variableKindName(kind) + " in the estimate, " +
           variableKindName(kindOfRole(key.role, dimension)) + " in the truth");
    }
    (isPose(kind) ? m.poses : m.landmarks).push_back(key);
  }
  const auto order = [](const VariableKey& a, const VariableKey& b) {
    return a.role != b.role ? a.role < b.role : a.id < b.id;
  };
  std::sort(m.poses.begin(), m.poses.end(), order);
  std::sort(m.landmarks.begin(), m.landmarks.end(), order);
  if (m.poses.empty()) fail("no pose is in both the estimate and the truth");
  return m;
}

Eigen::VectorXd centroid(const std::vector<Eigen::VectorXd>& points) {
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(points.front().size());
  for (const Eigen::VectorXd& p : points) sum += p;
  return sum / static_cast<double>(points.size());
}

void checkPointLists(const std::vector<Eigen::VectorXd>& estimate,
                     const std::vector<Eigen::VectorXd>& truth) {
  if (estimate.empty() || estimate.size() != truth.size()) {
    throw std::invalid_argument("alignRigid: " + std::to_string(estimate.size()) + " and " +
                                std::to_string(truth.size()) + " points");
  }
  const Eigen::Index dim = estimate.front().size();
  if (dim != 2 && dim != 3) throw std::invalid_argument("alignRigid: points of size 2 or 3");
  const auto other = [dim](const Eigen::VectorXd& p) { return p.size() != dim; };
  if (std::any_of(estimate.begin(), estimate.end(), other) ||
      std::any_of(truth.begin(), truth.end(), other)) {
    throw std::invalid_argument("alignRigid: points of different sizes");
  }
}

// The positions (first `dimension` parameters) of `keys` in `values`.
std::vector<Eigen::VectorXd> positions(const ModelEstimate& values,
                                       const std::vector<VariableKey>& keys, int dimension) {
  std::vector<Eigen::VectorXd> out;
  out.reserve(keys.size());
  for (const VariableKey& k : keys) out.push_back(values.at(k).head(dimension));
  return out;
}

double rms(double sum_of_squares, std::size_t n) {
  return n == 0 ? 0.0 : std::sqrt(sum_of_squares / static_cast<double>(n));
}

double alignedPositionRmse(const RigidAlignment& a, const std::vector<Eigen::VectorXd>& estimate,
                           const std::vector<Eigen::VectorXd>& truth) {
  double sum = 0.0;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    sum += (a.rotation * estimate[i] + a.translation - truth[i]).squaredNorm();
  }
  return rms(sum, estimate.size());
}

Eigen::MatrixXd rotationOf(VariableKind kind, const Eigen::VectorXd& value) {
  if (kind == VariableKind::SE2) return geometry::rot2(value[2]);
  return geometry::quat(value.data()).toRotationMatrix();
}

// The angle of a rotation matrix in [0, pi], from atan2 of its sine and cosine parts (accurate
// near 0 and pi, where acos of the trace is not).
double rotationAngle(const Eigen::MatrixXd& r) {
  if (r.rows() == 2) return std::abs(std::atan2(r(1, 0) - r(0, 1), r(0, 0) + r(1, 1)));
  const Eigen::Vector3d twice_sin_axis(r(2, 1) - r(1, 2), r(0, 2) - r(2, 0), r(1, 0) - r(0, 1));
  return std::atan2(0.5 * twice_sin_axis.norm(), 0.5 * (r.trace() - 1.0));
}

double rotationRmseDeg(const RigidAlignment& a, const ModelEstimate& estimate,
                       const ModelEstimate& truth, const std::vector<VariableKey>& poses,
                       VariableKind kind) {
  double sum = 0.0;
  for (const VariableKey& k : poses) {
    const Eigen::MatrixXd error =
        rotationOf(kind, truth.at(k)).transpose() * a.rotation * rotationOf(kind, estimate.at(k));
    sum += std::pow(rotationAngle(error), 2);
  }
  return rms(sum, poses.size()) * kDegreesPerRadian;
}

// Throws unless every between factor after the first reaches a pose an earlier one reached.
void requireOneChain(const ModelDataset& odometry) {
  std::unordered_set<VariableKey, VariableKeyHash> reached;
  for (const ModelFactor& f : odometry.factors) {
    if (!reached.empty() && reached.count(f.first) == 0 && reached.count(f.second) == 0) {
      throw std::invalid_argument("groundTruthValues: " + odometry.name + " line " +
                                  std::to_string(f.line) + ": neither " + keyName(f.first) +
                                  " nor " + keyName(f.second) +
                                  " is reached by the between factors before it");
    }
    reached.insert(f.first);
    reached.insert(f.second);
  }
}

}  // namespace

RigidAlignment alignRigid(const std::vector<Eigen::VectorXd>& estimate,
                          const std::vector<Eigen::VectorXd>& truth) {
  checkPointLists(estimate, truth);
  const Eigen::Index dim = estimate.front().size();
  const Eigen::VectorXd mean_estimate = centroid(estimate);
  const Eigen::VectorXd mean_truth = centroid(truth);
  Eigen::MatrixXd covariance = Eigen::MatrixXd::Zero(dim, dim);
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    covariance += (truth[i] - mean_truth) * (estimate[i] - mean_estimate).transpose();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(covariance,
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::VectorXd sign = Eigen::VectorXd::Ones(dim);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) sign[dim - 1] = -1.0;
  RigidAlignment a;
  a.rotation = svd.matrixU() * sign.asDiagonal() * svd.matrixV().transpose();
  a.translation = mean_truth - a.rotation * mean_estimate;
  return a;
}

ModelEstimate inEstimateFrame(const ModelEstimate& truth, const RigidAlignment& alignment) {
  const auto dim = alignment.rotation.rows();
  const Eigen::MatrixXd rt = alignment.rotation.transpose();
  ModelEstimate out;
  for (const auto& [key, value] : truth) {
    Eigen::VectorXd v = value;
    v.head(dim) = rt * (value.head(dim) - alignment.translation);
    if (key.role == VariableRole::Pose && dim == 2) {
      v[2] = wrapAngle(value[2] - std::atan2(alignment.rotation(1, 0), alignment.rotation(0, 0)));
    } else if (key.role == VariableRole::Pose) {
      const Eigen::Quaterniond q(Eigen::Matrix3d(rt) * geometry::quat(value.data()));
      v.tail<4>() << q.x(), q.y(), q.z(), q.w();
    }
    out[key] = v;
  }
  return out;
}

TrajectoryError trajectoryError(const ModelEstimate& estimate, const ModelEstimate& truth,
                                int dimension, const Kinds& kinds) {
  const Matches m = matchKeys(estimate, truth, dimension, kinds);
  const std::vector<Eigen::VectorXd> estimate_poses = positions(estimate, m.poses, dimension);
  const std::vector<Eigen::VectorXd> truth_poses = positions(truth, m.poses, dimension);
  TrajectoryError r;
  r.poses = m.poses.size();
  r.landmarks = m.landmarks.size();
  r.alignment = alignRigid(estimate_poses, truth_poses);
  r.ate_position_rmse = alignedPositionRmse(r.alignment, estimate_poses, truth_poses);
  r.ate_rotation_rmse_deg = rotationRmseDeg(r.alignment, estimate, truth, m.poses,
                                            kindOfRole(VariableRole::Pose, dimension));
  if (!m.landmarks.empty()) {
    r.landmark_rmse = alignedPositionRmse(r.alignment, positions(estimate, m.landmarks, dimension),
                                          positions(truth, m.landmarks, dimension));
  }
  return r;
}

ModelEstimate groundTruthValues(const ModelDataset& d) {
  ModelEstimate values;
  for (const ModelVertex& v : d.vertices) values[v.key] = v.value;
  if (!values.empty()) return values;
  ModelDataset odometry;
  odometry.name = d.name;
  odometry.dimension = d.dimension;
  odometry.convention = d.convention;
  for (const ModelFactor& f : d.factors) {
    if (f.kind == FactorKind::BetweenSE2 || f.kind == FactorKind::BetweenSE3) {
      odometry.factors.push_back(f);
    }
  }
  if (odometry.factors.empty()) {
    throw std::invalid_argument("groundTruthValues: " + d.name +
                                " has neither vertices nor between factors");
  }
  requireOneChain(odometry);
  return initialEstimate(odometry);
}

ModelEstimate readGroundTruth(const std::string& path) {
  return groundTruthValues(readModelDataset(path));
}

}  // namespace lslam::sim
