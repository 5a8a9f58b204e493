#include "host_sim/synthetic.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>

#include "host_sim/steps.h"
#include "lslam/geometry/angle.h"
#include "portable_random.h"

namespace lslam::sim {

namespace {

constexpr double kPi = 3.14159265358979323846;

using Random = detail::PortableRandom;

// Headings are quarter turns 0..3 (+x, +y, -x, -y).
constexpr std::array<int, 4> kStepX = {1, 0, -1, 0};
constexpr std::array<int, 4> kStepY = {0, 1, 0, -1};

double headingAngle(int quarter_turns) {
  switch (((quarter_turns % 4) + 4) % 4) {
    case 1:
      return 0.5 * kPi;
    case 2:
      return kPi;
    case 3:
      return -0.5 * kPi;
    default:
      return 0.0;
  }
}

struct GridPose {
  int x = 0;
  int y = 0;
  int heading = 0;  // quarter turns
};

// Exact relative pose of b in a's frame (rotation by a multiple of 90 deg).
Pose2D exactRelative(const GridPose& a, const GridPose& b) {
  const int dx = b.x - a.x;
  const int dy = b.y - a.y;
  int rx = dx;
  int ry = dy;
  switch (a.heading) {  // rotate (dx, dy) by -heading
    case 1:
      rx = dy;
      ry = -dx;
      break;
    case 2:
      rx = -dx;
      ry = -dy;
      break;
    case 3:
      rx = -dy;
      ry = dx;
      break;
    default:
      break;
  }
  return Pose2D{static_cast<double>(rx), static_cast<double>(ry),
                headingAngle(b.heading - a.heading)};
}

void validate(const SyntheticOptions& o) {
  auto bad = [](const std::string& what) {
    throw std::invalid_argument("generateManhattanWorld: " + what);
  };
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  auto probability = [](double p) { return p >= 0.0 && p <= 1.0; };  // false for NaN
  if (o.poses < 1) bad("poses must be >= 1");
  if (o.world_size < 2) bad("world_size must be >= 2");
  if (!probability(o.turn_probability)) bad("turn_probability must be in [0, 1]");
  if (!probability(o.loop_probability)) bad("loop_probability must be in [0, 1]");
  if (!(std::isfinite(o.loop_radius) && o.loop_radius >= 0.0)) bad("loop_radius must be >= 0");
  if (o.min_loop_separation < 2) bad("min_loop_separation must be >= 2");
  if (o.max_loops_per_pose < 0) bad("max_loops_per_pose must be >= 0");
  if (!positive(o.sigma_x) || !positive(o.sigma_y) || !positive(o.sigma_theta)) {
    bad("noise standard deviations must be finite and > 0");
  }
}

}  // namespace

SyntheticWorld generateManhattanWorld(const SyntheticOptions& options) {
  validate(options);
  Random rng(options.seed);
  const auto n = static_cast<std::size_t>(options.poses);
  const int last = options.world_size - 1;

  // Ground truth walk.
  std::vector<GridPose> grid(n);
  for (std::size_t i = 1; i < n; ++i) {
    const GridPose& p = grid[i - 1];
    // Choices: 0 straight, 1 left (+90 deg), 2 right (-90 deg).
    std::array<double, 3> weight = {1.0 - options.turn_probability, 0.5 * options.turn_probability,
                                    0.5 * options.turn_probability};
    std::array<bool, 3> allowed{};
    for (int c = 0; c < 3; ++c) {
      const int h = (p.heading + (c == 1 ? 1 : c == 2 ? 3 : 0)) % 4;
      const int nx = p.x + kStepX[static_cast<std::size_t>(h)];
      const int ny = p.y + kStepY[static_cast<std::size_t>(h)];
      allowed[static_cast<std::size_t>(c)] = nx >= 0 && nx <= last && ny >= 0 && ny <= last;
    }
    double total = 0.0;
    for (std::size_t c = 0; c < 3; ++c) {
      if (!allowed[c]) weight[c] = 0.0;
      total += weight[c];
    }
    if (total <= 0.0) {  // e.g. turn_probability == 0 facing the border: any allowed turn
      for (std::size_t c = 0; c < 3; ++c) weight[c] = allowed[c] ? 1.0 : 0.0;
      total = 0.0;
      for (double w : weight) total += w;
    }
    const double u = rng.uniform() * total;
    std::size_t choice = 0;
    double acc = 0.0;
    for (std::size_t c = 0; c < 3; ++c) {
      if (weight[c] <= 0.0) continue;
      choice = c;
      acc += weight[c];
      if (u < acc) break;
    }
    GridPose q;
    q.heading = (p.heading + (choice == 1 ? 1 : choice == 2 ? 3 : 0)) % 4;
    q.x = p.x + kStepX[static_cast<std::size_t>(q.heading)];
    q.y = p.y + kStepY[static_cast<std::size_t>(q.heading)];
    grid[i] = q;
  }

  SyntheticWorld world;
  world.ground_truth.reserve(n);
  for (const GridPose& g : grid) {
    world.ground_truth.push_back(
        Pose2D{static_cast<double>(g.x), static_cast<double>(g.y), headingAngle(g.heading)});
  }

  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  information(0, 0) = 1.0 / (options.sigma_x * options.sigma_x);
  information(1, 1) = 1.0 / (options.sigma_y * options.sigma_y);
  information(2, 2) = 1.0 / (options.sigma_theta * options.sigma_theta);

  auto noisyEdge = [&](std::size_t from, std::size_t to) {
    Edge2D e;
    e.from = static_cast<std::int64_t>(from);
    e.to = static_cast<std::int64_t>(to);
    const Pose2D exact = exactRelative(grid[from], grid[to]);
    e.measurement.x = exact.x + options.sigma_x * rng.normal();
    e.measurement.y = exact.y + options.sigma_y * rng.normal();
    e.measurement.theta = lslam::wrapAngle(exact.theta + options.sigma_theta * rng.normal());
    e.information = information;
    return e;
  };

  Dataset2D& d = world.dataset;
  d.name = "synthetic-manhattan";
  d.format = DatasetFormat::G2o;
  d.vertices.reserve(n);
  Vertex2D v0;
  v0.id = 0;
  v0.pose = world.ground_truth[0];
  d.vertices.push_back(v0);

  const double r2 = options.loop_radius * options.loop_radius;
  const auto separation = static_cast<std::size_t>(options.min_loop_separation);
  const auto max_loops = static_cast<std::size_t>(options.max_loops_per_pose);
  std::vector<std::size_t> candidates;
  for (std::size_t i = 1; i < n; ++i) {
    const Edge2D odometry = noisyEdge(i - 1, i);
    d.edges.push_back(odometry);
    Vertex2D v;
    v.id = static_cast<std::int64_t>(i);
    v.pose = composeMeasurement(d.vertices.back().pose, odometry.measurement);
    d.vertices.push_back(v);

    candidates.clear();
    for (std::size_t j = 0; j + separation <= i; ++j) {
      const int dx = grid[i].x - grid[j].x;
      const int dy = grid[i].y - grid[j].y;
      if (static_cast<double>(dx * dx + dy * dy) <= r2) candidates.push_back(j);
    }
    if (candidates.empty() || max_loops == 0) continue;
    if (rng.uniform() >= options.loop_probability) continue;
    const std::size_t count = std::min(max_loops, candidates.size());
    for (std::size_t k = 0; k < count; ++k) {  // partial Fisher-Yates
      const std::size_t pick = k + rng.index(candidates.size() - k);
      std::swap(candidates[k], candidates[pick]);
      d.edges.push_back(noisyEdge(candidates[k], i));
    }
  }
  return world;
}

}  // namespace lslam::sim
