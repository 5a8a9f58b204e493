#include "lslam/solver/compact_pose_graph.h"

#include <algorithm>

#include "lslam/geometry/coordinate_range.h"
#include "lslam/models/pose_slam_2d.h"
#include "lslam/models/pose_slam_3d.h"
#include "lslam/models/slam_2d.h"
#include "lslam/models/slam_3d.h"

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

// A place's covariance: finite, symmetric and positive semi-definite.
template <class Pose>
bool validCovariance(const Matrix<Pose>& m) {
  if (!m.allFinite() || !m.isApprox(m.transpose(), 1e-9)) return false;
  const Eigen::LDLT<Matrix<Pose>> ldlt(m);
  return ldlt.info() == Eigen::Success && ldlt.isPositive();
}

// A measurement's covariance whose every standard deviation lies within kMaxCoordinate (metres or
// radians; an information above about 1e-18). The places hold covariances, composed to first
// order: a weaker measurement would carry them towards overflow within a few steps.
template <int N>
bool withinVarianceRange(const Eigen::Matrix<double, N, N>& covariance) {
  constexpr double kMaxVariance = kMaxCoordinate * kMaxCoordinate;
  return covariance.allFinite() && (covariance.diagonal().array() <= kMaxVariance).all();
}

// A tangent covariance as a between measurement's information in its error coordinates (back
// from betweenTangentCovariance; betweenErrorPerTangent: e = S tau).
template <class Pose>
Matrix<Pose> errorInformation(const Matrix<Pose>& covariance) {
  const Matrix<Pose> s = betweenErrorPerTangent<Pose>();
  return positiveDefiniteInverse<Pose>(s * covariance * s);
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
                                      const Closure* closures, Index num_closures,
                                      const Observation* observations,
                                      Index num_observations) const {
  if (num_closures < 0 || (num_closures > 0 && closures == nullptr) || num_observations < 0 ||
      (num_observations > 0 && (observations == nullptr || !kLandmarks)) ||
      current_.node == kNoIndex) {
    return Status::InvalidArgument;  // (a smoother that start() did not begin included)
  }
  const auto checkBetween = [](const Pose& z, const Matrix& z_information) {
    const Status s = Between::validate(z, z_information);
    if (s != Status::Ok) return s;
    return withinVarianceRange(betweenTangentCovariance<Pose>(z_information))
               ? Status::Ok
               : Status::InvalidArgument;
  };
  Status s = checkBetween(odometry, information);
  for (Index i = 0; s == Status::Ok && i < num_closures; ++i) {
    const Closure& c = closures[i];
    s = checkBetween(c.measurement, c.information);
    if (s == Status::Ok) s = validateValue(c.seen.offset);
    // A place at a node (zero covariance) is the node itself.
    if (s == Status::Ok &&
        (!validCovariance<Pose>(c.seen.covariance) ||
         (c.seen.atNode() && !Pose().localCoordinates(c.seen.offset).isZero(0.0)))) {
      s = Status::InvalidArgument;
    }
    if (s == Status::Ok && (c.seen.node < 0 || c.seen.node >= smoother_.poses())) {
      s = Status::UnknownVariable;
    }
  }
  if constexpr (kLandmarks) {
    using Observed = typename Model::PointObservation;
    for (Index i = 0; s == Status::Ok && i < num_observations; ++i) {
      const Observation& o = observations[i];
      s = o.landmark < 0 ? Status::InvalidArgument : Observed::validate(o.position, o.information);
      if (s == Status::Ok &&
          !withinVarianceRange(positiveDefiniteInverse<Landmark>(o.information))) {
        s = Status::InvalidArgument;
      }
    }
  }
  return s;
}

