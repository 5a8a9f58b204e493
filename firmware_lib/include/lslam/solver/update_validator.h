#pragma once
// The checks an update passes before anything changes: ids, kinds, NaN/Inf, information SPD,
// capacity, and every added pose tied to the map or to a prior (the gauge). A rejected update
// leaves the id map as it was; an accepted one has the ids it adds in it.
#include <cstdint>

#include "lslam/factors/pose_graph_2d.h"
#include "lslam/linear/index.h"
#include "lslam/solver/gauge.h"
#include "lslam/solver/id_map.h"
#include "lslam/solver/update_input.h"
#include "lslam/status.h"

namespace lslam {

class UpdateValidator {
 public:
  // anchored_scratch: max_variables flags, this validator's alone.
  UpdateValidator(std::uint8_t* anchored_scratch, const PoseGraph2D& graph, IdMap& ids)
      : is_anchored_(anchored_scratch), graph_(graph), ids_(ids) {}

  // Validates an update against the committed graph and, on Ok, leaves the ids it adds in the map.
  // Also counts the caller's priors among the factors (valid or not: read only on Ok).
  [[nodiscard]] Status validate(const PoseInput* poses, Index num_poses, const FactorInput* factors,
                                Index num_factors, const Gauge& gauge, Index* priors);
  // Takes the ids of the first num_poses poses out of the map again (newest first).
  void forgetNewIds(const PoseInput* poses, Index num_poses);

 private:
  Status checkAnchored(Index num_poses, const FactorInput* factors, Index num_factors, bool anchor,
                       bool drop_anchor) const;

  std::uint8_t* is_anchored_;
  const PoseGraph2D& graph_;
  IdMap& ids_;
};

}  // namespace lslam
