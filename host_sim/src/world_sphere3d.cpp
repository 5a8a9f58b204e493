// sphere3d (worlds.h): rings of latitude on a sphere, each pose closing a loop one ring back.
#include <algorithm>
#include <cmath>

#include "world_draft.h"
#include "world_measurements.h"

namespace lslam::sim::detail {

namespace {

// Pose i: ring i / per_ring (south to north), longitude 2 pi (i % per_ring) / per_ring; facing
// east along the ring, z along the outward normal.
Pose3 spherePose(int i, int per_ring, int rings, double radius) {
  const int ring = i / per_ring;
  const double lat = -0.5 * kPi + kPi * (static_cast<double>(ring) + 0.5) / rings;
  const double lon = 2.0 * kPi * static_cast<double>(i % per_ring) / per_ring;
  const Eigen::Vector3d up(std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon),
                           std::sin(lat));
  const Eigen::Vector3d east(-std::sin(lon), std::cos(lon), 0.0);
  Eigen::Matrix3d r;
  r.col(0) = east;
  r.col(1) = up.cross(east);
  r.col(2) = up;
  return {Eigen::Quaterniond(r).normalized(), radius * up};
}

}  // namespace

WorldDraft draftSphere3D(const WorldOptions& o) {
  const int per_ring = std::max(2, static_cast<int>(std::lround(std::sqrt(o.steps))));
  const int rings = (o.steps + per_ring - 1) / per_ring;
  PortableRandom random(o.seed);
  WorldDraft w;
  w.name = "sphere3d";
  w.dimension = 3;
  std::vector<Pose3> truth;
  for (int i = 0; i < o.steps; ++i) {
    truth.push_back(spherePose(i, per_ring, rings, o.radius));
    w.poses.push_back(poseParameters(truth.back()));
    if (i == 0) continue;
    const double st = o.sigma_translation;
    const double sr = o.sigma_rotation;
    w.factors.push_back(
        noisyBetweenSE3(i - 1, i, relativePose(truth[i - 1], truth[i]), st, sr, random));
    const int j = i - per_ring;
    if (j < 0 || o.max_loops_per_pose == 0 || random.uniform() >= o.loop_probability) continue;
    w.factors.push_back(noisyBetweenSE3(j, i, relativePose(truth[j], truth[i]), st, sr, random));
  }
  return w;
}

}  // namespace lslam::sim::detail
