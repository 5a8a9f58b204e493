#include "host_sim/model_dataset_io.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <istream>
#include <optional>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "host_sim/dataset_io.h"
#include "lslam/geometry/coordinate_range.h"
#include "model_records.h"
#include "record_parsing.h"

namespace lslam::sim {

namespace {

using parsing::FieldParser;
using parsing::formatDouble;
using parsing::show;
using records::factorTag;
using records::isPositiveDefinite;
using records::rangeBearingProblem;
using records::vertexTag;

// Every record kind the reader knows. Edge2 is resolved to TORO or iSAM per file.
enum class Tag {
  VertexSE2,
  VertexXY,
  EdgeSE2,
  EdgeSE2XY,
  EdgeSE2RangeBearing,
  Fix,
  VertexSE3,
  VertexTrackXYZ,
  EdgeSE3,
  EdgeSE3TrackXYZ,
  ParamsSE3Offset,
  Vertex2,
  Edge2,
  Odometry,
  Landmark,
  Edge3,
  Point3,
  Other
};

Tag classify(std::string_view tag) {
  static const std::array<std::pair<std::string_view, Tag>, 17> kTags = {{
      {"VERTEX_SE2", Tag::VertexSE2},
      {"VERTEX_XY", Tag::VertexXY},
      {"EDGE_SE2", Tag::EdgeSE2},
      {"EDGE_SE2_XY", Tag::EdgeSE2XY},
      {"EDGE_SE2_RANGE_BEARING", Tag::EdgeSE2RangeBearing},
      {"FIX", Tag::Fix},
      {"VERTEX_SE3:QUAT", Tag::VertexSE3},
      {"VERTEX_TRACKXYZ", Tag::VertexTrackXYZ},
      {"EDGE_SE3:QUAT", Tag::EdgeSE3},
      {"EDGE_SE3_TRACKXYZ", Tag::EdgeSE3TrackXYZ},
      {"PARAMS_SE3OFFSET", Tag::ParamsSE3Offset},
      {"VERTEX2", Tag::Vertex2},
      {"EDGE2", Tag::Edge2},
      {"ODOMETRY", Tag::Odometry},
      {"LANDMARK", Tag::Landmark},
      {"EDGE3", Tag::Edge3},
      {"POINT3", Tag::Point3},
  }};
  for (const auto& [name, t] : kTags) {
    if (name == tag) return t;
  }
  return Tag::Other;
}

// 2 or 3; 0 for a record of either dimension (FIX).
int tagDimension(Tag tag) {
  switch (tag) {
    case Tag::VertexSE2:
    case Tag::VertexXY:
    case Tag::EdgeSE2:
    case Tag::EdgeSE2XY:
    case Tag::EdgeSE2RangeBearing:
    case Tag::Vertex2:
    case Tag::Edge2:
    case Tag::Odometry:
    case Tag::Landmark:
      return 2;
    case Tag::VertexSE3:
    case Tag::VertexTrackXYZ:
    case Tag::EdgeSE3:
    case Tag::EdgeSE3TrackXYZ:
    case Tag::ParamsSE3Offset:
    case Tag::Edge3:
    case Tag::Point3:
      return 3;
    case Tag::Fix:
    case Tag::Other:
      break;
  }
  return 0;
}

// The format of a record (Tag::Edge2 resolved with `edge2`).
DatasetFormat tagFormat(Tag tag, DatasetFormat edge2) {
  switch (tag) {
    case Tag::Vertex2:
      return DatasetFormat::Toro;
    case Tag::Edge2:
      return edge2;
    case Tag::Odometry:
    case Tag::Landmark:
    case Tag::Edge3:
    case Tag::Point3:
      return DatasetFormat::Isam;
    default:
      return DatasetFormat::G2o;
  }
}

std::string unsupportedReason(std::string_view tag) {
  return "unsupported record " + show(tag) +
         " (expected g2o VERTEX_SE2/VERTEX_XY/EDGE_SE2/EDGE_SE2_XY/EDGE_SE2_RANGE_BEARING/"
         "VERTEX_SE3:QUAT/VERTEX_TRACKXYZ/EDGE_SE3:QUAT/EDGE_SE3_TRACKXYZ/PARAMS_SE3OFFSET/FIX, "
         "TORO VERTEX2/EDGE2 or iSAM ODOMETRY/EDGE2/LANDMARK/EDGE3/POINT3)";
}

using Record = parsing::TaggedRecord<Tag>;

// ---- information matrices ----

// Field names "<prefix>ab" of an n x n upper triangle, row-major (a <= b, 1-based).
std::vector<std::string> triangleNames(char prefix, int n) {
  std::vector<std::string> names;
  for (int a = 1; a <= n; ++a) {
    for (int b = a; b <= n; ++b) {
      names.push_back(std::string(1, prefix) + std::to_string(a) + std::to_string(b));
    }
  }
  return names;
}

// Reads n(n+1)/2 numbers from field `first` on.
std::vector<double> readTriangle(const FieldParser& p, std::size_t first, int n, char prefix) {
  const std::vector<std::string> names = triangleNames(prefix, n);
  std::vector<double> values;
  for (std::size_t k = 0; k < names.size(); ++k)
    values.push_back(p.number(first + k, names[k].c_str()));
  return values;
}

// The symmetric matrix whose upper triangle (row-major) is `v`.
Eigen::MatrixXd symmetricFromUpper(const std::vector<double>& v, int n) {
  Eigen::MatrixXd m(n, n);
  std::size_t k = 0;
  for (int a = 0; a < n; ++a) {
    for (int b = a; b < n; ++b) {
      m(a, b) = v[k];
      m(b, a) = v[k];
      ++k;
    }
  }
  return m;
}

// The upper-triangular matrix whose upper triangle (row-major) is `v`.
Eigen::MatrixXd upperFromValues(const std::vector<double>& v, int n) {
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(n, n);
  std::size_t k = 0;
  for (int a = 0; a < n; ++a) {
    for (int b = a; b < n; ++b) r(a, b) = v[k++];
  }
  return r;
}

// R^T R for an upper-triangular R, each entry summed once and mirrored (exactly symmetric).
Eigen::MatrixXd gramOfUpper(const Eigen::MatrixXd& r) {
  const Eigen::Index n = r.rows();
  Eigen::MatrixXd m(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    for (Eigen::Index j = i; j < n; ++j) {
      double sum = 0.0;
      for (Eigen::Index k = 0; k <= i; ++k) sum += r(k, i) * r(k, j);  // R(k,i) = 0 for k > i
      m(i, j) = sum;
      m(j, i) = sum;
    }
  }
  return m;
}

std::string smallestEigenvalueText(const Eigen::MatrixXd& m) {
  if (!m.allFinite()) return "non-finite entries";
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(m, Eigen::EigenvaluesOnly);
  if (eig.info() != Eigen::Success) return "eigenvalues not computable";
  return "smallest eigenvalue " + formatDouble(eig.eigenvalues().minCoeff());
}

// g2o: the information as its upper triangle; must be positive definite.
Eigen::MatrixXd g2oInformation(const FieldParser& p, const Record& r, std::size_t first, int n) {
  const Eigen::MatrixXd m = symmetricFromUpper(readTriangle(p, first, n, 'I'), n);
  if (!isPositiveDefinite(m)) {
    p.fail(std::string(r.tokens[0]) + ": information matrix is not positive definite (" +
           smallestEigenvalueText(m) + ")");
  }
  return m;
}

// iSAM: the information R^T R of a square-root information R; must be positive definite.
// `diagonal` names the file fields of R's diagonal, for the message.
Eigen::MatrixXd isamInformation(const FieldParser& p, const Record& r, const Eigen::MatrixXd& sr,
                                const std::vector<std::string>& diagonal) {
  const Eigen::MatrixXd m = gramOfUpper(sr);
  if (!m.allFinite()) p.fail("information R^T R overflows (square-root information too large)");
  if (!isPositiveDefinite(m)) {
    // R^T R is singular exactly when R (triangular) has a zero on its diagonal; otherwise the
    // product under- or overflowed.
    std::string zeros;
    for (Eigen::Index k = 0; k < sr.rows(); ++k) {
      if (sr(k, k) != 0.0) continue;
      zeros += (zeros.empty() ? "" : ", ") + diagonal[static_cast<std::size_t>(k)] + " = 0";
    }
    p.fail(std::string(r.tokens[0]) +
           ": information matrix is not positive definite (information = R^T R; " +
           (zeros.empty() ? std::string("R^T R underflows or loses rank in rounding")
                          : "square-root information R is singular: " + zeros) +
           "; " + smallestEigenvalueText(m) + ")");
  }
  return m;
}

const std::vector<std::string> kDiagonalR2 = {"R11", "R22"};
const std::vector<std::string> kDiagonalR3 = {"R11", "R22", "R33"};
// EDGE3: S's diagonal in iSAM's order (x y z yaw pitch roll) is the file's S11 S22 S33 S66 S55 S44.
const std::vector<std::string> kDiagonalEdge3 = {"S11", "S22", "S33", "S66", "S55", "S44"};

// ---- rotations ----

void checkQuaternion(const FieldParser& p, const Record& r, double qx, double qy, double qz,
                     double qw) {
  const double norm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
  if (!(std::abs(norm - 1.0) <= kQuaternionNormTolerance)) {
    p.fail(std::string(r.tokens[0]) + ": quaternion norm " + formatDouble(norm) +
           " is not 1 (tolerance " + formatDouble(kQuaternionNormTolerance) + ")");
  }
}

// iSAM's Rot3d::euler_to_quat: R = Rz(yaw) Ry(pitch) Rx(roll), as (x, y, z, w).
std::array<double, 4> eulerToQuaternion(double yaw, double pitch, double roll) {
  const double sy = std::sin(yaw * 0.5);
  const double cy = std::cos(yaw * 0.5);
  const double sp = std::sin(pitch * 0.5);
  const double cp = std::cos(pitch * 0.5);
  const double sr = std::sin(roll * 0.5);
  const double cr = std::cos(roll * 0.5);
  return {sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
          cr * cp * cy + sr * sp * sy};
}

// ---- records ----

class Reader {
 public:
  Reader(const std::string& name, DatasetFormat format) : name_(name) {
    d_.name = name;
    d_.format = format;
    d_.convention =
        format == DatasetFormat::Isam ? ObjectiveConvention::Isam : ObjectiveConvention::G2o;
  }

