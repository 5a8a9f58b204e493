#include "host_sim/worlds.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>

#include "host_sim/model_chi2.h"
#include "world_draft.h"
#include "world_measurements.h"

namespace lslam::sim {

namespace {

using detail::PortableRandom;
using detail::WorldDraft;

// Its own stream, so that the world without outliers is the same with any outlier_rate 0.
constexpr std::uint32_t kOutlierStream = 0x6f75746cu;

void validate(const WorldOptions& o) {
  const auto bad = [](const std::string& what) {
    throw std::invalid_argument("simulate: " + what);
  };
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  const auto nonnegative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  const auto probability = [](double p) { return p >= 0.0 && p <= 1.0; };  // false for NaN
  if (o.steps < 2) bad("steps must be >= 2");
  if (!positive(o.sigma_translation) || !positive(o.sigma_rotation) ||
      !positive(o.sigma_landmark) || !positive(o.sigma_range) || !positive(o.sigma_bearing)) {
    bad("noise standard deviations must be finite and > 0");
  }
  if (!probability(o.loop_probability) || !probability(o.outlier_rate) ||
      !probability(o.turn_probability)) {
    bad("probabilities must be in [0, 1]");
  }
  if (o.max_loops_per_pose < 0 || o.landmarks < 0 || o.max_observations_per_pose < 0) {
    bad("counts must be >= 0");
  }
  if (!nonnegative(o.loop_radius) || !nonnegative(o.sensor_range)) bad("ranges must be >= 0");
  if (o.min_loop_separation < 2) bad("min_loop_separation must be >= 2");
  if (o.grid_size < 2) bad("grid_size must be >= 2");
  if (!positive(o.radius)) bad("radius must be > 0");
  if (o.floors < 1) bad("floors must be >= 1");
}

WorldDraft draft(WorldKind kind, const WorldOptions& o) {
  switch (kind) {
    case WorldKind::Sphere3D:
      return detail::draftSphere3D(o);
    case WorldKind::Garage3D:
      return detail::draftGarage3D(o);
    case WorldKind::Points3D:
      return detail::draftPoints3D(o);
    case WorldKind::Grid2D:
      break;
  }
  return detail::draftGrid2D(o);
}

Eigen::Vector3d positionOf(const WorldDraft& w, std::size_t i) {
  const Eigen::VectorXd& p = w.poses[i];
  return w.dimension == 2 ? Eigen::Vector3d(p[0], p[1], 0.0) : Eigen::Vector3d(p.head<3>());
}

// A wrong loop closure from a far earlier pose to pose i, or none if no pose is far enough.
bool addOutlier(const WorldOptions& o, const WorldDraft& w, std::size_t i,
                const ModelFactor& odometry, PortableRandom& random,
                std::vector<ModelFactor>& out) {
  const double far = wrongLoopClosureDistance(o);
  std::vector<std::size_t> candidates;
  for (std::size_t j = 0; j + static_cast<std::size_t>(o.min_loop_separation) <= i; ++j) {
    if ((positionOf(w, j) - positionOf(w, i)).norm() > far) candidates.push_back(j);
  }
  if (candidates.empty()) return false;
  const std::size_t j = candidates[random.index(candidates.size())];
  // A plausible loop closure: a relative pose within loop_radius, any heading (yaw).
  const double r = o.loop_radius * std::sqrt(random.uniform());
  const double direction = 2.0 * detail::kPi * random.uniform();
  const double heading = detail::kPi * (2.0 * random.uniform() - 1.0);
  ModelFactor f = odometry;
  f.first = detail::poseKey(static_cast<std::int64_t>(j));
  f.second = detail::poseKey(static_cast<std::int64_t>(i));
  if (w.dimension == 2) {
    f.measurement = Eigen::Vector3d(r * std::cos(direction), r * std::sin(direction), heading);
  } else {
    const detail::Pose3 z{Eigen::Quaterniond(Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ())),
                          Eigen::Vector3d(r * std::cos(direction), r * std::sin(direction), 0.0)};
    f.measurement = detail::poseParameters(z);
  }
  out.push_back(f);
  return true;
}

// Inserts the wrong loop closures after each pose's own factors; their indices into `outliers`.
void addOutliers(const WorldOptions& o, WorldDraft& w, std::vector<std::size_t>& outliers) {
  if (o.outlier_rate <= 0.0) return;
  PortableRandom random(o.seed ^ kOutlierStream);
  // The odometry's information goes with the wrong loop closures.
  const auto odometry = std::find_if(w.factors.begin(), w.factors.end(), [](const ModelFactor& f) {
    return f.kind == FactorKind::BetweenSE2 || f.kind == FactorKind::BetweenSE3;
  });
  if (odometry == w.factors.end()) return;
  std::vector<ModelFactor> factors;
  std::size_t next = 0;
  for (std::size_t i = 1; i < w.poses.size(); ++i) {
    for (; next < w.factors.size() &&
           detail::newestPose(w.factors[next]) <= static_cast<std::int64_t>(i);
         ++next) {
      factors.push_back(w.factors[next]);
    }
    if (i < static_cast<std::size_t>(o.min_loop_separation)) continue;
    if (random.uniform() >= o.outlier_rate) continue;
    if (addOutlier(o, w, i, *odometry, random, factors)) {
      outliers.push_back(factors.size() - 1);
    }
  }
  factors.insert(factors.end(), w.factors.begin() + static_cast<std::ptrdiff_t>(next),
                 w.factors.end());
  w.factors = std::move(factors);
}

ModelDataset emptyDataset(const std::string& name, int dimension) {
  ModelDataset d;
  d.name = name;
  d.format = DatasetFormat::G2o;
  d.convention = ObjectiveConvention::G2o;
  d.dimension = dimension;
  return d;
}

// The dataset and its truth: observed landmarks renumbered after the poses in order of first
// observation; vertices the dead reckoning from the true first pose.
SimulatedWorld finish(const WorldDraft& w, std::vector<std::size_t> outliers) {
  SimulatedWorld out;
  out.outliers = std::move(outliers);
  out.dataset = emptyDataset(w.name, w.dimension);
  out.truth = emptyDataset(w.name + "-truth", w.dimension);
  const auto poses = static_cast<std::int64_t>(w.poses.size());
  std::map<std::int64_t, std::int64_t> id_of;  // landmark index -> id
  for (ModelFactor f : w.factors) {
    if (f.second.role == VariableRole::Landmark) {
      f.second.id =
          id_of.emplace(f.second.id, poses + static_cast<std::int64_t>(id_of.size())).first->second;
    }
    out.dataset.factors.push_back(f);
  }
  const VariableKind pose = kindOfRole(VariableRole::Pose, w.dimension);
  for (std::int64_t i = 0; i < poses; ++i) {
    out.truth.vertices.push_back(
        {detail::poseKey(i), pose, w.poses[static_cast<std::size_t>(i)], 0});
  }
  std::vector<ModelVertex> landmarks(id_of.size());
  for (const auto& [index, id] : id_of) {
    landmarks[static_cast<std::size_t>(id - poses)] = {
        {VariableRole::Landmark, id},
        kindOfRole(VariableRole::Landmark, w.dimension),
        w.landmarks[static_cast<std::size_t>(index)],
        0};
  }
  out.truth.vertices.insert(out.truth.vertices.end(), landmarks.begin(), landmarks.end());
  // Dead reckoning from the true first pose.
  out.dataset.vertices = {out.truth.vertices.front()};
  const ModelEstimate initial = initialEstimate(out.dataset);
  out.dataset.vertices.clear();
  for (const ModelVertex& v : out.truth.vertices) {
    out.dataset.vertices.push_back({v.key, v.kind, initial.at(v.key), 0});
  }
  return out;
}

}  // namespace

