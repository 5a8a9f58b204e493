#pragma once
// The simulated sensors shared by the synthetic worlds: true rigid 3D poses, the noisy 3D
// relative-pose measurement with the information of its noise (worlds.h, NOISE), and what a
// range-limited sensor sees. Private to host_sim/src.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "host_sim/model_dataset.h"
#include "portable_random.h"

namespace lslam::sim::detail {

inline constexpr double kPi = 3.14159265358979323846;

// A true 3D pose: the rotation into the world frame and the position.
struct Pose3 {
  Eigen::Quaterniond q;
  Eigen::Vector3d t;
};

inline Pose3 relativePose(const Pose3& a, const Pose3& b) {
  const Eigen::Quaterniond ai = a.q.conjugate();
  return {(ai * b.q).normalized(), ai * (b.t - a.t)};
}

// exp of a rotation vector.
inline Eigen::Quaterniond rotationOf(const Eigen::Vector3d& r) {
  const double angle = r.norm();
  if (angle == 0.0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, r / angle));
}

// ModelDataset's SE3 parameters (x y z qx qy qz qw).
inline Eigen::VectorXd poseParameters(const Pose3& p) {
  Eigen::VectorXd v(7);
  v << p.t, p.q.x(), p.q.y(), p.q.z(), p.q.w();
  return v;
}

// sigma times three standard normal draws, x then y then z.
inline Eigen::Vector3d normal3(PortableRandom& random, double sigma) {
  const double x = random.normal();
  const double y = random.normal();
  const double z = random.normal();
  return sigma * Eigen::Vector3d(x, y, z);
}

inline VariableKey poseKey(std::int64_t id) {
  return {VariableRole::Pose, id};
}

// The indices of the points within [min_range, max_range] of `x`, nearest first (ties by index),
// at most max_count of them: what a range-limited sensor reports.
template <class Points, class Position>
std::vector<std::size_t> nearestInRange(const Points& points, const Position& x, double min_range,
                                        double max_range, std::size_t max_count) {
  std::vector<std::pair<double, std::size_t>> in_range;
  for (std::size_t k = 0; k < points.size(); ++k) {
    const double d = (points[k] - x).norm();
    if (d >= min_range && d <= max_range) in_range.emplace_back(d, k);
  }
  std::sort(in_range.begin(), in_range.end());
  in_range.resize(std::min(in_range.size(), max_count));
  std::vector<std::size_t> nearest;
  for (const auto& entry : in_range) nearest.push_back(entry.second);
  return nearest;
}

// Between factor from -> to of SE3 with measurement Z = rel exp(dt, dr) (translation noise in
// rel's frame, then rotation noise), information diag(1/st^2 x3, 4/sr^2 x3).
inline ModelFactor noisyBetweenSE3(std::int64_t from, std::int64_t to, const Pose3& rel,
                                   double sigma_translation, double sigma_rotation,
                                   PortableRandom& random) {
  const Eigen::Vector3d dt = normal3(random, sigma_translation);
  const Eigen::Vector3d dr = normal3(random, sigma_rotation);
  const Pose3 z{(rel.q * rotationOf(dr)).normalized(), rel.t + rel.q * dt};
  ModelFactor f;
  f.kind = FactorKind::BetweenSE3;
  f.first = poseKey(from);
  f.second = poseKey(to);
  f.measurement = poseParameters(z);
  f.information = Eigen::MatrixXd::Zero(6, 6);
  for (int k = 0; k < 3; ++k) {
    f.information(k, k) = 1.0 / (sigma_translation * sigma_translation);
    f.information(k + 3, k + 3) = 4.0 / (sigma_rotation * sigma_rotation);
  }
  return f;
}

}  // namespace lslam::sim::detail
