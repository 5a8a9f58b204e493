#pragma once
// Scoring an estimate against ground truth: the absolute trajectory error (ATE) after the best
// rigid alignment of the estimate's pose positions onto the truth's, the orientation error in the
// same alignment, and the landmark position error in it; and ground truth read from a file.
// Host-only; independent of firmware_lib.
//
// Why an alignment: an estimate is only defined up to the gauge of the problem (lslam-sim puts it
// in the frame of the first pose's initial value, the truth files in their own), so positions are
// compared after the rigid motion (rotation without reflection, translation, no scale) that best
// fits the matched pose positions in least squares (Umeyama 1991; Horn 1987 for 3D).
//
// Values are in each kind's parameters (model_dataset.h): SE2 (x, y, theta), Point2 (x, y), SE3
// (x, y, z, qx, qy, qz, qw), Point3 (x, y, z); quaternions are normalised before use.
#include <Eigen/Core>
#include <cstddef>
#include <string>
#include <unordered_map>
#include <vector>

#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"

namespace lslam::sim {

// truth ~ rotation * estimate + translation: rotation is dim x dim (dim 2 or 3), det +1.
struct RigidAlignment {
  Eigen::MatrixXd rotation;
  Eigen::VectorXd translation;
};

// The rigid motion minimising sum |R estimate[i] + t - truth[i]|^2 over proper rotations R (the
// SVD of the cross-covariance, its last singular direction flipped when U V^T would reflect).
// Degenerate inputs give a proper rotation and no NaN: with all points equal (one point) the
// rotation is the identity and t the difference of the centroids; with the points on one line (two
// points) in 3D the rotation about that line is not determined by them and is the SVD's choice
// (positions still fit as well as possible; orientation errors then depend on that choice). In 2D
// two distinct points determine the rotation. Throws std::invalid_argument if the lists are empty,
// differ in length, or hold points of different sizes or of a size other than 2 or 3.
RigidAlignment alignRigid(const std::vector<Eigen::VectorXd>& estimate,
                          const std::vector<Eigen::VectorXd>& truth);

struct TrajectoryError {
  std::size_t poses = 0;               // poses present in both (those the alignment fits)
  std::size_t landmarks = 0;           // landmarks present in both
  double ate_position_rmse = 0.0;      // RMS of |R p_est + t - p_truth| over the poses, metres
  double ate_rotation_rmse_deg = 0.0;  // RMS of the angle of R_truth^T (R R_est), degrees
  double landmark_rmse = 0.0;          // as ate_position_rmse over the landmarks (0 when none)
  RigidAlignment alignment;            // from the poses' positions only: landmarks do not move it
};

// Matches the keys present in both `estimate` and `truth` and scores them as above. `kinds` holds
// the kind of every variable of the estimate (variableKinds of its dataset) and `dimension` its
// dimension (ModelDataset::dimension); truth keys absent from the estimate are ignored, estimate
// keys absent from the truth are not scored. Throws std::invalid_argument if `dimension` is not 2
// or 3; an estimate key has no kind, a kind of the other dimension or a value of the wrong size; a
// truth value's size is not that of its role in `dimension` (Pose: SE2 3 / SE3 7, Landmark: Point2
// 2 / Point3 3: e.g. 3D truth for a 2D estimate); a matched key's kind in the estimate is not the
// one the truth's value has; or no pose is in both.
TrajectoryError trajectoryError(
    const ModelEstimate& estimate, const ModelEstimate& truth, int dimension,
    const std::unordered_map<VariableKey, VariableKind, VariableKeyHash>& kinds);

// `truth` carried into the estimate's frame by the inverse of `alignment` (p -> R^T (p - t),
// orientations rotated by R^T): what a plot draws beside the estimate. Kinds by role and the
// alignment's dimension (Pose: SE2/SE3, Landmark: Point2/Point3).
ModelEstimate inEstimateFrame(const ModelEstimate& truth, const RigidAlignment& alignment);

// The ground truth a dataset gives: its vertices' values if it has vertices (e.g. a `*.truth.g2o`
// written by the simulator); else, for an edge-only file (the noise-free iSAM measurement files of
// ../shared/datasets/groundtruth/), its poses chained along the between factors in file order: the
// first factor's first pose at the identity, then each pose from the first factor linking it to a
// pose already known, Xj = Xi Z or Xi = Xj Z^-1 (Z = Xi^-1 Xj, ModelFactor::first = i, second = j;
// initialEstimate of model_chi2.h on the between factors alone). Landmarks of such a file are not
// given (observations are skipped). Throws std::invalid_argument if the dataset has neither
// vertices nor between factors, or if a between factor after the first links two poses that no
// earlier between factor reaches (the truth would fall into unrelated frames).
ModelEstimate groundTruthValues(const ModelDataset& d);

// groundTruthValues of readModelDataset(path) (DatasetError as that reader throws).
ModelEstimate readGroundTruth(const std::string& path);

}  // namespace lslam::sim