  void setFormat(DatasetFormat format) {
    d_.format = format;
    d_.convention =
        format == DatasetFormat::Isam ? ObjectiveConvention::Isam : ObjectiveConvention::G2o;
  }

  void record(const Record& r) {
    const FieldParser p(name_, r.line, r.tokens);
    switch (r.tag) {
      case Tag::VertexSE2:
      case Tag::Vertex2:
        vertex(p, r, VariableKind::SE2, 5, {"x", "y", "theta"});
        break;
      case Tag::VertexXY:
        vertex(p, r, VariableKind::Point2, 4, {"x", "y"});
        break;
      case Tag::VertexSE3:
        vertex(p, r, VariableKind::SE3, 9, {"x", "y", "z", "qx", "qy", "qz", "qw"});
        break;
      case Tag::VertexTrackXYZ:
        vertex(p, r, VariableKind::Point3, 5, {"x", "y", "z"});
        break;
      case Tag::EdgeSE2:
      case Tag::Edge2:
      case Tag::Odometry:
        edgeSE2(p, r);
        break;
      case Tag::EdgeSE2XY:
      case Tag::EdgeSE2RangeBearing:
      case Tag::Landmark:
        observation2(p, r);
        break;
      case Tag::EdgeSE3:
        edgeSE3(p, r);
        break;
      case Tag::EdgeSE3TrackXYZ:
      case Tag::Point3:
        pointXYZ(p, r);
        break;
      case Tag::Edge3:
        edge3(p, r);
        break;
      case Tag::ParamsSE3Offset:
        params(p, r);
        break;
      case Tag::Fix: {
        if (r.tokens.size() < 2) p.fail("FIX: expected at least 2 fields, got 1 (no id)");
        for (std::size_t k = 1; k < r.tokens.size(); ++k) fix_.emplace_back(p.id(k, "id"), r.line);
        break;
      }
      case Tag::Other:
        break;
    }
  }

