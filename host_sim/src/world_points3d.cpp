// points3d (worlds.h): the 3D landmark world of synthetic_3d.h at any length.
#include <algorithm>

#include "world_draft.h"

namespace lslam::sim::detail {

namespace {

constexpr int kPosesPerLap = 100;

}  // namespace

WorldDraft draftPoints3D(const WorldOptions& o) {
  Synthetic3DOptions p;
  p.poses = o.steps;
  p.laps = std::max(1, o.steps / kPosesPerLap);
  p.landmarks = o.landmarks;
  p.seed = o.seed;
  p.radius = o.radius;
  p.loop_probability = o.max_loops_per_pose > 0 ? o.loop_probability : 0.0;
  p.observation_probability = 1.0;
  p.max_observations_per_pose = o.max_observations_per_pose;
  p.sensor_range = o.sensor_range;
  p.sigma_translation = o.sigma_translation;
  p.sigma_rotation = o.sigma_rotation;
  p.sigma_point = o.sigma_landmark;
  WorldDraft w = draftLandmarkWorld3D(p);
  w.name = "points3d";
  return w;
}

}  // namespace lslam::sim::detail
