#pragma once
// Rigid-transform helpers on ModelDataset parameter vectors (SE2: x y theta; SE3: x y z qx qy qz
// qw), shared by the host's chi2, online initial values and step builder. Private to host_sim;
// independent of firmware_lib.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

#include "host_sim/chi2.h"

namespace lslam::sim::geometry {

inline Eigen::Matrix2d rot2(double theta) {
  const double c = std::cos(theta);
  const double s = std::sin(theta);
  Eigen::Matrix2d m;
  m << c, -s, s, c;
  return m;
}

// The quaternion of SE3 parameters, normalised (files hold it to ~1e-6; g2o normalises on read).
inline Eigen::Quaterniond quat(const double* p) {
  return Eigen::Quaterniond(p[6], p[3], p[4], p[5]).normalized();
}

inline Eigen::VectorXd se3Params(const Eigen::Quaterniond& q, const Eigen::Vector3d& t) {
  Eigen::VectorXd p(7);
  p << t, q.x(), q.y(), q.z(), q.w();
  return p;
}

inline Eigen::VectorXd composeSE2(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::Vector2d t = Eigen::Vector2d(a[0], a[1]) + rot2(a[2]) * Eigen::Vector2d(b[0], b[1]);
  return Eigen::Vector3d(t.x(), t.y(), wrapAngle(a[2] + b[2]));
}

inline Eigen::VectorXd inverseSE2(const Eigen::VectorXd& a) {
  const Eigen::Vector2d t = -(rot2(a[2]).transpose() * Eigen::Vector2d(a[0], a[1]));
  return Eigen::Vector3d(t.x(), t.y(), wrapAngle(-a[2]));
}

inline Eigen::VectorXd composeSE3(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  const Eigen::Quaterniond qa = quat(a.data());
  const Eigen::Quaterniond qb = quat(b.data());
  return se3Params((qa * qb).normalized(), a.head<3>() + qa * b.head<3>());
}

inline Eigen::VectorXd inverseSE3(const Eigen::VectorXd& a) {
  const Eigen::Quaterniond qi = quat(a.data()).conjugate();
  return se3Params(qi, -(qi * a.head<3>()));
}

}  // namespace lslam::sim::geometry