template <class Model>
Status CompactPoseGraph<Model>::addStep(const Pose& odometry, const Matrix& information,
                                        const Closure* closures, Index num_closures,
                                        const Observation* observations, Index num_observations,
                                        CompactStepResult* result) {
  CompactStepResult local;
  CompactStepResult& r = result != nullptr ? *result : local;
  r = CompactStepResult{};
  r.status = check(odometry, information, closures, num_closures, observations, num_observations);
  if (r.status != Status::Ok) return r.status;

  // The next pose in the current node's frame.
  Matrix covariance;
  const Pose offset =
      composeWithCovariance<Pose>(current_.offset, current_.covariance, odometry,
                                  betweenTangentCovariance<Pose>(information), &covariance);
  const auto& graph = smoother_.graph();
  if (graph.freeVariablesOfKind(0) > 0 && roomForFactor<Between>()) {
    const Index node = smoother_.poses();
    const auto pose =
        ModelVariableInput<Model>::make(node, estimate(PlaceT{current_.node, offset, covariance}));
    // At a node the odometry goes in as it came (full smoothing, bit for bit).
    const Matrix info = current_.atNode() ? information : errorInformation<Pose>(covariance);
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
  for (Index i = 0; i < num_observations; ++i) observe(observations[i], r);
  return Status::Ok;
}

template <class Model>
Status CompactPoseGraph<Model>::addObservations(const Observation* observations,
                                                Index num_observations, CompactStepResult* result) {
  CompactStepResult local;
  CompactStepResult& r = result != nullptr ? *result : local;
  r = CompactStepResult{};
  // The odometry checked is a valid one: only the observations are the caller's.
  r.status = check(Pose(), Matrix::Identity(), nullptr, 0, observations, num_observations);
  if (r.status != Status::Ok) return r.status;
  for (Index i = 0; i < num_observations; ++i) observe(observations[i], r);
  return Status::Ok;
}

// The loop closure as a factor between nodes (see the header), then the relocalization.
template <class Model>
void CompactPoseGraph<Model>::closeLoop(const Closure& c, CompactStepResult& r) {
  const Index a = current_.node;
  const Index b = c.seen.node;
  // The current pose in b's frame, through the pose seen.
  const Matrix measured = betweenTangentCovariance<Pose>(c.information);
  Matrix seen_covariance;
  const Pose seen_offset = composeWithCovariance<Pose>(c.seen.offset, c.seen.covariance,
                                                       c.measurement, measured, &seen_covariance);
  if (a != b) {
    const bool exact = current_.atNode() && c.seen.atNode();
    Pose z = c.measurement;  // b -> a
    Matrix covariance = measured;
    if (!exact) {
      Matrix j_inverse;
      const Pose to_node = current_.offset.inverse(&j_inverse);
      z = composeWithCovariance<Pose>(seen_offset, seen_covariance, to_node,
                                      j_inverse * current_.covariance * j_inverse.transpose(),
                                      &covariance);
    }
    const Index ia = nodeIndex(a);
    const Index ib = nodeIndex(b);
    Index existing = factorOf<Between>(ib, ia);
    const bool reversed =
        existing == kNoIndex && (existing = factorOf<Between>(ia, ib)) != kNoIndex;
    if (reversed) {  // a -> b: the inverse measurement, its covariance carried through
      Matrix j;
      z = z.inverse(&j);
      covariance = j * covariance * j.transpose();
    }
    const Matrix info = exact && !reversed ? c.information : errorInformation<Pose>(covariance);
    const bool updated = addOrFold<Between>(ModelFactorInput<Model>::template make<Between>(
                                                reversed ? a : b, reversed ? b : a, z, info),
                                            existing, r);
    // The relocalization below reads the nodes' estimates: the solution of this factor first.
    if (updated && !smoother_.options().solve_after_update) smoother_.solve(false);
  }
  relocalize(b, seen_offset, seen_covariance, r);
}

// The current pose from a loop closure (in b's frame) fused with the current place (in a's): the
// information-weighted mean, as a filter does, in the frame of the older of the two nodes (the
// other's offset carried over through the nodes' estimates, solved after this closure's factor;
// a right-perturbation covariance is unchanged by that). Keeping places on the oldest nodes makes
// later loop closures join the same pairs again, which fold. What it trades: the fused place holds
// some of the closure's information, which the graph holds too, so a factor later derived from
// it counts that part twice (a switch to b instead, which counts nothing twice, folded a tenth as
// often on the grid worlds and ended with a 45 % larger trajectory error). At a node the current
// place is exact and stays.
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
  const Matrix seen_information = positiveDefiniteInverse<Pose>(seen_covariance);
  const Matrix current_information = positiveDefiniteInverse<Pose>(current_.covariance);
  const Pose carried = inFrameOf(a, current_.offset);
  const Pose from_seen = inFrameOf(b, seen);
  // The mean in the tangent at the closure's view (covariances are tangent ones here). A fusion
  // that double precision cannot resolve (one information swamping the other) leaves the place.
  const PoseCorrection<Pose> c =
      detail::weightedCorrection<Pose>(seen_information + current_information,
                                       current_information * from_seen.localCoordinates(carried));
  if (!c.valid) return;
  current_ = PlaceT{node, from_seen.retract(c.step), c.covariance};
  r.relocalized = true;
}