  ModelDataset finish(int dimension) {
    d_.dimension = dimension == 0 ? 2 : dimension;
    if (d_.format != DatasetFormat::Isam) checkKeys();
    return std::move(d_);
  }

 private:
  // VERTEX_SE2, VERTEX2, VERTEX_XY, VERTEX_SE3:QUAT, VERTEX_TRACKXYZ: id and values.
  void vertex(const FieldParser& p, const Record& r, VariableKind kind, std::size_t fields,
              std::initializer_list<const char*> names) {
    p.expectFields(fields);
    ModelVertex v;
    v.key = VariableKey{roleOf(kind), p.id(1, "id")};
    v.kind = kind;
    v.value.resize(static_cast<Eigen::Index>(names.size()));
    // Every kind's values begin with its position (x y, or x y z).
    const Eigen::Index positions = dimensionOf(kind);
    Eigen::Index k = 0;
    for (const char* field : names) {
      const auto i = static_cast<std::size_t>(2 + k);
      v.value[k] = k < positions ? p.coordinate(i, field) : p.number(i, field);
      ++k;
    }
    if (kind == VariableKind::SE3)
      checkQuaternion(p, r, v.value[3], v.value[4], v.value[5], v.value[6]);
    v.line = r.line;
    // g2o and TORO: one id space for all vertices.
    const auto [it, inserted] = vertex_index_.emplace(v.key.id, d_.vertices.size());
    if (!inserted) {
      const ModelVertex& first = d_.vertices[it->second];
      p.fail(std::string(r.tokens[0]) + ": duplicate vertex id " + std::to_string(v.key.id) +
             " (first defined at line " + std::to_string(first.line) + " by " +
             vertexTag(first.kind, d_.format) + ")");
    }
    d_.vertices.push_back(std::move(v));
  }