std::int64_t detail::newestPose(const ModelFactor& f) {
  if (arity(f.kind) == 1) return f.first.role == VariableRole::Pose ? f.first.id : -1;
  if (f.second.role == VariableRole::Landmark) return f.first.id;
  return std::max(f.first.id, f.second.id);
}

double wrongLoopClosureDistance(const WorldOptions& o) {
  return 2.0 * o.loop_radius + 1.0;
}

std::optional<WorldKind> parseWorldKind(const std::string& name) {
  for (const WorldKind k :
       {WorldKind::Grid2D, WorldKind::Sphere3D, WorldKind::Garage3D, WorldKind::Points3D}) {
    if (name == worldKindName(k)) return k;
  }
  return std::nullopt;
}

const char* worldKindName(WorldKind kind) {
  switch (kind) {
    case WorldKind::Sphere3D:
      return "sphere3d";
    case WorldKind::Garage3D:
      return "garage3d";
    case WorldKind::Points3D:
      return "points3d";
    case WorldKind::Grid2D:
      break;
  }
  return "grid2d";
}

WorldOptions defaultWorldOptions(WorldKind kind) {
  WorldOptions o;
  switch (kind) {
    case WorldKind::Sphere3D:
      o.steps = 2500;
      o.loop_probability = 1.0;
      o.max_loops_per_pose = 1;
      o.landmarks = 0;
      break;
    case WorldKind::Garage3D:
      o.steps = 1600;
      o.loop_probability = 0.8;
      o.landmarks = 0;
      break;
    case WorldKind::Points3D:
      o.landmarks = 60;
      o.sensor_range = 4.0;
      o.loop_probability = 0.3;
      break;
    case WorldKind::Grid2D:
      break;
  }
  return o;
}

SimulatedWorld simulateWorld(WorldKind kind, const WorldOptions& options) {
  validate(options);
  WorldDraft w = draft(kind, options);
  std::vector<std::size_t> outliers;
  addOutliers(options, w, outliers);
  return finish(w, std::move(outliers));
}

}  // namespace lslam::sim
