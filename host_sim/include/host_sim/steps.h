#pragma once
// The incremental order in which a dataset is fed to a solver, and the small SE(2) helpers used to
// initialise a new pose. Host-only; independent of firmware_lib's geometry (these are reference
// computations).
//
// A step introduces at most one new pose and carries the edges the solver adds with it. Step 0
// introduces the first pose of the graph and has no edges (the solver anchors it with a prior).
// Every later step's edges only reference poses introduced by this or earlier steps, and the new
// pose appears in the step's first edge, so the solver can initialise it from that edge
// (initialPoseFromEdge) before adding the edges. Every edge of the dataset appears in exactly one
// step.
//
// The pose set is every id used by an edge or a vertex. Ids need not be contiguous.
//
// StepOrder::Online (the order a robot would produce the data): poses are introduced in ascending
// id order (pose ids in these datasets are time-ordered); step k introduces the k-th smallest id
// and holds every edge whose larger endpoint max(from, to) is that pose, in file order among
// themselves. Edges between two older poses therefore cannot occur. Every pose except the first
// must have at least one edge to an older pose; otherwise (a pose linked only to later poses, a
// vertex without edges, a graph of several components) DatasetError(name, line, reason) names the
// pose and the line of its first edge in file order (of its vertex if it has no edge).
//
// StepOrder::File (the file as a stream of edges): the first edge's smaller endpoint is the anchor
// (step 0, no edges) and its other endpoint is step 1's new pose. Then edges are walked in file
// order: an edge with one endpoint not seen yet starts a new step that introduces that pose (the
// step is that pose, that edge and the following edges until the next new pose); an edge whose
// endpoints are both known goes into the current (last) step; an edge with both endpoints unknown
// throws DatasetError(name, edge line, "edge i -> j introduces two new poses ..."). This is what
// happens on intel.g2o, whose edges are listed out of time order: its first edge is 441 -> 442
// (line 896) and its second 411 -> 412 (line 897), so File order throws at line 897; use Online
// order for intel. A vertex whose id no edge uses also throws (at the vertex line). With no edges,
// the smallest vertex id is the only step.
//
// Both orders: an edge with from == to or a negative id throws DatasetError at the edge's line.
// An empty dataset gives no steps.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "host_sim/dataset.h"

namespace lslam::sim {

enum class StepOrder { Online, File };

struct Step {
  std::int64_t new_pose = -1;      // pose introduced by this step, -1 if none
  std::vector<std::size_t> edges;  // indices into Dataset2D::edges
};

std::vector<Step> buildSteps(const Dataset2D& d, StepOrder order);

// ---- SE(2) helpers (angles wrapped to (-pi, pi]) ----

// xi * z: the pose reached from xi by the relative motion z (expressed in xi's frame).
Pose2D composeMeasurement(const Pose2D& xi, const Pose2D& z);
// xi^-1 * xj: the pose xj seen from xi (the noise-free measurement of an edge xi -> xj).
Pose2D relativePose(const Pose2D& xi, const Pose2D& xj);

// Initial value of `new_pose` from edge e and the current estimate of e's other endpoint:
// known * z if new_pose == e.to, known * z^-1 if new_pose == e.from. Throws std::invalid_argument
// if new_pose is not an endpoint of e.
Pose2D initialPoseFromEdge(const Edge2D& e, std::int64_t new_pose, const Pose2D& known_estimate);

}  // namespace lslam::sim