  void selfEdge(const FieldParser& p, const Record& r, std::int64_t i, std::int64_t j) const {
    if (i != j) return;
    p.fail(std::string(r.tokens[0]) + ": edge from pose " + std::to_string(i) +
           " to itself (from == to)");
  }

  void addFactor(FactorKind kind, VariableKey first, VariableKey second,
                 const std::vector<double>& z, Eigen::MatrixXd information, std::size_t line) {
    ModelFactor f;
    f.kind = kind;
    f.first = first;
    f.second = second;
    f.measurement =
        Eigen::Map<const Eigen::VectorXd>(z.data(), static_cast<Eigen::Index>(z.size()));
    f.information = std::move(information);
    f.line = line;
    d_.factors.push_back(std::move(f));
  }

  // EDGE_SE2 (g2o), EDGE2 (TORO or iSAM), ODOMETRY (iSAM).
  void edgeSE2(const FieldParser& p, const Record& r) {
    p.expectFields(12);
    const std::int64_t i = p.id(1, "from");
    const std::int64_t j = p.id(2, "to");
    const std::vector<double> z = {p.coordinate(3, "dx"), p.coordinate(4, "dy"),
                                   p.number(5, "dtheta")};
    Eigen::MatrixXd m;
    if (d_.format == DatasetFormat::Toro) {
      static const std::array<const char*, 6> kNames = {"inf_ff", "inf_fs", "inf_ss",
                                                        "inf_rr", "inf_fr", "inf_sr"};
      std::array<double, 6> a{};
      for (std::size_t k = 0; k < 6; ++k) a[k] = p.number(6 + k, kNames[k]);
      selfEdge(p, r, i, j);
      m.resize(3, 3);
      m << a[0], a[1], a[4],  // xx xy yy thth xth yth
          a[1], a[2], a[5],   //
          a[4], a[5], a[3];
      if (!isPositiveDefinite(m)) {
        p.fail(std::string(r.tokens[0]) + ": information matrix is not positive definite (" +
               smallestEigenvalueText(m) + ")");
      }
    } else if (d_.format == DatasetFormat::Isam) {
      const Eigen::MatrixXd sr = upperFromValues(readTriangle(p, 6, 3, 'R'), 3);
      selfEdge(p, r, i, j);
      m = isamInformation(p, r, sr, kDiagonalR3);
    } else {
      const std::vector<double> upper = readTriangle(p, 6, 3, 'I');
      selfEdge(p, r, i, j);
      m = symmetricFromUpper(upper, 3);
      if (!isPositiveDefinite(m)) {
        p.fail(std::string(r.tokens[0]) + ": information matrix is not positive definite (" +
               smallestEigenvalueText(m) + ")");
      }
    }
    addFactor(FactorKind::BetweenSE2, {VariableRole::Pose, i}, {VariableRole::Pose, j}, z,
              std::move(m), r.line);
  }

