#include "lslam/solver/update_validator.h"

#include "lslam/factors/information.h"

namespace lslam {

Status UpdateValidator::validate(const PoseInput* poses, Index num_poses,
                                 const FactorInput* factors, Index num_factors, const Gauge& gauge,
                                 Index* priors) {
  *priors = 0;
  if (num_poses < 0 || num_factors < 0 || (num_poses > 0 && poses == nullptr) ||
      (num_factors > 0 && factors == nullptr)) {
    return Status::InvalidArgument;
  }
  if (num_poses > graph_.maxVariables() - graph_.variables() ||
      num_factors > graph_.maxFactors() - graph_.factors()) {
    return Status::CapacityExhausted;
  }
  for (Index i = 0; i < num_poses; ++i) {
    if (validateValue(poses[i].initial) != Status::Ok) return Status::NonFiniteInput;
    if (poses[i].id < 0) return Status::InvalidArgument;
  }
  // The added ids enter the map now so that every lookup below is uniform; forgetNewIds() undoes
  // it.
  Index inserted = 0;
  Status status = Status::Ok;
  for (; inserted < num_poses; ++inserted) {
    if (ids_.find(poses[inserted].id) != kNoIndex) {
      status = Status::DuplicateVariable;
      break;
    }
    ids_.insert(poses[inserted].id, graph_.variables() + inserted);
  }
  Index prior_count = 0;
  for (Index f = 0; f < num_factors && status == Status::Ok; ++f) {
    const FactorInput& in = factors[f];
    const int arity = factorArity(in.kind);
    if (arity == 0) {
      status = Status::InvalidArgument;  // not a FactorKind
    } else if (ids_.find(in.from) == kNoIndex || (arity == 2 && ids_.find(in.to) == kNoIndex)) {
      status = Status::UnknownVariable;
    } else if (arity == 2 && in.from == in.to) {
      status = Status::InvalidArgument;
    } else if (validateValue(in.measurement) != Status::Ok) {
      status = Status::NonFiniteInput;
    } else {
      status = checkInformation(in.information);
    }
    prior_count += arity == 1 ? 1 : 0;
  }
  *priors = prior_count;
  // The anchor takes a factor too (PoseGraphSolver2D::update()).
  const bool anchor = Gauge::anchorsFirstPose(graph_.variables(), num_poses, prior_count);
  if (status == Status::Ok && anchor && num_factors + 1 > graph_.maxFactors()) {
    status = Status::CapacityExhausted;
  }
  if (status == Status::Ok) {
    status = checkAnchored(num_poses, factors, num_factors, anchor, gauge.dropsAnchor(prior_count));
  }
  if (status != Status::Ok) forgetNewIds(poses, inserted);
  return status;
}

// Every added pose must be tied to the existing graph (or to a prior) through this call's factors;
// a pose floating free would make Lambda singular, and rounding could hide that from the pivots.
// `anchor`: the solver anchors the first added pose (update() adds a prior). `drop_anchor`: this
// call takes the anchor out, so the committed graph (one connected piece, held by the anchor
// alone) must itself be tied to one of this call's priors: by a prior on a committed pose, or
// through this call's between factors to a pose it adds that is.
Status UpdateValidator::checkAnchored(Index num_poses, const FactorInput* factors,
                                      Index num_factors, bool anchor, bool drop_anchor) const {
  const Index first_new = graph_.variables();
  // A flag per added pose, and at [num_poses] one for the committed graph as a whole (index
  // `committed`). Few poses per call: the repeated sweeps stay small.
  std::uint8_t* is_anchored = is_anchored_;
  const Index committed = num_poses;
  const auto node = [&](VariableId id) {
    const Index v = ids_.find(id) - first_new;
    return v < 0 ? committed : v;
  };
  for (Index i = 0; i < num_poses; ++i) is_anchored[i] = 0;
  // (An empty graph has no committed node; then num_poses may fill the whole array.)
  if (first_new > 0) is_anchored[committed] = drop_anchor ? 0 : 1;
  Index anchored = 0;
  const Index required = num_poses + (drop_anchor ? 1 : 0);
  if (anchor) {
    is_anchored[0] = 1;
    anchored = 1;
  }
  bool progress = true;
  while (progress && anchored < required) {
    progress = false;
    for (Index f = 0; f < num_factors; ++f) {
      const FactorInput& in = factors[f];
      const Index a = node(in.from);
      if (factorArity(in.kind) == 1) {
        if (is_anchored[a] == 0) {
          is_anchored[a] = 1;
          ++anchored;
          progress = true;
        }
        continue;
      }
      const Index b = node(in.to);
      if ((is_anchored[a] != 0) != (is_anchored[b] != 0)) {
        is_anchored[is_anchored[a] != 0 ? b : a] = 1;
        ++anchored;
        progress = true;
      }
    }
  }
  return anchored == required ? Status::Ok : Status::UnconstrainedVariable;
}

void UpdateValidator::forgetNewIds(const PoseInput* poses, Index num_poses) {
  for (Index i = num_poses - 1; i >= 0; --i) ids_.eraseNewest(poses[i].id);
}

}  // namespace lslam
