#pragma once
// The objective of every model (SE2/SE3 poses, Point2/Point3 landmarks, every FactorKind of
// model_dataset.h) in both conventions, and the initial estimate of a dataset. Host-only and
// independent of firmware_lib: it includes no lslam/ header and has its own small geometry (Eigen
// rotation matrices and quaternions).
//
// Values and measurements are in each kind's parameters (model_dataset.h): SE2 (x, y, theta),
// Point2 (x, y), SE3 (x, y, z, qx, qy, qz, qw), Point3 (x, y, z). Below, X = (R, t) is a pose as a
// rigid transform (a point p in its frame is R p + t in the world); angles are wrapped to
// (-pi, pi] (wrapAngle of chi2.h).
//
// ERRORS, convention G2o (g2o's edge types):
//   BetweenSE2     e = (x, y, theta) of Z^-1 Xi^-1 Xj                 (EdgeSE2)
//   PriorSE2       e = (x, y, theta) of Z^-1 X                        (EdgeSE2Prior)
//   BetweenSE3     e = (t, qvec) of Z^-1 Xi^-1 Xj, the quaternion taken with qw >= 0 (EdgeSE3)
//   PriorSE3       e = (t, qvec) of Z^-1 X, qw >= 0                   (EdgeSE3Prior)
//   PointXY2       e = R^T (l - t) - z                                (EdgeSE2PointXY)
//   PointXYZ3      e = R^T (l - t) - z                                (EdgeSE3PointXYZ)
//   RangeBearing2  e = (|d| - r, wrap(atan2(d_y, d_x) - b)), d = R^T (l - t)
//   PriorPoint2/3  e = l - z
// ERRORS, convention Isam (iSAM 1.x factors; see model_dataset_io.h for the file records):
//   BetweenSE2     e = (x, y, theta) of Xi^-1 Xj minus z, angle wrapped  (Pose2d_Pose2d_Factor)
//   PriorSE2       e = X - z, angle wrapped                              (Pose2d_Factor)
//   BetweenSE3     e = v(Xi^-1 Xj) - v(Z), v = (x, y, z, yaw, pitch, roll), the three angles
//                  wrapped (Pose3d_Pose3d_Factor; yaw/pitch/roll of isamYawPitchRoll below)
//   PriorSE3       e = v(X) - v(Z), angles wrapped                       (Pose3d_Factor)
//   PointXY2, PointXYZ3, RangeBearing2, point priors: as in G2o (iSAM's Pose2d_Point2d_Factor and
//                  Pose3d_Point3d_Factor are e = R^T (l - t) - z; iSAM files have no range-bearing
//                  records or priors, the G2o forms are used for them).
// chi2 = sum over the factors of e^T Omega e, Omega = ModelFactor::information exactly as stored.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <unordered_map>

#include "host_sim/chi2.h"
#include "host_sim/model_dataset.h"