  // EDGE_SE2_XY (g2o), EDGE_SE2_RANGE_BEARING (lslam's g2o record), LANDMARK (iSAM).
  void observation2(const FieldParser& p, const Record& r) {
    p.expectFields(8);
    const bool range_bearing = r.tag == Tag::EdgeSE2RangeBearing;
    const std::int64_t pose = p.id(1, "pose");
    const std::int64_t lm = p.id(2, "landmark");
    const std::vector<double> z = {p.coordinate(3, range_bearing ? "range" : "dx"),
                                   range_bearing ? p.number(4, "bearing") : p.coordinate(4, "dy")};
    if (range_bearing) {
      if (const std::string why = rangeBearingProblem(z[0], z[1]); !why.empty())
        p.fail(std::string(r.tokens[0]) + ": " + why);
    }
    Eigen::MatrixXd m;
    if (d_.format == DatasetFormat::Isam) {
      m = isamInformation(p, r, upperFromValues(readTriangle(p, 5, 2, 'R'), 2), kDiagonalR2);
    } else {
      sharedIdSpace(p, r, pose, lm);
      m = g2oInformation(p, r, 5, 2);
    }
    addFactor(range_bearing ? FactorKind::RangeBearing2 : FactorKind::PointXY2,
              {VariableRole::Pose, pose}, {VariableRole::Landmark, lm}, z, std::move(m), r.line);
  }

  // g2o: a pose and a landmark cannot have the same id.
  void sharedIdSpace(const FieldParser& p, const Record& r, std::int64_t pose,
                     std::int64_t lm) const {
    if (pose != lm) return;
    p.fail(std::string(r.tokens[0]) + ": pose and landmark have the same id " +
           std::to_string(pose) + " (g2o ids are one space)");
  }

  // EDGE_SE3:QUAT (g2o).
  void edgeSE3(const FieldParser& p, const Record& r) {
    p.expectFields(31);
    const std::int64_t i = p.id(1, "from");
    const std::int64_t j = p.id(2, "to");
    static const std::array<const char*, 7> kNames = {"x", "y", "z", "qx", "qy", "qz", "qw"};
    std::vector<double> z;
    for (std::size_t k = 0; k < 7; ++k) {
      z.push_back(k < 3 ? p.coordinate(3 + k, kNames[k]) : p.number(3 + k, kNames[k]));
    }
    const std::vector<double> upper = readTriangle(p, 10, 6, 'I');
    selfEdge(p, r, i, j);
    checkQuaternion(p, r, z[3], z[4], z[5], z[6]);
    Eigen::MatrixXd m = symmetricFromUpper(upper, 6);
    if (!isPositiveDefinite(m)) {
      p.fail(std::string(r.tokens[0]) + ": information matrix is not positive definite (" +
             smallestEigenvalueText(m) + ")");
    }
    addFactor(FactorKind::BetweenSE3, {VariableRole::Pose, i}, {VariableRole::Pose, j}, z,
              std::move(m), r.line);
  }

