// grid2d (worlds.h): the Manhattan grid of synthetic.h with point landmarks.
#include <algorithm>
#include <cmath>
#include <utility>

#include "host_sim/synthetic.h"
#include "lslam/geometry/angle.h"
#include "world_draft.h"
#include "world_measurements.h"

namespace lslam::sim::detail {

namespace {

// Its own stream, so that the poses and their measurements are those of the landmark-free grid.
constexpr std::uint32_t kLandmarkStream = 0x6c616e64u;

SyntheticOptions gridOptions(const WorldOptions& o) {
  SyntheticOptions g;
  g.poses = o.steps;
  g.seed = o.seed;
  g.world_size = o.grid_size;
  g.turn_probability = o.turn_probability;
  g.loop_probability = o.loop_probability;
  g.loop_radius = o.loop_radius;
  g.min_loop_separation = o.min_loop_separation;
  g.max_loops_per_pose = o.max_loops_per_pose;
  g.sigma_x = o.sigma_translation;
  g.sigma_y = o.sigma_translation;
  g.sigma_theta = o.sigma_rotation;
  return g;
}

ModelFactor betweenOf(const Edge2D& e) {
  ModelFactor f;
  f.kind = FactorKind::BetweenSE2;
  f.first = poseKey(e.from);
  f.second = poseKey(e.to);
  f.measurement = Eigen::Vector3d(e.measurement.x, e.measurement.y, e.measurement.theta);
  f.information = e.information;
  return f;
}

// The observation of landmark k (true position l) from the true pose x.
ModelFactor observation(const WorldOptions& o, std::size_t pose, const Eigen::Vector3d& x,
                        std::size_t k, const Eigen::Vector2d& l, PortableRandom& random) {
  const double c = std::cos(x.z());
  const double s = std::sin(x.z());
  const Eigen::Vector2d d = l - x.head<2>();
  const Eigen::Vector2d local(c * d.x() + s * d.y(), -s * d.x() + c * d.y());
  const double n1 = random.normal();
  const double n2 = random.normal();
  ModelFactor f;
  f.first = poseKey(static_cast<std::int64_t>(pose));
  f.second = {VariableRole::Landmark, static_cast<std::int64_t>(k)};
  if (o.landmark_measurement == LandmarkMeasurement::Position) {
    f.kind = FactorKind::PointXY2;
    f.measurement = local + o.sigma_landmark * Eigen::Vector2d(n1, n2);
    f.information = Eigen::Matrix2d::Identity() / (o.sigma_landmark * o.sigma_landmark);
  } else {
    f.kind = FactorKind::RangeBearing2;
    const double bearing = std::atan2(local.y(), local.x());
    f.measurement = Eigen::Vector2d(local.norm() + o.sigma_range * n1,
                                    lslam::wrapAngle(bearing + o.sigma_bearing * n2));
    f.information = Eigen::Vector2d(1.0 / (o.sigma_range * o.sigma_range),
                                    1.0 / (o.sigma_bearing * o.sigma_bearing))
                        .asDiagonal();
  }
  return f;
}

// The nearest landmark a pose observes lies this far at least: below it a bearing is ill-defined
// and a range's noise may turn it negative (6 sigma of the range's noise, at least 0.5 m).
double minimumRange(const WorldOptions& o) {
  return std::max(0.5, 6.0 * o.sigma_range);
}

}  // namespace

WorldDraft draftGrid2D(const WorldOptions& o) {
  const SyntheticWorld grid = generateManhattanWorld(gridOptions(o));
  WorldDraft w;
  w.name = "grid2d";
  w.dimension = 2;
  for (const Pose2D& p : grid.ground_truth)
    w.poses.emplace_back(Eigen::Vector3d(p.x, p.y, p.theta));
  PortableRandom random(o.seed ^ kLandmarkStream);
  const double low = -1.0;
  const double span = static_cast<double>(o.grid_size + 1);
  for (int k = 0; k < o.landmarks; ++k) {
    const double x = low + span * random.uniform();
    const double y = low + span * random.uniform();
    w.landmarks.emplace_back(Eigen::Vector2d(x, y));
  }
  // The grid's edges are in online order: each pose's odometry and loop closures, then its
  // observations.
  std::size_t e = 0;
  for (std::size_t i = 0; i < w.poses.size(); ++i) {
    for (;
         e < grid.dataset.edges.size() && grid.dataset.edges[e].to == static_cast<std::int64_t>(i);
         ++e) {
      w.factors.push_back(betweenOf(grid.dataset.edges[e]));
    }
    const Eigen::Vector3d x = w.poses[i];
    const Eigen::Vector2d position = x.head<2>();
    for (const std::size_t k :
         nearestInRange(w.landmarks, position, minimumRange(o), o.sensor_range,
                        static_cast<std::size_t>(o.max_observations_per_pose))) {
      w.factors.push_back(observation(o, i, x, k, w.landmarks[k], random));
    }
  }
  return w;
}

}  // namespace lslam::sim::detail
