#pragma once
// What the caller hands to PoseGraphSolver2D::update(): poses and measurements.
#include "lslam/eigen.h"
#include "lslam/factors/pose_graph_2d.h"
#include "lslam/geometry/se2.h"
#include "lslam/solver/id_map.h"

namespace lslam {

struct PoseInput {
  VariableId id = 0;
  SE2 initial;
};

// A measurement: a prior on pose `from` (to is ignored), or pose `to` seen from pose `from`. A
// kind outside FactorKind is rejected (InvalidArgument). The information must be symmetric
// positive definite (checkInformation); one symmetric only to rounding is used as its symmetric
// part (symmetricPart), whichever path the update takes.
struct FactorInput {
  FactorKind kind = FactorKind::BetweenSE2;
  VariableId from = 0;
  VariableId to = 0;
  SE2 measurement;
  Mat3 information = Mat3::Identity();
};

}  // namespace lslam