// A landmark observation as a factor from the current node (see the header); a landmark seen for
// the first time enters from it while the graph has room.
template <class Model>
void CompactPoseGraph<Model>::observe(const Observation& o, CompactStepResult& r) {
  if constexpr (kLandmarks) {
    using Observed = typename Model::PointObservation;
    const Index a = current_.node;
    PointVector z = o.position;  // in a's frame
    PointMatrix info = o.information;
    if (!current_.atNode()) {
      Eigen::Matrix<double, kPointDim, Pose::kDof> j_pose;
      PointMatrix j_point;
      z = current_.offset.transformFrom(o.position, &j_pose, &j_point);
      const PointMatrix covariance =
          j_pose * current_.covariance * j_pose.transpose() +
          j_point * positiveDefiniteInverse<Landmark>(o.information) * j_point.transpose();
      info = positiveDefiniteInverse<Landmark>(covariance);
    }
    const auto factor = ModelFactorInput<Model>::template make<Observed>(a, o.landmark, z, info);
    const Index l = smoother_.template indexOf<Landmark>(o.landmark);
    if (l != kNoIndex) {
      // From a node the observation maps. From a place past the capacity it is folded into the
      // node's factor of that landmark when the pair is joined already, then corrects the place.
      // The place may hold the map's own estimate from earlier corrections, which the fold
      // counts again, as relocalize's fusion does for loop closures. What it trades, on points3d:
      // 8 % above full smoothing's trajectory error, against 12 % when a mapped landmark only
      // corrected the place; pairs not yet joined taken from places too ended 22 % above, and
      // slower.
      if (current_.atNode()) {
        static_cast<void>(addOrFold<Observed>(factor, factorOf<Observed>(nodeIndex(a), l), r));
      } else {
        const Index existing = factorOf<Observed>(nodeIndex(a), l);
        if (existing != kNoIndex && addOrFold<Observed>(factor, existing, r) &&
            !smoother_.options().solve_after_update) {
          smoother_.solve(false);
        }
        r.localized += localizeOn(l, o) ? 1 : 0;
      }
      return;
    }
    const auto& graph = smoother_.graph();
    UpdateResult u;
    Status s = Status::CapacityExhausted;
    if (graph.freeVariablesOfKind(1) > 0 && makeRoomForNewPair<Observed>(r)) {
      const auto landmark = ModelVariableInput<Model>::make(
          o.landmark, Observed::initialize(estimate(current_), o.position));
      s = smoother_.update(&landmark, 1, &factor, 1, &u);
    }
    if (s == Status::Ok) {
      record(u, r);
      r.landmarks_added += 1;
    } else {
      r.dropped += 1;
    }
  }
}

// The current place corrected by a mapped landmark's observation, the landmark's estimate taken
// as exact (a Kalman update of the offset, right perturbation, in information form). Past the
// capacity it is what keeps a place between loop closures from drifting on odometry alone; like
// the fusion of relocalize, it counts the observation again in factors later derived from the
// place. At a node the place is exact and stays; so does a place the update cannot correct in
// double precision (PoseCorrection::valid). Returns whether the place was corrected.
template <class Model>
bool CompactPoseGraph<Model>::localizeOn(Index landmark, const Observation& o) {
  if constexpr (kLandmarks) {
    if (current_.atNode()) return false;
    const PoseCorrection<Pose> c = correctionByObservedPoint<typename Model::PointObservation>(
        estimate(current_), current_.covariance, smoother_.template estimateAt<Landmark>(landmark),
        o.position, o.information);
    if (!c.valid) return false;
    current_ = PlaceT{current_.node, current_.offset.retract(c.step), c.covariance};
    return true;
  } else {
    static_cast<void>(landmark);
    static_cast<void>(o);
    return false;
  }
}

