#pragma once
// A small synthetic 3D SLAM dataset with point landmarks, for the Cortex-M7 landmark stream
// (data/landmarks_3d_300.g2o). Host-only.
//
// The robot flies `laps` laps of a wavy circle (radius growing by lap_radius_step each lap for
// sweep_laps laps, then shrinking as long back, and so on; height
// height_amplitude * sin(2 phi + lap)), facing along the track with a small roll; pose ids
// 0..poses-1 in time order. Landmarks (ids poses, poses + 1, ...) are scattered around the track
// (radius +-landmark_spread, height -1..2 m); only those observed at least twice are kept,
// renumbered in order of first observation.
//
// Factors, in online order (for each pose i: odometry i-1 -> i, its loop closure, its
// observations):
//  - odometry: the true relative pose with noise;
//  - loop closures: from the pose one lap earlier (i - poses / laps), with probability
//    loop_probability;
//  - observations: with probability observation_probability a pose observes the (at most)
//    max_observations_per_pose nearest landmarks within sensor_range, as EDGE_SE3_TRACKXYZ (the
//    landmark in the robot frame) with noise.
// Noise: a relative pose Z = T exp(dt, dr) with dt ~ N(0, sigma_translation^2 I), dr (rotation
// vector) ~ N(0, sigma_rotation^2 I); information diag(1/sigma_t^2 x3, 4/sigma_r^2 x3), g2o's
// coordinates (t, quaternion vector ~ dr / 2). A point: z + N(0, sigma_point^2 I), information
// I / sigma_point^2. Vertices: host_sim's initialEstimate of the factors (dead reckoning).
//
// Deterministic: std::mt19937 with the project's own uniform and Gaussian transforms (as
// synthetic.h); values through std::sin/std::cos/std::log/std::sqrt.
#include <cstdint>

#include "host_sim/model_dataset.h"

namespace lslam::sim {

struct Synthetic3DOptions {
  int poses = 300;               // >= 2 * laps
  int laps = 3;                  // >= 1
  int landmarks = 40;            // scattered before the observation filter, >= 0
  std::uint32_t seed = 7;        // mt19937 seed
  double radius = 10.0;          // metres, first lap
  double lap_radius_step = 0.3;  // metres per lap
  // Laps after which the radius turns: it sweeps out and back in between radius and radius +
  // sweep_laps x lap_radius_step, so that a long run keeps flying over the same landmarks (0: it
  // grows for ever; at most 1,000,000).
  int sweep_laps = 10;
  double height_amplitude = 0.5;         // metres
  double landmark_spread = 3.0;          // metres around the track
  double loop_probability = 0.3;         // in [0, 1]
  double observation_probability = 0.5;  // in [0, 1]
  int max_observations_per_pose = 2;     // >= 0
  double sensor_range = 4.0;             // metres
  double sigma_translation = 0.05;       // metres, > 0
  double sigma_rotation = 0.01;          // radians, > 0
  double sigma_point = 0.05;             // metres, > 0
};

// Throws std::invalid_argument for options outside the ranges above. The dataset is g2o, dimension
// 3, named "synthetic-landmarks-3d"; its lines are 0.
ModelDataset generateLandmarkWorld3D(const Synthetic3DOptions& options = {});

}  // namespace lslam::sim
