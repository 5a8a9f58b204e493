#include "host_sim/steps.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <unordered_set>

#include "lslam/geometry/angle.h"
#include "lslam/geometry/se2.h"

namespace lslam::sim {

namespace {

std::string edgeText(const Edge2D& e) {
  return std::to_string(e.from) + " -> " + std::to_string(e.to);
}

void checkEdge(const Dataset2D& d, const Edge2D& e) {
  if (e.from < 0 || e.to < 0) {
    throw DatasetError(d.name, e.line, "edge " + edgeText(e) + ": id out of range (negative)");
  }
  if (e.from == e.to) {
    throw DatasetError(d.name, e.line, "edge " + edgeText(e) + " links a pose to itself");
  }
}

// Line of the first edge touching `id` in file order, or of its vertex; 0 if neither exists.
std::size_t firstLineOf(const Dataset2D& d, std::int64_t id, const Edge2D** first_edge) {
  *first_edge = nullptr;
  for (const Edge2D& e : d.edges) {
    if (e.from == id || e.to == id) {
      *first_edge = &e;
      return e.line;
    }
  }
  for (const Vertex2D& v : d.vertices) {
    if (v.id == id) return v.line;
  }
  return 0;
}

std::vector<Step> buildOnline(const Dataset2D& d) {
  std::vector<std::int64_t> ids;
  ids.reserve(2 * d.edges.size() + d.vertices.size());
  for (const Edge2D& e : d.edges) {
    checkEdge(d, e);
    ids.push_back(e.from);
    ids.push_back(e.to);
  }
  for (const Vertex2D& v : d.vertices) ids.push_back(v.id);
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());

  std::vector<Step> steps(ids.size());
  std::unordered_map<std::int64_t, std::size_t> step_of;
  step_of.reserve(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) {
    steps[k].new_pose = ids[k];
    step_of.emplace(ids[k], k);
  }
  for (std::size_t i = 0; i < d.edges.size(); ++i) {
    const Edge2D& e = d.edges[i];
    steps[step_of.at(std::max(e.from, e.to))].edges.push_back(i);
  }
  for (std::size_t k = 1; k < steps.size(); ++k) {
    if (!steps[k].edges.empty()) continue;
    const std::int64_t id = steps[k].new_pose;
    const Edge2D* first = nullptr;
    const std::size_t line = firstLineOf(d, id, &first);
    std::string reason = "pose " + std::to_string(id) +
                         " has no edge to an older pose (online order introduces poses in "
                         "ascending id order; previous pose " +
                         std::to_string(steps[k - 1].new_pose) + ")";
    if (first != nullptr) {
      reason += "; its first edge " + edgeText(*first) + " links it only to later poses";
    } else {
      reason += "; it has no edge at all";
    }
    throw DatasetError(d.name, line, reason);
  }
  return steps;
}

std::vector<Step> buildFile(const Dataset2D& d) {
  std::vector<Step> steps;
  std::unordered_set<std::int64_t> known;
  if (d.edges.empty()) {
    if (d.vertices.empty()) return steps;
    const auto smallest =
        std::min_element(d.vertices.begin(), d.vertices.end(),
                         [](const Vertex2D& a, const Vertex2D& b) { return a.id < b.id; });
    steps.push_back(Step{smallest->id, {}});
    known.insert(smallest->id);
  } else {
    const Edge2D& e0 = d.edges.front();
    checkEdge(d, e0);
    const std::int64_t anchor = std::min(e0.from, e0.to);
    steps.push_back(Step{anchor, {}});
    known.insert(anchor);
  }
  for (std::size_t i = 0; i < d.edges.size(); ++i) {
    const Edge2D& e = d.edges[i];
    checkEdge(d, e);
    const bool from_known = known.count(e.from) != 0;
    const bool to_known = known.count(e.to) != 0;
    if (from_known && to_known) {
      steps.back().edges.push_back(i);
    } else if (from_known || to_known) {
      const std::int64_t pose = from_known ? e.to : e.from;
      known.insert(pose);
      steps.push_back(Step{pose, {i}});
    } else {
      throw DatasetError(d.name, e.line,
                         "edge " + edgeText(e) +
                             " introduces two new poses (neither was seen in an earlier edge), "
                             "so file order cannot attach it to the graph");
    }
  }
  for (const Vertex2D& v : d.vertices) {
    if (known.count(v.id) == 0) {
      throw DatasetError(d.name, v.line,
                         "pose " + std::to_string(v.id) + " (vertex) has no edge in file order");
    }
  }
  return steps;
}

}  // namespace

std::vector<Step> buildSteps(const Dataset2D& d, StepOrder order) {
  switch (order) {
    case StepOrder::Online:
      return buildOnline(d);
    case StepOrder::File:
      return buildFile(d);
  }
  throw std::invalid_argument("buildSteps: unknown StepOrder");
}

Pose2D composeMeasurement(const Pose2D& xi, const Pose2D& z) {
  const double c = std::cos(xi.theta);
  const double s = std::sin(xi.theta);
  Pose2D out;
  out.x = xi.x + c * z.x - s * z.y;
  out.y = xi.y + s * z.x + c * z.y;
  out.theta = lslam::wrapAngle(xi.theta + z.theta);
  return out;
}

Pose2D relativePose(const Pose2D& xi, const Pose2D& xj) {
  const double c = std::cos(xi.theta);
  const double s = std::sin(xi.theta);
  const double dx = xj.x - xi.x;
  const double dy = xj.y - xi.y;
  Pose2D out;
  out.x = c * dx + s * dy;
  out.y = -s * dx + c * dy;
  out.theta = lslam::wrapAngle(xj.theta - xi.theta);
  return out;
}

// Through firmware_lib's SE2, so that firmware feeding the same stream (tests/target) starts every
// pose from the same doubles without a copy of this arithmetic.
Pose2D initialPoseFromEdge(const Edge2D& e, std::int64_t new_pose, const Pose2D& known_estimate) {
  const SE2 known(known_estimate.x, known_estimate.y, known_estimate.theta);
  const SE2 z(e.measurement.x, e.measurement.y, e.measurement.theta);
  if (new_pose == e.to || new_pose == e.from) {
    const SE2 pose = known.compose(new_pose == e.to ? z : z.inverse());
    return Pose2D{pose.x(), pose.y(), pose.theta()};
  }
  throw std::invalid_argument("initialPoseFromEdge: pose " + std::to_string(new_pose) +
                              " is not an endpoint of edge " + edgeText(e));
}

}  // namespace lslam::sim