template <class Model>
template <class F>
bool CompactPoseGraph<Model>::addOrFold(const ModelFactorInput<Model>& factor, Index existing,
                                        CompactStepResult& r) {
  UpdateResult u;
  Status s = Status::CapacityExhausted;
  if (existing != kNoIndex) {
    s = smoother_.addFolded(factor, existing, &u);
  } else if (makeRoomForNewPair<F>(r)) {
    s = smoother_.update(nullptr, 0, &factor, 1, &u);
  }
  if (s == Status::Ok) {
    record(u, r);
    (existing != kNoIndex ? r.folded : r.factors_added) += 1;
  } else {
    // The inputs were checked: only room, a factorization that failed and changed nothing, or a
    // composed measurement or value beyond kMaxCoordinate (a map about 1e9 m across) is left to
    // refuse it.
    r.dropped += 1;
  }
  return s == Status::Ok;
}

// Room for a factor of kind F that keeps one slot for a fold: Smoother::addFolded adds its
// measurement as a factor before merging it, so a full graph could fold no more.
template <class Model>
template <class F>
bool CompactPoseGraph<Model>::roomForFactor() const {
  const auto& graph = smoother_.graph();
  return graph.freeFactors() >= 2 &&
         graph.freeFactorValues() >= kFactorValues<F> + kFactorValues<Between>;
}

// A factor for a pair not yet joined while roomForFactor and the Cholesky factor fills at most
// kNewPairPoolShare of its block pool: past that, a reordering (which stages a whole second factor
// beside the live one) could no longer fit, and the attempt would fail only after its work.
template <class Model>
template <class F>
bool CompactPoseGraph<Model>::roomForNewPair() const {
  const auto& factor = smoother_.factor();
  return roomForFactor<F>() && static_cast<double>(factor.liveBlocks()) <=
                                   kNewPairPoolShare * static_cast<double>(factor.poolCapacity());
}

template <class Model>
template <class F>
bool CompactPoseGraph<Model>::makeRoomForNewPair(CompactStepResult& r) {
  if (roomForNewPair<F>()) return true;
  const Index since = std::max(smoother_.blocksAtLastOrder(), room_reorder_failed_at_);
  if (!roomForFactor<F>() || since == 0 ||
      static_cast<double>(smoother_.factorBlocks()) <
          kRoomReorderGrowth * static_cast<double>(since)) {
    return false;
  }
  UpdateResult u;
  if (smoother_.reorder(&u) != Status::Ok) {  // no change to the estimate, factor or graph
    room_reorder_failed_at_ = smoother_.factorBlocks();
    return false;
  }
  record(u, r);
  r.reordered_for_room = true;
  return roomForNewPair<F>();
}

template <class Model>
template <class F>
Index CompactPoseGraph<Model>::factorOf(Index first, Index second) const {
  const auto& graph = smoother_.graph();
  Index found = kNoIndex;
  graph.forEachFactor(first, [&](Index f) {
    if (found == kNoIndex && graph.factorKind(f) == kFactorKind<Model, F> &&
        graph.firstVariable(f) == first && graph.secondVariable(f) == second) {
      found = f;
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
  return smoother_.template estimateAt<Pose>(nodeIndex(node));
}

template <class Model>
Index CompactPoseGraph<Model>::nodeIndex(Index node) const {
  const Index v = smoother_.template indexOf<Pose>(node);
  LSLAM_ASSERT(v != kNoIndex);
  return v;
}

template <class Model>
void CompactPoseGraph<Model>::record(const UpdateResult& u, CompactStepResult& r) const {
  r.updates += 1;
  r.block_products += u.block_products;
  r.reordered = r.reordered || u.reordered;
}

template class CompactPoseGraph<PoseSlam2D>;
template class CompactPoseGraph<PoseSlam3D>;
template class CompactPoseGraph<Slam2D>;
template class CompactPoseGraph<Slam3D>;

}  // namespace lslam
