#include "host_sim/synthetic_3d.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <map>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "host_sim/model_chi2.h"
#include "world_draft.h"
#include "world_measurements.h"

namespace lslam::sim {

namespace {

using detail::kPi;
using detail::Pose3;

void checkOptions(const Synthetic3DOptions& o) {
  const auto probability = [](double p) { return p >= 0.0 && p <= 1.0; };
  if (o.laps < 1 || o.sweep_laps < 0 || o.sweep_laps > 1000000 || o.poses < 2 * o.laps ||
      o.landmarks < 0 || o.max_observations_per_pose < 0 || !probability(o.loop_probability) ||
      !probability(o.observation_probability) || !(o.radius > 0.0) || !(o.sensor_range >= 0.0) ||
      !(o.sigma_translation > 0.0) || !(o.sigma_rotation > 0.0) || !(o.sigma_point > 0.0)) {
    throw std::invalid_argument("generateLandmarkWorld3D: option out of range");
  }
}

// The true pose at time i: on the lap's circle, facing along the track, pitched with the slope.
Pose3 truePose(const Synthetic3DOptions& o, int i) {
  const int per_lap = o.poses / o.laps;
  const int lap = std::min(i / per_lap, o.laps - 1);
  const double phi = 2.0 * kPi * static_cast<double>(i) / static_cast<double>(per_lap);
  const int period = 2 * o.sweep_laps;
  const int swept = period > 0 ? std::min(lap % period, period - lap % period) : lap;
  const double r = o.radius + o.lap_radius_step * static_cast<double>(swept);
  const double z = o.height_amplitude * std::sin(2.0 * phi + static_cast<double>(lap));
  const double slope = 2.0 * o.height_amplitude * std::cos(2.0 * phi + lap) / r;
  const double yaw = phi + 0.5 * kPi;
  const double pitch = -std::atan(slope);
  const double roll = 0.05 * std::sin(3.0 * phi);
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX());
  return {q.normalized(), Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z)};
}

ModelFactor betweenFactor(const Synthetic3DOptions& o, detail::PortableRandom& random, int from,
                          int to, const Pose3& a, const Pose3& b) {
  return detail::noisyBetweenSE3(from, to, detail::relativePose(a, b), o.sigma_translation,
                                 o.sigma_rotation, random);
}

}  // namespace

detail::WorldDraft detail::draftLandmarkWorld3D(const Synthetic3DOptions& o) {
  checkOptions(o);
  detail::PortableRandom random(o.seed);
  const int per_lap = o.poses / o.laps;
  detail::WorldDraft w;
  w.name = "synthetic-landmarks-3d";
  w.dimension = 3;
  for (int k = 0; k < o.landmarks; ++k) {
    const double phi = 2.0 * kPi * random.uniform();
    const double r = o.radius + o.landmark_spread * (2.0 * random.uniform() - 1.0);
    const double z = -1.0 + 3.0 * random.uniform();
    w.landmarks.emplace_back(Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z));
  }
  // Observations name the scattered landmark's index.
  for (int i = 0; i < o.poses; ++i) {
    const Pose3 x = truePose(o, i);
    w.poses.push_back(detail::poseParameters(x));
    if (i > 0) w.factors.push_back(betweenFactor(o, random, i - 1, i, truePose(o, i - 1), x));
    if (i >= per_lap && random.uniform() < o.loop_probability) {
      w.factors.push_back(betweenFactor(o, random, i - per_lap, i, truePose(o, i - per_lap), x));
    }
    if (random.uniform() >= o.observation_probability) continue;
    for (const std::size_t k :
         detail::nearestInRange(w.landmarks, x.t, 0.0, o.sensor_range,
                                static_cast<std::size_t>(o.max_observations_per_pose))) {
      ModelFactor f;
      f.kind = FactorKind::PointXYZ3;
      f.first = {VariableRole::Pose, i};
      f.second = {VariableRole::Landmark, static_cast<std::int64_t>(k)};
      const Eigen::Vector3d l = w.landmarks[k];
      f.measurement = x.q.conjugate() * (l - x.t) + detail::normal3(random, o.sigma_point);
      f.information = Eigen::MatrixXd::Identity(3, 3) / (o.sigma_point * o.sigma_point);
      w.factors.push_back(f);
    }
  }
  return w;
}

ModelDataset generateLandmarkWorld3D(const Synthetic3DOptions& o) {
  const detail::WorldDraft w = detail::draftLandmarkWorld3D(o);
  std::vector<int> observed(w.landmarks.size(), 0);
  for (const ModelFactor& f : w.factors) {
    if (f.kind == FactorKind::PointXYZ3) ++observed[static_cast<std::size_t>(f.second.id)];
  }

  // Keep landmarks seen at least twice, renumbered after the poses in order of first observation.
  ModelDataset d;
  d.name = "synthetic-landmarks-3d";
  d.format = DatasetFormat::G2o;
  d.convention = ObjectiveConvention::G2o;
  d.dimension = 3;
  std::map<int, std::int64_t> id_of;
  for (ModelFactor f : w.factors) {
    if (f.kind == FactorKind::PointXYZ3) {
      const int k = static_cast<int>(f.second.id);
      if (observed[k] < 2) continue;
      const auto it = id_of.emplace(k, o.poses + static_cast<std::int64_t>(id_of.size())).first;
      f.second.id = it->second;
    }
    d.factors.push_back(f);
  }

  // Vertices: the dead-reckoning initial estimate, poses then landmarks by id.
  const ModelEstimate initial = initialEstimate(d);
  for (int i = 0; i < o.poses; ++i) {
    const VariableKey key{VariableRole::Pose, i};
    d.vertices.push_back({key, VariableKind::SE3, initial.at(key), 0});
  }
  for (std::size_t k = 0; k < id_of.size(); ++k) {
    const VariableKey key{VariableRole::Landmark, o.poses + static_cast<std::int64_t>(k)};
    d.vertices.push_back({key, VariableKind::Point3, initial.at(key), 0});
  }
  return d;
}

}  // namespace lslam::sim
