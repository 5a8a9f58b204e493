#pragma once
// A synthetic 2D pose graph in a Manhattan world (after Olson et al., ICRA 2006). Host-only.
//
// The robot drives on a grid of unit streets inside a square of world_size x world_size
// intersections (coordinates 0..world_size-1), starting at (0, 0) heading along +x. Each step it
// may turn +-90 deg at the intersection it stands on (left and right each with probability
// turn_probability / 2; a move that would leave the world is not taken, and the remaining choices
// keep their relative weights) and then drives 1 m forward. Pose ids are 0..poses-1 (time order).
//
// Edges, in online order (for each pose i >= 1: the odometry edge i-1 -> i, then its loop
// closures j -> i with j < i):
//  - odometry: the true relative pose of i in i-1 plus noise;
//  - loop closures: earlier poses j <= i - min_loop_separation whose true position is within
//    loop_radius of pose i are candidates; with probability loop_probability pose i gets
//    min(max_loops_per_pose, #candidates) of them, chosen uniformly; measurement = true relative
//    pose plus noise.
// Noise: independent zero-mean Gaussian on (dx, dy, dtheta) with std (sigma_x, sigma_y,
// sigma_theta) (dtheta wrapped to (-pi, pi]); information = diag(1/sigma^2), the inverse of that
// covariance. Vertices: pose 0 at the true start (0, 0, 0), every other pose chained from the
// previous one with the noisy odometry (the dead-reckoning initial estimate). No FIX lines.
//
// Deterministic: std::mt19937 seeded with `seed`, and the project's own transforms for uniform
// and Gaussian draws (Marsaglia's polar method; no std:: distributions, whose output differs
// between standard libraries). The graph topology (which edges exist) uses only exact arithmetic
// and is identical on every platform; the noise values go through std::log/std::sqrt and the
// vertices through std::sin/std::cos, which are identical wherever the maths library is.
#include <cstdint>
#include <vector>

#include "host_sim/dataset.h"

namespace lslam::sim {

struct SyntheticOptions {
  int poses = 500;                // >= 1
  std::uint32_t seed = 1;         // mt19937 seed
  int world_size = 10;            // intersections per side (>= 2)
  double turn_probability = 0.3;  // in [0, 1]
  double loop_probability = 0.5;  // in [0, 1]
  double loop_radius = 1.0;       // metres, >= 0 (1.0: same intersection or a neighbouring one)
  int min_loop_separation = 10;   // j <= i - this for a loop closure j -> i (>= 2)
  int max_loops_per_pose = 2;     // >= 0
  double sigma_x = 0.05;          // metres, > 0
  double sigma_y = 0.05;          // metres, > 0
  double sigma_theta = 0.01;      // radians, > 0
};

struct SyntheticWorld {
  Dataset2D dataset;                 // g2o format, name "synthetic-manhattan", lines 0
  std::vector<Pose2D> ground_truth;  // ground_truth[i] is the true pose of id i
};

// Throws std::invalid_argument for options outside the ranges above.
SyntheticWorld generateManhattanWorld(const SyntheticOptions& options = {});

}  // namespace lslam::sim
