#pragma once
// The gauge rules (see "The gauge" in smoother.h): which update gets the anchor, the
// solver's prior on the first pose, and which takes it out again (the caller's first prior).
#include "lslam/linear/index.h"

namespace lslam {

class Gauge {
 public:
  // Whether an update of num_poses poses and `priors` caller priors, onto a committed graph of
  // `committed_variables`, gets the anchor.
  static bool anchorsFirstPose(Index committed_variables, Index num_poses, Index priors) {
    return committed_variables == 0 && num_poses > 0 && priors == 0;
  }
  // Whether an update with `priors` caller priors takes the anchor out (the caller's first prior).
  bool dropsAnchor(Index priors) const { return anchor_factor_ != kNoIndex && priors > 0; }
  // The anchor's factor while it is in the problem, else kNoIndex.
  Index anchorFactor() const { return anchor_factor_; }
  // After a committed update that added the anchor as factor `anchor_factor`, or dropped it.
  void commit(bool anchored, bool dropped, Index anchor_factor) {
    if (anchored) anchor_factor_ = anchor_factor;
    if (dropped) anchor_factor_ = kNoIndex;
  }

 private:
  Index anchor_factor_ = kNoIndex;
};

}  // namespace lslam