  // EDGE_SE3_TRACKXYZ (g2o, with or without the offset parameter id), POINT3 (iSAM, with or
  // without the square-root information).
  void pointXYZ(const FieldParser& p, const Record& r) {
    const bool isam = r.tag == Tag::Point3;
    const std::size_t n = r.tokens.size();
    const std::size_t full = 12;              // tag pose pt x y z + 6
    const std::size_t other = isam ? 6 : 13;  // iSAM: no information; g2o: with param
    if (n != full && n != other) {
      const std::string tag(r.tokens[0]);
      const std::string expected = "expected " + std::to_string(full) + " fields (or " +
                                   std::to_string(other) +
                                   (isam ? " without square-root information"
                                         : " with a sensor "
                                           "offset id") +
                                   ")";
      if (n < std::max(full, other)) {
        p.fail(tag + ": " + expected + ", got " + std::to_string(n) + " (truncated line?)");
      }
      p.fail(tag + ": trailing garbage " + show(r.tokens[std::max(full, other)]) + " (" + expected +
             ", got " + std::to_string(n) + ")");
    }
    const std::int64_t pose = p.id(1, "pose");
    const std::int64_t pt = p.id(2, "point");
    std::size_t k = 3;
    if (!isam && n == 13) {
      const std::int64_t param = p.id(3, "param");
      if (params_.count(param) == 0) {
        p.fail(std::string(r.tokens[0]) + ": sensor offset parameter " + std::to_string(param) +
               " is not defined by a PARAMS_SE3OFFSET line above");
      }
      ++k;
    }
    const std::vector<double> z = {p.coordinate(k, "x"), p.coordinate(k + 1, "y"),
                                   p.coordinate(k + 2, "z")};
    Eigen::MatrixXd m;
    if (isam) {
      const Eigen::MatrixXd sr = n == full ? upperFromValues(readTriangle(p, k + 3, 3, 'R'), 3)
                                           : Eigen::MatrixXd(Eigen::MatrixXd::Identity(3, 3));
      m = isamInformation(p, r, sr, kDiagonalR3);
    } else {
      sharedIdSpace(p, r, pose, pt);
      m = g2oInformation(p, r, k + 3, 3);
    }
    addFactor(FactorKind::PointXYZ3, {VariableRole::Pose, pose}, {VariableRole::Landmark, pt}, z,
              std::move(m), r.line);
  }

  // EDGE3 (iSAM): see the header for the convention.
  void edge3(const FieldParser& p, const Record& r) {
    const std::size_t n = r.tokens.size();
    if (n != 30 && n != 9) {
      const std::string tag(r.tokens[0]);
      const std::string expected = "expected 30 fields (or 9 without square-root information)";
      if (n < 30)
        p.fail(tag + ": " + expected + ", got " + std::to_string(n) + " (truncated line?)");
      p.fail(tag + ": trailing garbage " + show(r.tokens[30]) + " (" + expected + ", got " +
             std::to_string(n) + ")");
    }
    const std::int64_t i = p.id(1, "from");
    const std::int64_t j = p.id(2, "to");
    const double x = p.coordinate(3, "x");
    const double y = p.coordinate(4, "y");
    const double z = p.coordinate(5, "z");
    const double roll = p.number(6, "roll");
    const double pitch = p.number(7, "pitch");
    const double yaw = p.number(8, "yaw");
    Eigen::MatrixXd s = Eigen::MatrixXd::Identity(6, 6);
    if (n == 30) {
      const Eigen::MatrixXd f = upperFromValues(readTriangle(p, 9, 6, 'S'), 6);  // file order
      s.topRows(3) = f.topRows(3);  // translation rows: as in the file (iSAM's loader)
      // Rotation block: file (roll, pitch, yaw) reversed to iSAM's (yaw, pitch, roll).
      s.bottomRightCorner(3, 3) << f(5, 5), f(4, 5), f(3, 5),  //
          0.0, f(4, 4), f(3, 4),                               //
          0.0, 0.0, f(3, 3);
    }
    selfEdge(p, r, i, j);
    if (!(std::abs(pitch) <= kHalfPi)) {
      p.fail(std::string(r.tokens[0]) + ": pitch " + formatDouble(pitch) +
             " is outside [-pi/2, pi/2] (the Euler angles iSAM compares would not be those of the "
             "rotation)");
    }
    const std::array<double, 4> q = eulerToQuaternion(yaw, pitch, roll);
    std::vector<double> meas = {x, y, z, q[0], q[1], q[2], q[3]};
    VariableKey first{VariableRole::Pose, i};
    VariableKey second{VariableRole::Pose, j};
    if (i > j) {
      // iSAM's loader adds the factor j -> i with the inverse measurement.
      const Eigen::Quaterniond rot(q[3], q[0], q[1], q[2]);
      const Eigen::Vector3d t = -(rot.conjugate() * Eigen::Vector3d(x, y, z));
      // Rotated, a translation keeps its length but not its coordinates' bound.
      if (checkCoordinates(t) != Status::Ok) {
        p.fail("EDGE3: the inverse measurement's translation " +
               parsing::beyondCoordinateRange("(" + formatDouble(t.x()) + ", " +
                                              formatDouble(t.y()) + ", " + formatDouble(t.z()) +
                                              ")"));
      }
      meas = {t.x(), t.y(), t.z(), -q[0], -q[1], -q[2], q[3]};
      std::swap(first, second);
    }
    addFactor(FactorKind::BetweenSE3, first, second, meas, isamInformation(p, r, s, kDiagonalEdge3),
              r.line);
  }

