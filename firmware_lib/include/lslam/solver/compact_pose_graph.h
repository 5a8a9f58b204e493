#pragma once
// Mapping for as long as the robot runs in the memory of one Smoother: a graph that stops growing
// at the smoother's pose capacity and keeps learning from every later loop closure and landmark
// observation (firmware_lib/README.md, "Mapping past the capacity", says why and what it trades).
//
// The method (a reduced pose graph, after Johannsson et al., ICRA 2013, with Ila et al.'s "a
// link only when informative" in its cheapest form, a merge):
//  - Every pose of the trajectory is a Place: a node (a pose variable of the smoother) and the
//    pose's offset from it, with the offset's covariance (zero for a node).
//  - While the smoother has room, each step's pose is a node of its own, joined to the current
//    place by its odometry (composed with the current offset), and the graph is full smoothing.
//  - At capacity the trajectory rides on the nodes: odometry composes onto the current offset
//    (its covariance grows, first order), and a loop closure from a place seen earlier (node b,
//    offset T_b) to the current pose (node a, offset T_a) becomes a between factor b -> a of
//    measurement T_b z T_a^-1, whose covariance is the three parts' propagated to first order.
//    The current pose is then fused with the closure's view of it, on the older of a and b
//    (relocalize). A landmark seen for the first time enters from the current place (its
//    observation carried through the offset); an observation of a mapped landmark is folded into
//    the current node's factor of it, if the graph has one, and corrects the current place
//    (localizeOn).
//  - A derived factor on a pair the graph already joins is folded into that factor
//    (Smoother::addFolded): factors do not grow with time either. A pair not yet joined takes a
//    factor while the smoother has one to spare (one is kept for folds) and the live Cholesky
//    factor fills at most kNewPairPoolShare of the block pool. At that share, a factor that has
//    grown by kRoomReorderGrowth since its last ordering is reordered first (the incremental
//    order fills more and more, and once every pair is refused only folds reach the factor, which
//    add no fill, so the growth rule never fires); past that the measurement is dropped (counted
//    in the step's result) and only localizes.
//
// Every step's inputs are checked before anything changes; a rejected step changes nothing. Node
// ids are 0, 1, 2, ... in the order they were added (the smoother's pose ids).
#include "lslam/eigen.h"
#include "lslam/factors/merged_measurement.h"
#include "lslam/solver/smoother.h"
#include "lslam/status.h"

