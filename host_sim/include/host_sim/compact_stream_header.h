#pragma once
// Turns a long 2D pose graph (a `simulate grid2d` world and its truth) into a C++ header for the
// Cortex-M7 program that maps it in fixed memory (tests/target/compact_stream.cpp, a
// CompactPoseGraph<PoseSlam2D> on max_poses nodes), with the host's results on the same inputs.
// Host-only.
//
// The stream, as a robot whose place recognition matches against its map's keyframes: each step's
// odometry from the previous pose, and its loop closures to poses that are nodes of the map (the
// first max_poses poses; closures to later poses are left out, as the target keeps no record of
// them). Measurements are rounded to float (the stream lives in flash); every odometry and every
// loop closure must share one information matrix each (grid2d's), written once.
//
// The header (<cstdint> only):
//   kMaxPoses, kMaxFactors, kFactorBlocks   the solver's capacities (the block pool as lslam-sim
//                                           run --max-poses sizes it);
//   kNumSteps, kFirstPose[3], kOdometry[kNumSteps - 1][3] (step s + 1: x y theta from pose s);
//   kOdometryInformation[6], kClosureInformation[6]    upper triangles, row by row;
//   kClosures[] {step, node, x y theta}       by step;
//   kHostChi2                                 Smoother::chi2() after the host's run of the stream;
//   kHostNodes[kMaxPoses][3]                  the host's node estimates;
//   kTruthNodes[kMaxPoses][2]                 the nodes' true positions;
//   kFirstBatchMapRms                         the position RMS against the truth (rigidly aligned)
//                                             of the independent batch optimum of the first
//                                             kMaxPoses steps: the map the capacity would freeze.
#include <string>

#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"

namespace lslam::sim {

// Throws std::invalid_argument for a dataset that is not a 2D pose graph of odometry chains,
// information that differs between measurements of one kind, a truth without every node, or a
// name_space that is not an identifier.
std::string compactStreamHeader(const ModelDataset& d, const ModelEstimate& truth, int max_poses,
                                const std::string& source_name, const std::string& name_space);

}  // namespace lslam::sim