  // PARAMS_SE3OFFSET (g2o): only the identity offset.
  void params(const FieldParser& p, const Record& r) {
    p.expectFields(9);
    const std::int64_t id = p.id(1, "id");
    static const std::array<const char*, 7> kNames = {"x", "y", "z", "qx", "qy", "qz", "qw"};
    std::array<double, 7> v{};
    for (std::size_t k = 0; k < 7; ++k) v[k] = p.number(2 + k, kNames[k]);
    checkQuaternion(p, r, v[3], v[4], v[5], v[6]);
    if (v[0] != 0.0 || v[1] != 0.0 || v[2] != 0.0 || v[3] != 0.0 || v[4] != 0.0 || v[5] != 0.0) {
      p.fail("PARAMS_SE3OFFSET: only the identity sensor offset (0 0 0 0 0 0 1) is supported");
    }
    const auto [it, inserted] = params_.emplace(id, r.line);
    if (!inserted) {
      p.fail("PARAMS_SE3OFFSET: duplicate parameter id " + std::to_string(id) +
             " (first defined at line " + std::to_string(it->second) + ")");
    }
  }

  // g2o/TORO: the kinds of the ids each edge names (one id space), declarations, FIX roles.
  void checkKeys() {
    std::size_t bad_line = 0;
    std::string reason;
    const auto describe = [&](const ModelFactor& f) {
      return std::string(factorTag(f.kind, d_.format)) + " " + std::to_string(f.first.id) + " -> " +
             std::to_string(f.second.id);
    };
    // Edge-only files: the kind of each id's first use.
    std::unordered_map<std::int64_t, std::pair<VariableKind, std::size_t>> used;
    for (const ModelFactor& f : d_.factors) {
      const auto [kind1, kind2] = endpointKinds(f.kind);
      for (const auto& [key, kind] : {std::pair{f.first, kind1}, std::pair{f.second, kind2}}) {
        if (!reason.empty()) break;
        if (!d_.vertices.empty()) {
          const auto it = vertex_index_.find(key.id);
          if (it == vertex_index_.end()) {
            reason = describe(f) + " names " + roleName(key.role) + " " + std::to_string(key.id) +
                     ", which no " + vertexTag(kind, d_.format) + " line declares";
          } else if (d_.vertices[it->second].kind != kind) {
            const ModelVertex& v = d_.vertices[it->second];
            reason = describe(f) + " names " + roleName(key.role) + " " + std::to_string(key.id) +
                     ", but " + vertexTag(v.kind, d_.format) + " at line " +
                     std::to_string(v.line) + " declares id " + std::to_string(key.id) + " as a " +
                     roleName(roleOf(v.kind)) + " (g2o ids are one space)";
          }
        } else {
          const auto [it, inserted] = used.emplace(key.id, std::pair{kind, f.line});
          if (!inserted && it->second.first != kind) {
            reason = describe(f) + " uses id " + std::to_string(key.id) + " as a " +
                     roleName(key.role) + ", but line " + std::to_string(it->second.second) +
                     " uses it as a " + roleName(roleOf(it->second.first)) +
                     " (g2o ids are one space)";
          }
        }
        if (!reason.empty()) bad_line = f.line;
      }
      if (!reason.empty()) break;  // factors are in file order: the first is the earliest
    }
    for (const auto& [id, line] : fix_) {
      if (bad_line != 0 && line >= bad_line) break;
      if (d_.vertices.empty() || vertex_index_.count(id) != 0) continue;
      bad_line = line;
      reason = "FIX names id " + std::to_string(id) + ", which no vertex line declares";
      break;
    }
    if (!reason.empty()) throw DatasetError(name_, bad_line, reason);

    for (const auto& [id, line] : fix_) {
      VariableRole role = VariableRole::Pose;
      if (const auto v = vertex_index_.find(id); v != vertex_index_.end()) {
        role = d_.vertices[v->second].key.role;
      } else if (const auto u = used.find(id); u != used.end()) {
        role = roleOf(u->second.first);
      }
      d_.fixed.push_back(VariableKey{role, id});
      d_.fixed_lines.push_back(line);
    }
  }

