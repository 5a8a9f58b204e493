#include "lslam/solver/compact_pose_graph.h"

#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"

namespace lslam {
namespace {

template <class Pose>
using Matrix = Eigen::Matrix<double, Pose::kDof, Pose::kDof>;

// a b with the covariance of independent a and b (right perturbations, first order).
template <class Pose>
Pose composeWithCovariance(const Pose& a, const Matrix<Pose>& sa, const Pose& b,
                           const Matrix<Pose>& sb, Matrix<Pose>* s) {
  Matrix<Pose> ja;
  Matrix<Pose> jb;
  const Pose c = a.compose(b, &ja, &jb);
  *s = ja * sa * ja.transpose() + jb * sb * jb.transpose();
  return c;
}

// A column at a time: a matrix right-hand side takes Eigen's blocked solver, whose workspace may
// come from the heap.
template <class Pose>
Matrix<Pose> inverseOf(const Matrix<Pose>& spd) {
  const Eigen::LLT<Matrix<Pose>> llt(spd);
  Matrix<Pose> inverse;
  for (int c = 0; c < Pose::kDof; ++c) inverse.col(c) = llt.solve(Matrix<Pose>::Identity().col(c));
  return inverse;
}

template <class Pose>
bool finiteSymmetric(const Matrix<Pose>& m) {
  return m.allFinite() && m.isApprox(m.transpose(), 1e-9);
}

}  // namespace

template <class Model>
Status CompactPoseGraph<Model>::start(const Pose& first, UpdateResult* result) {
  if (smoother_.variables() != 0) return Status::InvalidArgument;
  const auto pose = ModelVariableInput<Model>::make(0, first);
  const Status s = smoother_.update(&pose, 1, nullptr, 0, result);
  if (s == Status::Ok) current_ = PlaceT{0, Pose(), Matrix::Zero()};
  return s;
}

template <class Model>
Status CompactPoseGraph<Model>::check(const Pose& odometry, const Matrix& information,
                                      const Closure* closures, Index num_closures) const {
  if (num_closures < 0 || (num_closures > 0 && closures == nullptr) || smoother_.poses() == 0) {
    return Status::InvalidArgument;
  }
  Status s = Between::validate(odometry, information);
  for (Index i = 0; s == Status::Ok && i < num_closures; ++i) {
    const Closure& c = closures[i];
    s = Between::validate(c.measurement, c.information);
    if (s == Status::Ok) s = validateValue(c.seen.offset);
    if (s == Status::Ok && !finiteSymmetric<Pose>(c.seen.covariance)) s = Status::InvalidArgument;
    if (s == Status::Ok && (c.seen.node < 0 || c.seen.node >= smoother_.poses())) {
      s = Status::UnknownVariable;
    }
  }
  return s;
}

template <class Model>
Status CompactPoseGraph<Model>::addStep(const Pose& odometry, const Matrix& information,
                                        const Closure* closures, Index num_closures,
                                        CompactStepResult* result) {
  CompactStepResult local;
  CompactStepResult& r = result != nullptr ? *result : local;
  r = CompactStepResult{};
  r.status = check(odometry, information, closures, num_closures);
  if (r.status != Status::Ok) return r.status;

  // The new pose in the current node's frame.
  Matrix covariance;
  const Pose offset = composeWithCovariance<Pose>(current_.offset, current_.covariance, odometry,
                                                  inverseOf<Pose>(information), &covariance);
  const auto& graph = smoother_.graph();
  if (graph.freeVariablesOfKind(0) > 0 && graph.template canAddFactor<Between>()) {
    const Index node = smoother_.poses();
    const auto pose =
        ModelVariableInput<Model>::make(node, estimate(PlaceT{current_.node, offset, covariance}));
    // At a node the odometry goes in as it came (full smoothing, bit for bit).
    const Matrix info = current_.atNode() ? information : inverseOf<Pose>(covariance);
    const auto factor = ModelFactorInput<Model>::template make<Between>(
        current_.node, node, current_.atNode() ? odometry : offset, info);
    UpdateResult u;
    const Status s = smoother_.update(&pose, 1, &factor, 1, &u);
    if (s == Status::Ok) {
      record(u, r);
      r.node_added = true;
      current_ = PlaceT{node, Pose(), Matrix::Zero()};
    } else if (s != Status::CapacityExhausted) {
      r.status = s;
      return s;
    }
  }
  if (!r.node_added) current_ = PlaceT{current_.node, offset, covariance};
  for (Index i = 0; i < num_closures; ++i) closeLoop(closures[i], r);
  return Status::Ok;
}

// The loop closure as a factor between nodes (see the header), then the relocalization.
template <class Model>
void CompactPoseGraph<Model>::closeLoop(const Closure& c, CompactStepResult& r) {
  const Index a = current_.node;
  const Index b = c.seen.node;
  // The current pose in b's frame, through the pose seen.
  Matrix seen_covariance;
  const Pose seen_offset =
      composeWithCovariance<Pose>(c.seen.offset, c.seen.covariance, c.measurement,
                                  inverseOf<Pose>(c.information), &seen_covariance);
  if (a != b) {
    const bool exact = current_.atNode() && c.seen.atNode();
    Pose z = c.measurement;  // b -> a
    Matrix covariance;
    Matrix info = c.information;
    if (!exact) {
      Matrix j_inverse;
      const Pose to_node = current_.offset.inverse(&j_inverse);
      z = composeWithCovariance<Pose>(seen_offset, seen_covariance, to_node,
                                      j_inverse * current_.covariance * j_inverse.transpose(),
                                      &covariance);
      info = inverseOf<Pose>(covariance);
    }
    bool reversed = false;
    const Index existing = factorBetween(b, a, &reversed);
    if (reversed) {  // a -> b: the inverse measurement, its information carried through
      z = z.inverse();
      Matrix back;  // d z^-1 / d z inverted: the derivative of inverting again
      static_cast<void>(z.inverse(&back));
      info = back.transpose() * info * back;
    }
    const Index from = reversed ? a : b;
    const Index to = reversed ? b : a;
    const auto factor = ModelFactorInput<Model>::template make<Between>(from, to, z, info);
    UpdateResult u;
    Status s = Status::CapacityExhausted;
    if (existing != kNoIndex) {
      s = smoother_.addFolded(factor, existing, &u);
    } else if (roomForNewPair()) {
      s = smoother_.update(nullptr, 0, &factor, 1, &u);
    }
    if (s == Status::Ok) {
      record(u, r);
      (existing != kNoIndex ? r.folded : r.factors_added) += 1;
    } else {
      // The inputs were checked: only room (or a factorization that failed and changed nothing)
      // is left to refuse it.
      r.dropped += 1;
    }
  }
  relocalize(b, seen_offset, seen_covariance, r);
}

// The current pose from a loop closure (in b's frame) fused with the current place (in a's): the
// information-weighted mean, as a filter does, in the frame of the older of the two nodes (the
// other's offset carried over through the nodes' estimates; a right-perturbation covariance is
// unchanged by that). Keeping places on the oldest nodes makes later loop closures join the same
// pairs again, which fold. At a node the current place is exact and stays.
template <class Model>
void CompactPoseGraph<Model>::relocalize(Index b, const Pose& seen, const Matrix& seen_covariance,
                                         CompactStepResult& r) {
  if (current_.atNode()) return;
  const Index a = current_.node;
  const Index node = a < b ? a : b;
  const auto inFrameOf = [&](Index from, const Pose& offset) {
    return from == node ? offset
                        : estimateAt(node).inverse().compose(estimateAt(from)).compose(offset);
  };
  Matrix information;
  const Pose fused = mergedMeasurement(inFrameOf(b, seen), inverseOf<Pose>(seen_covariance),
                                       inFrameOf(a, current_.offset),
                                       inverseOf<Pose>(current_.covariance), &information);
  current_ = PlaceT{node, fused, inverseOf<Pose>(information)};
  r.relocalized = true;
}

// A factor for a new pair while the graph has one free and the Cholesky factor fills at most
// kNewPairPoolShare of its block pool: past that, a reordering (which stages a whole new factor
// beside the live one) could no longer fit, and the attempt would fail only after its work.
template <class Model>
bool CompactPoseGraph<Model>::roomForNewPair() const {
  const auto& factor = smoother_.factor();
  return smoother_.graph().template canAddFactor<Between>() &&
         static_cast<double>(factor.liveBlocks()) <=
             kNewPairPoolShare * static_cast<double>(factor.poolCapacity());
}

template <class Model>
Index CompactPoseGraph<Model>::factorBetween(Index b, Index a, bool* reversed) const {
  const auto& graph = smoother_.graph();
  Index found = kNoIndex;
  graph.forEachFactor(a, [&](Index f) {
    if (found != kNoIndex || graph.factorKind(f) != kFactorKind<Model, Between>) return;
    if (graph.firstVariable(f) == b && graph.secondVariable(f) == a) {
      found = f;
      *reversed = false;
    } else if (graph.firstVariable(f) == a && graph.secondVariable(f) == b) {
      found = f;
      *reversed = true;
    }
  });
  return found;
}

template <class Model>
typename CompactPoseGraph<Model>::Pose CompactPoseGraph<Model>::estimate(
    const PlaceT& place) const {
  return estimateAt(place.node).compose(place.offset);
}

template <class Model>
typename CompactPoseGraph<Model>::Pose CompactPoseGraph<Model>::estimateAt(Index node) const {
  return smoother_.template estimateAt<Pose>(node);
}

template <class Model>
void CompactPoseGraph<Model>::record(const UpdateResult& u, CompactStepResult& r) const {
  r.updates += 1;
  r.block_products += u.block_products;
  r.reordered = r.reordered || u.reordered;
}

template class CompactPoseGraph<PoseSlam2D>;
template class CompactPoseGraph<PoseSlam3D>;

}  // namespace lslam
