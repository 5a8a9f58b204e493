#pragma once
// The simulator's worlds: noisy SLAM datasets with their ground truth, for `lslam-sim simulate`.
// Host-only.
//
// Every world is a robot driving `steps` poses (ids 0..steps-1, time order), measuring its
// odometry, closing loops where it comes back near an earlier pose, and (where the world has
// them) observing point landmarks (ids steps, steps + 1, ... in order of first observation; only
// landmarks observed at least once exist). Factors are in online order: for each pose, its
// odometry, its loop closures, then its landmark observations.
//   grid2d    the Manhattan grid of synthetic.h (grid_size x grid_size intersections 1 m apart,
//             turns, loop closures to poses within loop_radius), plus `landmarks` points scattered
//             uniformly over the grid (margin 1 m), observed within sensor_range as a position in
//             the robot frame (EDGE_SE2_XY) or as range and bearing (EDGE_SE2_RANGE_BEARING).
//             With landmarks 0 and outlier_rate 0 its factors are those `lslam-sim generate`
//             writes.
//   sphere3d  sphere2500-like: rings of latitude on a sphere of `radius`, about sqrt(steps) poses
//             per ring, driven ring after ring; each pose closes a loop to the pose one ring
//             earlier at the same longitude (with loop_probability; max_loops_per_pose 0: none).
//   garage3d  parking-garage-like: `floors` rectangular floors (30 m x 12 m, 3 m apart), each
//             lap's last side a ramp to the next floor; the robot drives up to the top and back
//             down, again and again, closing loops to earlier poses within loop_radius on the same
//             floor (at most max_loops_per_pose per pose, with loop_probability).
//   points3d  the 3D landmark world of synthetic_3d.h: steps / 100 laps (at least one) of a wavy
//             circle of `radius`, growing 0.3 m a lap for 10 laps and shrinking back for 10 (a
//             long run keeps over the same landmarks); from the second lap on, a loop closure to
//             the pose one lap back with loop_probability (max_loops_per_pose 0: none); observing
//             the nearest of `landmarks` points within sensor_range as positions in the robot
//             frame (EDGE_SE3_TRACKXYZ).
// Landmarks nearer than max(0.5 m, 6 sigma_range) are not observed in grid2d (a bearing is
// ill-defined at the robot, and a range's noise must not make it negative).
//
// NOISE (zero-mean Gaussian, independent; the information written is the inverse covariance of
// the noise in the file's error coordinates, so chi2 at the optimum follows a chi-square law):
//   2D relative pose: (dx, dy, dtheta) + N(0, diag(st^2, st^2, sr^2));
//   3D relative pose: Z = T exp(dt, dr), dt ~ N(0, st^2 I), dr ~ N(0, sr^2 I); information
//     diag(1/st^2 x3, 4/sr^2 x3) (g2o's quaternion-vector coordinates are dr / 2);
//   landmark position in the robot frame: + N(0, sl^2 I); range-bearing: + N(0, diag(sg^2, sb^2)).
// OUTLIERS: with probability outlier_rate, a pose (at least min_loop_separation after the first)
// gets one wrong loop closure: to a pose at least min_loop_separation earlier and farther than
// wrongLoopClosureDistance (2 loop_radius + 1 m) from it (none if there is no such pose), measured
// as a plausible loop closure (a relative pose within loop_radius, any heading; 3D: any yaw) with
// the odometry's information. They are listed in SimulatedWorld::outliers.
//
// The initial values (vertices) are dead reckoning from the true first pose: each variable from the
// first factor that reaches it (model_chi2.h's initialEstimate). Deterministic for a seed on every
// platform where std::sin/cos/log/sqrt agree (portable draws, see synthetic.h).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "host_sim/model_dataset.h"

namespace lslam::sim {

enum class WorldKind { Grid2D, Sphere3D, Garage3D, Points3D };
enum class LandmarkMeasurement { Position, RangeBearing };

// "grid2d", "sphere3d", "garage3d", "points3d"; nullopt for another name.
std::optional<WorldKind> parseWorldKind(const std::string& name);
const char* worldKindName(WorldKind kind);

struct WorldOptions {
  int steps = 1000;        // poses, >= 2
  std::uint32_t seed = 1;  // mt19937 seed
  // Noise standard deviations (> 0): relative poses' translation (m, per axis) and rotation (rad;
  // 3D: per axis of the rotation vector); landmark positions (m, per axis); range (m); bearing.
  double sigma_translation = 0.05;
  double sigma_rotation = 0.01;
  double sigma_landmark = 0.05;
  double sigma_range = 0.05;
  double sigma_bearing = 0.01;
  // Loop closures: the probability that a pose with candidates closes loops, at most how many,
  // the distance of a candidate (m), and how many poses back it must lie at least.
  double loop_probability = 0.5;  // in [0, 1]
  int max_loops_per_pose = 2;     // >= 0
  double loop_radius = 1.0;       // >= 0
  int min_loop_separation = 10;   // >= 2
  double outlier_rate = 0.0;      // in [0, 1]
  // Landmarks (grid2d, points3d): how many are scattered, the sensor's range (m), how many of the
  // nearest in range a pose observes at most, and how (grid2d).
  int landmarks = 200;                // >= 0
  double sensor_range = 1.5;          // >= 0
  int max_observations_per_pose = 3;  // >= 0
  LandmarkMeasurement landmark_measurement = LandmarkMeasurement::Position;
  // Geometry.
  int grid_size = 10;             // grid2d: intersections per side, >= 2
  double turn_probability = 0.3;  // grid2d: in [0, 1]
  double radius = 10.0;           // sphere3d, points3d: m, > 0
  int floors = 4;                 // garage3d: >= 1
};

// The options a world starts from (then the command line's): the fields above, except sphere3d's
// 2500 steps, loop_probability 1 and one loop per pose (sphere2500 closes nearly every pose),
// garage3d's 1600 steps and loop_probability 0.8 (neither has landmarks), and points3d's 60
// landmarks within 4 m and loop_probability 0.3.
WorldOptions defaultWorldOptions(WorldKind kind);

struct SimulatedWorld {
  ModelDataset dataset;               // g2o; vertices: the initial values
  ModelDataset truth;                 // g2o; vertices only: the true poses and landmarks
  std::vector<std::size_t> outliers;  // indices into dataset.factors of the wrong loop closures
};

// How far apart the two poses of a wrong loop closure are at least (OUTLIERS above).
double wrongLoopClosureDistance(const WorldOptions& options);

// Throws std::invalid_argument for options outside the ranges above.
SimulatedWorld simulateWorld(WorldKind kind, const WorldOptions& options);

}  // namespace lslam::sim