  static constexpr double kHalfPi = 1.5707963267948966;

  const std::string& name_;
  ModelDataset d_;
  std::unordered_map<std::int64_t, std::size_t> vertex_index_;  // id -> index in d_.vertices
  std::unordered_map<std::int64_t, std::size_t> params_;        // PARAMS_SE3OFFSET id -> line
  std::vector<std::pair<std::int64_t, std::size_t>> fix_;       // FIX ids and lines, file order
};

ModelDataset parseImpl(std::istream& in, const std::string& name) {
  const auto file = parsing::scanFile<Tag>(in, name, classify);
  const DatasetFormat edge2 = file.edge2Format();

  Reader reader(name, file.has_graph_name ? DatasetFormat::Toro : DatasetFormat::G2o);
  std::optional<DatasetFormat> format;
  std::size_t format_line = 0;
  int dimension = 0;
  std::size_t dimension_line = 0;
  for (const Record& r : file.records) {
    if (r.tag == Tag::Other) throw DatasetError(name, r.line, unsupportedReason(r.tokens[0]));
    const DatasetFormat f = tagFormat(r.tag, edge2);
    if (!format) {
      format = f;
      format_line = r.line;
      reader.setFormat(f);
    } else if (f != *format) {
      throw DatasetError(name, r.line,
                         "record '" + std::string(r.tokens[0]) + "' is a " + formatName(f) +
                             " record, but the file is read as " + formatName(*format) +
                             " (first " + formatName(*format) + " record at line " +
                             std::to_string(format_line) + ")");
    }
    if (const int dim = tagDimension(r.tag); dim != 0) {
      if (dimension == 0) {
        dimension = dim;
        dimension_line = r.line;
      } else if (dim != dimension) {
        throw DatasetError(name, r.line,
                           "record '" + std::string(r.tokens[0]) + "' is a " + std::to_string(dim) +
                               "D record, but the file is " + std::to_string(dimension) +
                               "D (first " + std::to_string(dimension) + "D record at line " +
                               std::to_string(dimension_line) + ")");
      }
    }
    reader.record(r);
  }
  return reader.finish(dimension);
}

}  // namespace

ModelDataset readModelDataset(const std::string& path) {
  std::ifstream in = parsing::openDatasetFile(path);
  return parseImpl(in, path);
}

ModelDataset parseModelDataset(std::istream& in, const std::string& name) {
  return parseImpl(in, name);
}

}  // namespace lslam::sim
