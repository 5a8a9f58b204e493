// garage3d (worlds.h): rectangular floors joined by ramps, driven up and down again and again.
#include <algorithm>
#include <cmath>
#include <utility>

#include "world_draft.h"
#include "world_measurements.h"

namespace lslam::sim::detail {

namespace {

constexpr double kLength = 30.0;      // m, a floor's long side (x)
constexpr double kWidth = 12.0;       // m, its short side (y), the last of which is the ramp
constexpr double kFloorHeight = 3.0;  // m
constexpr double kStep = 1.0;         // m driven between poses
constexpr double kLap = 2.0 * (kLength + kWidth);

// The point at arc length s of a lap, counter-clockwise from (0, 0), and the direction of travel.
std::pair<Eigen::Vector2d, Eigen::Vector2d> lapPoint(double s) {
  if (s < kLength) return {{s, 0.0}, {1.0, 0.0}};
  s -= kLength;
  if (s < kWidth) return {{kLength, s}, {0.0, 1.0}};
  s -= kWidth;
  if (s < kLength) return {{kLength - s, kWidth}, {-1.0, 0.0}};
  s -= kLength;
  return {{0.0, kWidth - s}, {0.0, -1.0}};
}

// A point of the way up at arc length u: the floors' laps, each lap's last side climbing to the
// next floor, the top floor's flat. Its position, direction of travel (x-y) and whether it climbs.
struct PathPoint {
  Eigen::Vector3d position;
  Eigen::Vector2d direction;
  bool climbing = false;
};

PathPoint upPath(double u, int floors) {
  const int floor = std::min(static_cast<int>(u / kLap), floors - 1);
  const double s = u - kLap * floor;
  const auto [xy, direction] = lapPoint(s);
  const double ramp_start = kLap - kWidth;
  const bool climbing = floor + 1 < floors && s >= ramp_start;
  const double z = kFloorHeight * (floor + (climbing ? (s - ramp_start) / kWidth : 0.0));
  return {Eigen::Vector3d(xy.x(), xy.y(), z), direction, climbing};
}

// The true pose after driving `distance` metres: up the floors, then the same way back down (a
// U-turn on the spot at the top and at the bottom), and again.
Pose3 garagePose(double distance, int floors) {
  const double up_length = kLap * floors;
  double u = std::fmod(distance, 2.0 * up_length);
  const bool descending = u > up_length;
  if (descending) u = 2.0 * up_length - u;
  const PathPoint at = upPath(u, floors);
  // It faces the way it drives next: on the way down, the stretch just before u on the way up.
  const PathPoint ahead = descending ? upPath(std::max(0.0, u - 1e-9), floors) : at;
  const double sign = descending ? -1.0 : 1.0;
  const double yaw = std::atan2(sign * ahead.direction.y(), sign * ahead.direction.x());
  const double pitch = ahead.climbing ? sign * std::atan(kFloorHeight / kWidth) : 0.0;
  // Nose up is a negative rotation about the robot's y axis (x forward, z up).
  const Eigen::Quaterniond q = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitY());
  return {q.normalized(), at.position};
}

// The earlier poses pose i closes loops to (worlds.h: loop_radius, min_loop_separation,
// loop_probability, max_loops_per_pose).
std::vector<int> loopPartners(const WorldOptions& o, const std::vector<Pose3>& truth, int i,
                              PortableRandom& random) {
  std::vector<int> candidates;
  for (int j = 0; j + o.min_loop_separation <= i; ++j) {
    if ((truth[j].t - truth[i].t).norm() <= o.loop_radius) candidates.push_back(j);
  }
  if (candidates.empty() || o.max_loops_per_pose == 0) return {};
  if (random.uniform() >= o.loop_probability) return {};
  const std::size_t count =
      std::min(static_cast<std::size_t>(o.max_loops_per_pose), candidates.size());
  for (std::size_t k = 0; k < count; ++k) {  // partial Fisher-Yates
    std::swap(candidates[k], candidates[k + random.index(candidates.size() - k)]);
  }
  candidates.resize(count);
  return candidates;
}

}  // namespace

WorldDraft draftGarage3D(const WorldOptions& o) {
  PortableRandom random(o.seed);
  WorldDraft w;
  w.name = "garage3d";
  w.dimension = 3;
  std::vector<Pose3> truth;
  const double st = o.sigma_translation;
  const double sr = o.sigma_rotation;
  for (int i = 0; i < o.steps; ++i) {
    truth.push_back(garagePose(kStep * i, o.floors));
    w.poses.push_back(poseParameters(truth.back()));
    if (i == 0) continue;
    w.factors.push_back(
        noisyBetweenSE3(i - 1, i, relativePose(truth[i - 1], truth[i]), st, sr, random));
    for (const int j : loopPartners(o, truth, i, random)) {
      w.factors.push_back(noisyBetweenSE3(j, i, relativePose(truth[j], truth[i]), st, sr, random));
    }
  }
  return w;
}

}  // namespace lslam::sim::detail