namespace lslam::sim {

// A value for every variable, in its kind's parameters.
using ModelEstimate = std::unordered_map<VariableKey, Eigen::VectorXd, VariableKeyHash>;

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Vector7d = Eigen::Matrix<double, 7, 1>;

// Per-factor errors, G2o convention (the formulas above).
Eigen::Vector3d errorBetweenSE2G2o(const Eigen::Vector3d& xi, const Eigen::Vector3d& xj,
                                   const Eigen::Vector3d& z);
Eigen::Vector3d errorPriorSE2G2o(const Eigen::Vector3d& x, const Eigen::Vector3d& z);
Vector6d errorBetweenSE3G2o(const Vector7d& xi, const Vector7d& xj, const Vector7d& z);
Vector6d errorPriorSE3G2o(const Vector7d& x, const Vector7d& z);
// Per-factor errors, Isam convention.
Eigen::Vector3d errorBetweenSE2Isam(const Eigen::Vector3d& xi, const Eigen::Vector3d& xj,
                                    const Eigen::Vector3d& z);
Eigen::Vector3d errorPriorSE2Isam(const Eigen::Vector3d& x, const Eigen::Vector3d& z);
Vector6d errorBetweenSE3Isam(const Vector7d& xi, const Vector7d& xj, const Vector7d& z);
Vector6d errorPriorSE3Isam(const Vector7d& x, const Vector7d& z);
// Landmark errors (both conventions).
Eigen::Vector2d errorPointXY2(const Eigen::Vector3d& x, const Eigen::Vector2d& l,
                              const Eigen::Vector2d& z);
Eigen::Vector2d errorRangeBearing2(const Eigen::Vector3d& x, const Eigen::Vector2d& l,
                                   const Eigen::Vector2d& z);
Eigen::Vector3d errorPointXYZ3(const Vector7d& x, const Eigen::Vector3d& l,
                               const Eigen::Vector3d& z);

// iSAM's Rot3d::quat_to_euler: (yaw, pitch, roll) with R = Rz(yaw) Ry(pitch) Rx(roll),
//   yaw = atan2(2 (w z + x y), w^2 + x^2 - y^2 - z^2), pitch = asin(2 (w y - z x)) (argument
//   clamped to [-1, 1]), roll = atan2(2 (w x + y z), w^2 - x^2 - y^2 + z^2).
Eigen::Vector3d isamYawPitchRoll(const Eigen::Quaterniond& q);

// The error of `f` under `convention`, given the values of its variables (`second` is ignored for
// a prior). Throws std::invalid_argument if a value or the measurement has the wrong size.
Eigen::VectorXd factorError(ObjectiveConvention convention, const ModelFactor& f,
                            const Eigen::VectorXd& first, const Eigen::VectorXd& second);
// The same, looking the values up in `values`; throws std::invalid_argument naming the factor's
// line if a variable has no value.
Eigen::VectorXd factorError(ObjectiveConvention convention, const ModelFactor& f,
                            const ModelEstimate& values);

// Whether component k of the error of `kind` under `convention` is an angle (wrapped): used to
// difference errors.
bool isAngularErrorComponent(ObjectiveConvention convention, FactorKind kind, int k);

// chi2 = sum e^T Omega e over d.factors, in d.convention. Throws std::invalid_argument if a
// variable has no value or a value has the wrong size.
double chi2(const ModelDataset& d, const ModelEstimate& values);

// The kind of a factor's variable: slot 0 = ModelFactor::first, 1 = second (two-variable factors
// only); and the size of its measurement (the parameters of the value it predicts).
VariableKind factorVariableKind(FactorKind kind, int slot);
int measurementSize(FactorKind kind);

// The kind of every variable the dataset names (vertices and factors). Throws
// std::invalid_argument if one key is used as two kinds.
std::unordered_map<VariableKey, VariableKind, VariableKeyHash> variableKinds(const ModelDataset& d);

// The initial estimate: the vertices (a later vertex with the same key wins); then every variable
// without a value is initialised when first seen, in file order of the factors, from the first
// factor that reaches it (the online initial values):
//   - a prior: the variable = z;
//   - a between factor with one pose known: Xj = Xi Z, or Xi = Xj Z^-1 (composition of rigid
//     transforms, both conventions: z is Xi^-1 Xj in both);
//   - an observation with the pose known: l = R z + t (PointXY2, PointXYZ3), or
//     l = t + R (r cos b, r sin b) (RangeBearing2);
//   - a factor none of whose variables is known (the first factor of the file, or of a new
//     connected component): its first variable at the origin (identity pose), then as above;
//   - an observation whose landmark is known but not its pose: the pose with identity rotation and
//     t = l - z (PointXY2, PointXYZ3; RangeBearing2: l - (r cos b, r sin b)).
ModelEstimate initialEstimate(const ModelDataset& d);

// The error of a factor of `kind` from raw parameter arrays, for the solver's inner loop (no
// checks): `first`, `second` (unused for a prior) and `z` hold parameterCount values of their
// kinds; errorDimension(kind) values are written to `e`.
void factorErrorRaw(ObjectiveConvention convention, FactorKind kind, const double* first,
                    const double* second, const double* z, double* e);

}  // namespace lslam::sim
