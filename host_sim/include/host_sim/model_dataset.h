#pragma once
// A dataset of any model (2D or 3D poses, with or without point landmarks) as read from a file, in
// file order, before any solver sees it. Host-only; independent of firmware_lib.
//
// Values are stored in each kind's natural parameters:
//   SE2    (x, y, theta)
//   Point2 (x, y)
//   SE3    (x, y, z, qx, qy, qz, qw), a unit quaternion (readers normalise nothing: a quaternion
//          whose norm is off by more than kQuaternionNormTolerance is an error at its line)
//   Point3 (x, y, z)
// Measurements use the same parameters as the values they predict: a relative pose for a between
// factor, a position in the robot frame for a point observation, (range, bearing) for
// RangeBearing2.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "host_sim/dataset.h"

namespace lslam::sim {

enum class VariableKind { SE2, Point2, SE3, Point3 };

// The tangent dimension of a kind (3, 2, 6, 3) and the number of stored parameters (3, 2, 7, 3).
int tangentDimension(VariableKind kind);
int parameterCount(VariableKind kind);
const char* variableKindName(VariableKind kind);  // "SE2", "Point2", "SE3", "Point3"

// Poses and landmarks are two id spaces: some files share one space between them (g2o,
// victoriaPark), others give landmarks their own (torus2000Points: POINT3 ids 0..19). A key names a
// variable in either case.
enum class VariableRole { Pose, Landmark };
struct VariableKey {
  VariableRole role = VariableRole::Pose;
  std::int64_t id = 0;
  bool operator==(const VariableKey& o) const { return role == o.role && id == o.id; }
  bool operator!=(const VariableKey& o) const { return !(*this == o); }
};
struct VariableKeyHash {
  std::size_t operator()(const VariableKey& k) const {
    return std::hash<std::int64_t>()(k.id * 2 + (k.role == VariableRole::Landmark ? 1 : 0));
  }
};

// The kind of a variable of `role` in a model of `dimension` (2 or 3): SE2/SE3 or Point2/Point3.
VariableKind kindOfRole(VariableRole role, int dimension);
// The role of a kind's variables (SE2/SE3: Pose; Point2/Point3: Landmark), its name ("pose",
// "landmark"), and the dimension of a kind's model (2 or 3).
VariableRole roleOf(VariableKind kind);
const char* roleName(VariableRole role);
int dimensionOf(VariableKind kind);

enum class FactorKind {
  PriorSE2,       // z: SE2; variables: {pose}
  BetweenSE2,     // z: SE2 of xj in xi's frame; {xi, xj}
  PriorPoint2,    // z: Point2; {landmark}
  PointXY2,       // z: Point2 position of the landmark in the pose's frame; {pose, landmark}
  RangeBearing2,  // z: (range, bearing) of the landmark from the pose; {pose, landmark}
  PriorSE3,       // z: SE3; {pose}
  BetweenSE3,     // z: SE3 of xj in xi's frame; {xi, xj}
  PriorPoint3,    // z: Point3; {landmark}
  PointXYZ3,      // z: Point3 position of the landmark in the pose's frame; {pose, landmark}
};
const char* factorKindName(FactorKind kind);
int errorDimension(FactorKind kind);  // 3, 3, 2, 2, 2, 6, 6, 3, 3
int arity(FactorKind kind);           // 1 or 2
// The kinds of the variables a factor connects, in its order (a prior, of arity 1: its one kind
// twice).
std::pair<VariableKind, VariableKind> endpointKinds(FactorKind kind);

struct ModelVertex {
  VariableKey key;
  VariableKind kind = VariableKind::SE2;
  Eigen::VectorXd value;  // parameterCount(kind) entries
  std::size_t line = 0;   // 1-based line in the file (0: not from a file)
};

struct ModelFactor {
  FactorKind kind = FactorKind::BetweenSE2;
  VariableKey first;            // the pose of a two-variable factor, or the prior's variable
  VariableKey second;           // unused for a prior
  Eigen::VectorXd measurement;  // in the parameters of the predicted value (see above)
  Eigen::MatrixXd information;  // errorDimension x errorDimension, always the information
  std::size_t line = 0;
};

// Which objective chi2 means for this dataset (see model_chi2.h):
//   G2o:  sum e^T Omega e with g2o's errors (3D: e = (t, qvec with qw >= 0) of Z^-1 Xi^-1 Xj);
//   Isam: iSAM's objective (2D: e = (x, y, theta) of Xi^-1 Xj minus z, angle wrapped; landmark e in
//         the robot frame; Omega = R^T R). See ../shared/datasets/MANIFEST.md section 3.
enum class ObjectiveConvention { G2o, Isam };

struct ModelDataset {
  std::string name;
  DatasetFormat format = DatasetFormat::G2o;
  ObjectiveConvention convention = ObjectiveConvention::G2o;
  int dimension = 2;                     // 2 or 3
  std::vector<ModelVertex> vertices;     // file order; empty for edge-only files (iSAM)
  std::vector<ModelFactor> factors;      // file order
  std::vector<VariableKey> fixed;        // FIX lines, file order
  std::vector<std::size_t> fixed_lines;  // the line of each `fixed` key (may be empty: not known)
};

// |q| may differ from 1 by this much in a file (printed with 6-9 digits) before it is an error.
inline constexpr double kQuaternionNormTolerance = 1e-5;

}  // namespace lslam::sim