namespace lslam {

template <class Pose>
struct Place {
  using Covariance = Eigen::Matrix<double, Pose::kDof, Pose::kDof>;
  Index node = kNoIndex;                       // its graph index, which is also its pose id
  Pose offset;                                 // the pose in the node's frame
  Covariance covariance = Covariance::Zero();  // the offset's (right perturbation); 0 at a node
  bool atNode() const { return covariance.isZero(0.0); }
};

// A pose's correction by an observation z (of kind Observed, with its information) of a point
// whose estimate is taken as exact: a Kalman update in information form, right perturbation. The
// step is for pose.retract, or for the offset of a place at that pose (the same perturbation);
// the covariance replaces the pose's, which must be positive definite. Not `valid` when the
// update is numerically singular (an information so strong that J^T Omega J overflows, or swamps
// the pose's own past double precision, some 15 orders): the pose is then to stay as it was (the
// step and covariance are zero, not a correction).
template <class Pose>
struct PoseCorrection {
  Eigen::Matrix<double, Pose::kDof, 1> step = Eigen::Matrix<double, Pose::kDof, 1>::Zero();
  Eigen::Matrix<double, Pose::kDof, Pose::kDof> covariance =
      Eigen::Matrix<double, Pose::kDof, Pose::kDof>::Zero();
  bool valid = false;
};

namespace detail {
// The correction of an information-weighted mean in one tangent: step = total^-1 g and its
// covariance total^-1, valid when total is finite and positive definite in double precision and
// both results are finite (LLT passes a NaN pivot, so finiteness is tested apart).
template <class Pose>
PoseCorrection<Pose> weightedCorrection(const Eigen::Matrix<double, Pose::kDof, Pose::kDof>& total,
                                        const Eigen::Matrix<double, Pose::kDof, 1>& g) {
  using Matrix = Eigen::Matrix<double, Pose::kDof, Pose::kDof>;
  PoseCorrection<Pose> c;
  const Eigen::LLT<Matrix> llt(total);
  if (!total.allFinite() || llt.info() != Eigen::Success) return c;
  c.step = llt.solve(g);
  c.covariance = positiveDefiniteInverse<Pose>(llt);  // the factorization above, not a second
  c.valid = c.step.allFinite() && c.covariance.allFinite() &&
            Eigen::LLT<Matrix>(c.covariance).info() == Eigen::Success;
  return c;
}
}  // namespace detail

template <class Observed, class Pose, class Point>
PoseCorrection<Pose> correctionByObservedPoint(
    const Pose& pose, const Eigen::Matrix<double, Pose::kDof, Pose::kDof>& covariance,
    const Point& point, const Eigen::Matrix<double, Observed::kErrorDim, 1>& z,
    const Eigen::Matrix<double, Observed::kErrorDim, Observed::kErrorDim>& information) {
  using Matrix = Eigen::Matrix<double, Pose::kDof, Pose::kDof>;
  Eigen::Matrix<double, Observed::kErrorDim, Pose::kDof> j;
  const Eigen::Matrix<double, Observed::kErrorDim, 1> e =
      Observed::error(pose, point, z, &j, nullptr);
  const Matrix total = positiveDefiniteInverse<Pose>(covariance) + j.transpose() * information * j;
  return detail::weightedCorrection<Pose>(total, -(j.transpose() * (information * e)));
}

// A loop closure of a step: the pose seen (a place the caller kept from an earlier step) and
// the measured pose of the current one in its frame, with its information.
template <class Pose>
struct PlaceClosure {
  Place<Pose> seen;
  Pose measurement;
  Eigen::Matrix<double, Pose::kDof, Pose::kDof> information;
};

// What a step did.
struct CompactStepResult {
  Status status = Status::Ok;
  bool node_added = false;          // the step's pose became a node
  bool relocalized = false;         // the current place moved to a loop closure's node
  Index factors_added = 0;          // loop closures and observations on a pair not yet joined
  Index folded = 0;                 // ... merged into a factor already there
  Index dropped = 0;                // ... that found no room (factors, landmarks or block pool)
  bool reordered_for_room = false;  // the factor was reordered to make room for a pair
  Index landmarks_added = 0;        // landmarks seen for the first time
  Index localized = 0;              // observations of mapped landmarks that corrected the place
  Index updates = 0;                // smoother updates the step made
  std::int64_t block_products = 0;
  bool reordered = false;
};

template <class Model>
class CompactPoseGraph {
 public:
  using Pose = TypeAtT<0, typename Model::Variables>;
  using Between = typename Model::PoseBetween;
  using Matrix = Eigen::Matrix<double, Pose::kDof, Pose::kDof>;
  using PlaceT = Place<Pose>;
  using Closure = PlaceClosure<Pose>;
  static constexpr bool kLandmarks = Model::Variables::kSize > 1;
  // A pose-only model's "landmark" is its pose kind, never used.
  using Landmark = TypeAtT<Model::Variables::kSize - 1, typename Model::Variables>;
  static constexpr int kPointDim = kLandmarks ? Landmark::kDof : 1;
  using PointVector = Eigen::Matrix<double, kPointDim, 1>;
  using PointMatrix = Eigen::Matrix<double, kPointDim, kPointDim>;
  // A landmark observation of a step: the landmark's id and its position measured in the current
  // pose's frame (Model::PointObservation), with its information.
  struct Observation {
    VariableId landmark = -1;
    PointVector position = PointVector::Zero();
    PointMatrix information = PointMatrix::Identity();
  };
  // New pairs stop once the live factor holds this share of the block pool (roomForNewPair): a
  // reordering stages a copy beside it, and the fill of later folds needs the rest.
  static constexpr double kNewPairPoolShare = 0.4;
  // A factor at that share is reordered for room once it has grown this much since its last
  // ordering (or since a reordering for room that failed): lower reorders more often for less
  // room gained each time.
  static constexpr double kRoomReorderGrowth = 1.2;

