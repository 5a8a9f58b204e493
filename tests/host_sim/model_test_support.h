#pragma once
// Small helpers shared by the host tests of the model datasets: keys, poses as homogeneous
// matrices and back, random information matrices and factors. Independent of firmware_lib.
#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <utility>

#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"

namespace lslam::sim::test {

inline VariableKey pose(std::int64_t id) {
  return VariableKey{VariableRole::Pose, id};
}
inline VariableKey landmark(std::int64_t id) {
  return VariableKey{VariableRole::Landmark, id};
}

// SE2 (x, y, theta) as a 3x3 homogeneous matrix, and back.
inline Eigen::Matrix3d h2(const Eigen::VectorXd& x) {
  Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
  t.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(x[2]).matrix();
  t(0, 2) = x[0];
  t(1, 2) = x[1];
  return t;
}
inline Eigen::VectorXd fromH2(const Eigen::Matrix3d& t) {
  return Eigen::Vector3d(t(0, 2), t(1, 2), std::atan2(t(1, 0), t(0, 0)));
}

// SE3 (x, y, z, qx, qy, qz, qw) as a 4x4 homogeneous matrix (quaternion normalised), and back.
inline Eigen::Matrix4d h3(const Eigen::VectorXd& p) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = Eigen::Quaterniond(p[6], p[3], p[4], p[5]).normalized().matrix();
  t.topRightCorner<3, 1>() = p.head<3>();
  return t;
}
inline Eigen::VectorXd fromH3(const Eigen::Matrix4d& t) {
  const Eigen::Quaterniond q(Eigen::Matrix3d(t.topLeftCorner<3, 3>()));
  Vector7d p;
  p << t(0, 3), t(1, 3), t(2, 3), q.x(), q.y(), q.z(), q.w();
  return p;
}

// B B^T + diag(d), B with entries uniform in [-1, 1]: positive definite, with correlations.
inline Eigen::MatrixXd randomInformation(std::mt19937& rng, const Eigen::VectorXd& diag) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = static_cast<int>(diag.size());
  Eigen::MatrixXd b(n, n);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) b(r, c) = u(rng);
  }
  Eigen::MatrixXd omega = b * b.transpose();
  omega.diagonal() += diag;
  return omega;
}

inline ModelFactor factor(FactorKind kind, VariableKey a, VariableKey b, Eigen::VectorXd z,
                          Eigen::MatrixXd info, std::size_t line = 0) {
  ModelFactor f;
  f.kind = kind;
  f.first = a;
  f.second = b;
  f.measurement = std::move(z);
  f.information = std::move(info);
  f.line = line;
  return f;
}

}  // namespace lslam::sim::test