  explicit CompactPoseGraph(Smoother<Model>& smoother) : smoother_(smoother) {}

  // The first pose, node 0 (the smoother must be empty).
  [[nodiscard]] Status start(const Pose& first, UpdateResult* result = nullptr);
  // One step: the odometry from the current pose to the next one, then its loop closures, then
  // its landmark observations (a model with landmarks; a landmark enters at its first
  // observation, from the current place). NonFiniteInput / InformationNotPositiveDefinite for a
  // bad measurement, UnknownVariable for a place whose node is not in the graph, InvalidArgument
  // for a translation beyond kMaxCoordinate, a measurement whose covariance has a standard
  // deviation beyond it (an information below about 1e-18, which would carry the places'
  // covariances towards overflow), a place covariance that is not finite and symmetric, a
  // negative count or landmark id, or observations in a pose-only model (nothing changed).
  [[nodiscard]] Status addStep(const Pose& odometry, const Matrix& information,
                               const Closure* closures, Index num_closures,
                               const Observation* observations, Index num_observations,
                               CompactStepResult* result = nullptr);
  [[nodiscard]] Status addStep(const Pose& odometry, const Matrix& information,
                               const Closure* closures, Index num_closures,
                               CompactStepResult* result = nullptr) {
    return addStep(odometry, information, closures, num_closures, nullptr, 0, result);
  }

  // Landmark observations from the current pose outside a step (the first pose's): checked as
  // addStep checks them, then added as a step adds them.
  [[nodiscard]] Status addObservations(const Observation* observations, Index num_observations,
                                       CompactStepResult* result = nullptr);

  // The current pose's place (the caller keeps it to name this pose in later loop closures).
  const PlaceT& current() const { return current_; }
  // The estimate of a place: its node's estimate composed with the offset.
  Pose estimate(const PlaceT& place) const;
  Index nodes() const { return smoother_.poses(); }
  const Smoother<Model>& smoother() const { return smoother_; }

 private:
  Status check(const Pose& odometry, const Matrix& information, const Closure* closures,
               Index num_closures, const Observation* observations, Index num_observations) const;
  // The factor of kind F from `first` to `second` (that order), or kNoIndex.
  template <class F>
  Index factorOf(Index first, Index second) const;
  template <class F>
  bool roomForFactor() const;
  template <class F>
  bool roomForNewPair() const;
  // roomForNewPair, after a reordering for room if the factor grew enough since its last order.
  template <class F>
  bool makeRoomForNewPair(CompactStepResult& r);
  // The graph index of node `node` (its pose id).
  Index nodeIndex(Index node) const;
  void closeLoop(const Closure& closure, CompactStepResult& r);
  void observe(const Observation& observation, CompactStepResult& r);
  bool localizeOn(Index landmark, const Observation& observation);
  // Adds `factor` on a pair not yet joined, or folds it into `existing` (kNoIndex: none); counts
  // the outcome and returns whether the smoother took it.
  template <class F>
  bool addOrFold(const ModelFactorInput<Model>& factor, Index existing, CompactStepResult& r);
  void relocalize(Index b, const Pose& seen, const Matrix& seen_covariance, CompactStepResult& r);
  Pose estimateAt(Index node) const;
  void record(const UpdateResult& u, CompactStepResult& r) const;

  Smoother<Model>& smoother_;
  PlaceT current_;
  Index room_reorder_failed_at_ = 0;  // the live blocks at the last failed reordering for room
};

}  // namespace lslam
