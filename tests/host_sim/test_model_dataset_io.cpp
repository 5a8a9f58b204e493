// Tests of the model-dataset readers and g2o writer (host_sim/model_dataset_io.h): every record
// kind parsed from strings against values computed here (iSAM R^T R with Eigen products, EDGE3's
// Euler angles with Eigen's AngleAxis, independently of the reader); every error with its line;
// write -> read bit-exact for 2D, 3D and landmark datasets; the writer's rejections; the real
// files' counts; and the EDGE3 convention checked against groundtruth/sphere2500_groundtruth.txt
// (its loop closures must agree with its composed odometry). lslam's EDGE_SE2_RANGE_BEARING: read,
// errors, write -> read, and a small file run incrementally against the batch solver.
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "dataset_files.h"
#include "host_sim/dataset_io.h"
#include "host_sim/model_batch_solver.h"
#include "host_sim/model_chi2.h"
#include "host_sim/model_dataset.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/model_run.h"
#include "lslam/geometry/coordinate_range.h"

using lslam::sim::DatasetError;
using lslam::sim::DatasetFormat;
using lslam::sim::FactorKind;
using lslam::sim::ModelDataset;
using lslam::sim::ModelFactor;
using lslam::sim::ModelVertex;
using lslam::sim::ObjectiveConvention;
using lslam::sim::parseModelDataset;
using lslam::sim::VariableKey;
using lslam::sim::VariableKind;
using lslam::sim::VariableRole;
using lslam::sim::writeModelG2o;
using lslam::sim::test::datasetPath;
using lslam::sim::test::present;

namespace {

using Lines = std::vector<std::string>;

std::string join(const Lines& lines) {
  std::string text;
  for (const std::string& l : lines) text += l + "\n";
  return text;
}

ModelDataset parse(const std::string& text, const std::string& name = "t.g2o") {
  std::istringstream in(text);
  return parseModelDataset(in, name);
}

ModelDataset parse(const Lines& lines, const std::string& name = "t.g2o") {
  return parse(join(lines), name);
}

// Parsing must throw DatasetError at `line` with a reason containing every fragment.
void expectError(const Lines& lines, const std::string& name, std::size_t line,
                 const std::vector<std::string>& fragments) {
  const std::string text = join(lines);
  std::optional<DatasetError> error;
  try {
    parse(text, name);
  } catch (const DatasetError& e) {
    error = e;
  }
  REQUIRE_MESSAGE(error.has_value(), "no DatasetError for:\n" << text);
  INFO("text:\n" << text << "reason: " << error->reason());
  CHECK(error->file() == name);
  CHECK(error->line() == line);
  CHECK(std::string(error->what()) == name + ":" + std::to_string(line) + ": " + error->reason());
  for (const std::string& f : fragments) {
    CHECK_MESSAGE(error->reason().find(f) != std::string::npos, "missing '" << f << "'");
  }
}

VariableKey pose(std::int64_t id) {
  return VariableKey{VariableRole::Pose, id};
}
VariableKey landmark(std::int64_t id) {
  return VariableKey{VariableRole::Landmark, id};
}

Eigen::VectorXd vec(std::initializer_list<double> values) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(values.size()));
  Eigen::Index k = 0;
  for (double x : values) v[k++] = x;
  return v;
}

// "a b c ..." of the n x n upper triangle of m, row-major, with full precision.
std::string upperText(const Eigen::MatrixXd& m) {
  std::ostringstream s;
  s.precision(17);
  for (Eigen::Index a = 0; a < m.rows(); ++a) {
    for (Eigen::Index b = a; b < m.cols(); ++b) s << (a + b == 0 ? "" : " ") << m(a, b);
  }
  return s.str();
}

// The rotation of iSAM's Euler angles built independently: yaw about Z, pitch about the new Y,
// roll about the new X.
Eigen::Matrix3d zyx(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Isometry3d isometry(const Eigen::VectorXd& se3) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::Quaterniond(se3[6], se3[3], se3[4], se3[5]).toRotationMatrix();
  t.translation() = se3.head<3>();
  return t;
}

bool sameKey(const VariableKey& a, const VariableKey& b) {
  return a == b;
}

// Bit-exact equality of two datasets' contents (not name, format or convention).
void expectSameContents(const ModelDataset& a, const ModelDataset& b) {
  CHECK(a.dimension == b.dimension);
  REQUIRE(a.vertices.size() == b.vertices.size());
  for (std::size_t k = 0; k < a.vertices.size(); ++k) {
    INFO("vertex #" << k);
    CHECK(sameKey(a.vertices[k].key, b.vertices[k].key));
    CHECK(a.vertices[k].kind == b.vertices[k].kind);
    REQUIRE(a.vertices[k].value.size() == b.vertices[k].value.size());
    CHECK(a.vertices[k].value == b.vertices[k].value);
  }
  REQUIRE(a.factors.size() == b.factors.size());
  for (std::size_t k = 0; k < a.factors.size(); ++k) {
    INFO("factor #" << k);
    CHECK(a.factors[k].kind == b.factors[k].kind);
    CHECK(sameKey(a.factors[k].first, b.factors[k].first));
    CHECK(sameKey(a.factors[k].second, b.factors[k].second));
    REQUIRE(a.factors[k].measurement.size() == b.factors[k].measurement.size());
    CHECK(a.factors[k].measurement == b.factors[k].measurement);
    REQUIRE(a.factors[k].information.rows() == b.factors[k].information.rows());
    CHECK(a.factors[k].information == b.factors[k].information);
  }
  REQUIRE(a.fixed.size() == b.fixed.size());
  for (std::size_t k = 0; k < a.fixed.size(); ++k) CHECK(sameKey(a.fixed[k], b.fixed[k]));
}

ModelDataset roundTrip(const ModelDataset& d) {
  std::ostringstream out;
  writeModelG2o(out, d);
  return parse(out.str(), "written.g2o");
}

std::size_t countKind(const ModelDataset& d, FactorKind kind) {
  std::size_t n = 0;
  for (const ModelFactor& f : d.factors) n += f.kind == kind ? 1 : 0;
  return n;
}

std::size_t distinctLandmarks(const ModelDataset& d) {
  std::set<std::int64_t> ids;
  for (const ModelFactor& f : d.factors) {
    if (f.second.role == VariableRole::Landmark) ids.insert(f.second.id);
  }
  return ids.size();
}

}  // namespace

// ---- records ----

TEST_CASE("g2o 2D: VERTEX_SE2, VERTEX_XY, EDGE_SE2, EDGE_SE2_XY, FIX") {
  const ModelDataset d = parse({
      "VERTEX_SE2 0 1 2 0.5",
      "VERTEX_XY 7 3.5 -4",
      "VERTEX_SE2 1 2 2 -0.25",
      "EDGE_SE2 0 1 1 0 -0.75 11 12 13 22 23 33",
      "EDGE_SE2_XY 1 7 1.5 -6 4 0.5 9",
      "FIX 0 7",
  });
  CHECK(d.name == "t.g2o");
  CHECK(d.format == DatasetFormat::G2o);
  CHECK(d.convention == ObjectiveConvention::G2o);
  CHECK(d.dimension == 2);
  REQUIRE(d.vertices.size() == 3);
  CHECK(sameKey(d.vertices[0].key, pose(0)));
  CHECK(d.vertices[0].kind == VariableKind::SE2);
  CHECK(d.vertices[0].value == vec({1, 2, 0.5}));
  CHECK(d.vertices[0].line == 1);
  CHECK(sameKey(d.vertices[1].key, landmark(7)));
  CHECK(d.vertices[1].kind == VariableKind::Point2);
  CHECK(d.vertices[1].value == vec({3.5, -4}));
  CHECK(d.vertices[1].line == 2);
  REQUIRE(d.factors.size() == 2);
  const ModelFactor& e = d.factors[0];
  CHECK(e.kind == FactorKind::BetweenSE2);
  CHECK(sameKey(e.first, pose(0)));
  CHECK(sameKey(e.second, pose(1)));
  CHECK(e.measurement == vec({1, 0, -0.75}));
  Eigen::Matrix3d info;
  info << 11, 12, 13, 12, 22, 23, 13, 23, 33;  // positive definite (minors 11, 98, 873)
  CHECK(e.information == Eigen::MatrixXd(info));
  CHECK(e.line == 4);
  const ModelFactor& l = d.factors[1];
  CHECK(l.kind == FactorKind::PointXY2);
  CHECK(sameKey(l.first, pose(1)));
  CHECK(sameKey(l.second, landmark(7)));
  CHECK(l.measurement == vec({1.5, -6}));
  Eigen::Matrix2d info2;
  info2 << 4, 0.5, 0.5, 9;
  CHECK(l.information == Eigen::MatrixXd(info2));
  CHECK(l.line == 5);
  REQUIRE(d.fixed.size() == 2);
  CHECK(sameKey(d.fixed[0], pose(0)));
  CHECK(sameKey(d.fixed[1], landmark(7)));  // a FIX takes the role of its vertex
}

TEST_CASE("EDGE_SE2_RANGE_BEARING: lslam's range-bearing record -> RangeBearing2") {
  const ModelDataset d = parse({
      "VERTEX_SE2 0 1 2 0.5",
      "VERTEX_XY 7 3.5 -4",
      "EDGE_SE2_RANGE_BEARING 0 7 2.5 -1.25 4 0.5 9",
      "EDGE_SE2_RANGE_BEARING 0 7 1e-300 3.141592653589793 1 0 1",  // the largest bearing
      "EDGE_SE2_RANGE_BEARING 0 7 7 -3.141592653589793 1 -0.75 1",  // -pi rounded, > -pi
      "EDGE_SE2_RANGE_BEARING 0 7 +0.5 -0 2 0 3",
  });
  CHECK(d.format == DatasetFormat::G2o);
  CHECK(d.convention == ObjectiveConvention::G2o);
  CHECK(d.dimension == 2);
  REQUIRE(d.factors.size() == 4);
  const ModelFactor& f = d.factors[0];
  CHECK(f.kind == FactorKind::RangeBearing2);
  CHECK(sameKey(f.first, pose(0)));
  CHECK(sameKey(f.second, landmark(7)));
  CHECK(f.measurement == vec({2.5, -1.25}));
  Eigen::Matrix2d info;
  info << 4, 0.5, 0.5, 9;  // (range, bearing) order, as written
  CHECK(f.information == Eigen::MatrixXd(info));
  CHECK(f.line == 3);
  // Bearings are stored as read: the bounds of (-pi, pi] in doubles, and -0.
  const double pi = std::acos(-1.0);  // the double nearest pi
  CHECK(d.factors[1].measurement == vec({1e-300, pi}));
  CHECK(d.factors[2].measurement == vec({7, -pi}));
  CHECK(d.factors[2].information(1, 0) == -0.75);
  CHECK(d.factors[3].measurement[0] == 0.5);
  CHECK(std::signbit(d.factors[3].measurement[1]));
  CHECK(d.factors[3].line == 6);

  // Edge-only: the landmark id takes the landmark role (FIX too), as for EDGE_SE2_XY.
  const ModelDataset edges = parse(
      Lines{"EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1", "EDGE_SE2_RANGE_BEARING 1 5 2 0.5 1 0 1", "FIX 5"});
  REQUIRE(edges.factors.size() == 2);
  CHECK(edges.factors[1].kind == FactorKind::RangeBearing2);
  CHECK(sameKey(edges.factors[1].second, landmark(5)));
  REQUIRE(edges.fixed.size() == 1);
  CHECK(sameKey(edges.fixed[0], landmark(5)));
}

namespace {

// A symmetric positive definite n x n matrix with full off-diagonal structure.
Eigen::MatrixXd spd(int n, double seed) {
  Eigen::MatrixXd b(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) b(i, j) = std::sin(seed + 1.7 * i + 0.3 * j * j);
  }
  Eigen::MatrixXd m = b.transpose() * b + n * Eigen::MatrixXd::Identity(n, n);
  return (m + m.transpose()) / 2;  // exactly symmetric
}

}  // namespace

TEST_CASE("g2o 3D: VERTEX_SE3:QUAT, VERTEX_TRACKXYZ, EDGE_SE3:QUAT, EDGE_SE3_TRACKXYZ, FIX") {
  const Eigen::MatrixXd info6 = spd(6, 0.4);
  const Eigen::MatrixXd info3 = spd(3, 1.1);
  const Eigen::Quaterniond q = Eigen::Quaterniond(0.9, 0.1, -0.3, 0.2).normalized();
  std::ostringstream qs;
  qs.precision(17);
  qs << q.x() << " " << q.y() << " " << q.z() << " " << q.w();
  const ModelDataset d = parse({
      "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1",
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1",
      "VERTEX_SE3:QUAT 1 1 2 3 " + qs.str(),
      "VERTEX_TRACKXYZ 9 4 5 -6",
      "EDGE_SE3:QUAT 0 1 1 2 3 " + qs.str() + " " + upperText(info6),
      "EDGE_SE3_TRACKXYZ 1 9 0 0.5 -1 2 " + upperText(info3),
      "EDGE_SE3_TRACKXYZ 0 9 7 8 9 1 0 0 1 0 1",
      "FIX 1",
  });
  CHECK(d.dimension == 3);
  CHECK(d.format == DatasetFormat::G2o);
  CHECK(d.convention == ObjectiveConvention::G2o);
  REQUIRE(d.vertices.size() == 3);
  CHECK(sameKey(d.vertices[1].key, pose(1)));
  CHECK(d.vertices[1].kind == VariableKind::SE3);
  CHECK(d.vertices[1].value == vec({1, 2, 3, q.x(), q.y(), q.z(), q.w()}));
  CHECK(sameKey(d.vertices[2].key, landmark(9)));
  CHECK(d.vertices[2].kind == VariableKind::Point3);
  CHECK(d.vertices[2].value == vec({4, 5, -6}));
  CHECK(d.vertices[2].line == 4);
  REQUIRE(d.factors.size() == 3);
  const ModelFactor& e = d.factors[0];
  CHECK(e.kind == FactorKind::BetweenSE3);
  CHECK(sameKey(e.first, pose(0)));
  CHECK(sameKey(e.second, pose(1)));
  CHECK(e.measurement == vec({1, 2, 3, q.x(), q.y(), q.z(), q.w()}));
  CHECK(e.information == info6);
  CHECK(e.information(0, 5) == info6(0, 5));  // I16: translation x with qz
  CHECK(e.line == 5);
  const ModelFactor& p = d.factors[1];
  CHECK(p.kind == FactorKind::PointXYZ3);
  CHECK(sameKey(p.first, pose(1)));
  CHECK(sameKey(p.second, landmark(9)));
  CHECK(p.measurement == vec({0.5, -1, 2}));
  CHECK(p.information == info3);
  const ModelFactor& p2 = d.factors[2];  // the form without the sensor offset id
  CHECK(p2.measurement == vec({7, 8, 9}));
  CHECK(p2.information == Eigen::MatrixXd::Identity(3, 3));
  REQUIRE(d.fixed.size() == 1);
  CHECK(sameKey(d.fixed[0], pose(1)));
}

TEST_CASE("TORO VERTEX2/EDGE2 read as the 2D reader reads them") {
  const Lines lines = {"# TORO", "VERTEX2 0 0 0 0", "VERTEX2 1 1 0 0.5",
                       "EDGE2 0 1 1 0.25 0.5 10 1 20 30 2 3"};
  const ModelDataset d = parse(lines, "t.graph");
  CHECK(d.format == DatasetFormat::Toro);
  CHECK(d.convention == ObjectiveConvention::G2o);
  std::istringstream in(join(lines));
  const lslam::sim::Dataset2D d2 = lslam::sim::parseDataset2D(in, "t.graph");
  REQUIRE(d.factors.size() == 1);
  CHECK(d.factors[0].information == Eigen::MatrixXd(d2.edges[0].information));
  Eigen::Matrix3d expected;  // inf_xx inf_xy inf_yy inf_thth inf_xth inf_yth
  expected << 10, 1, 2, 1, 20, 3, 2, 3, 30;
  CHECK(d.factors[0].information == Eigen::MatrixXd(expected));
  CHECK(d.vertices[1].value == vec({1, 0, 0.5}));
  // Without '#' lines or a ".graph" name, EDGE2 is iSAM's (dataset_io.h's rule).
  CHECK(parse(Lines{"EDGE2 0 1 1 0 0 1 0 0 1 0 1"}, "t.txt").format == DatasetFormat::Isam);
  CHECK(parse(Lines{"# c", "EDGE2 0 1 1 0 0 1 0 1 1 0 0"}, "t.txt").format == DatasetFormat::Toro);
  CHECK(parse(Lines{}, "t.graph").format == DatasetFormat::Toro);
  CHECK(parse(Lines{}, "t.g2o").format == DatasetFormat::G2o);
  CHECK(parse(Lines{}, "t.g2o").dimension == 2);
}

TEST_CASE("iSAM 2D: ODOMETRY, EDGE2 and LANDMARK square-root information -> R^T R") {
  const ModelDataset d = parse(
      {
          "ODOMETRY 0 1 1 0.5 0.1 2 0.5 -0.25 3 0.75 4",
          "LANDMARK 1 2 11.5 -3.25 1.5 0.5 2.5",
          "EDGE2 1 3 0.5 0 -3 100 0 0 500 0 500",
          "LANDMARK 3 2 1 2 1.581139 0 1.581139",
      },
      "t.txt");
  CHECK(d.format == DatasetFormat::Isam);
  CHECK(d.convention == ObjectiveConvention::Isam);
  CHECK(d.dimension == 2);
  CHECK(d.vertices.empty());
  REQUIRE(d.factors.size() == 4);
  Eigen::Matrix3d r;
  r << 2, 0.5, -0.25, 0, 3, 0.75, 0, 0, 4;
  const Eigen::Matrix3d omega = r.transpose() * r;
  CHECK(d.factors[0].kind == FactorKind::BetweenSE2);
  CHECK(sameKey(d.factors[0].first, pose(0)));
  CHECK(sameKey(d.factors[0].second, pose(1)));
  CHECK(d.factors[0].measurement == vec({1, 0.5, 0.1}));
  CHECK((d.factors[0].information - Eigen::MatrixXd(omega)).cwiseAbs().maxCoeff() == 0.0);
  Eigen::Matrix2d r2;
  r2 << 1.5, 0.5, 0, 2.5;
  const Eigen::Matrix2d omega2 = r2.transpose() * r2;
  CHECK(d.factors[1].kind == FactorKind::PointXY2);
  CHECK(sameKey(d.factors[1].first, pose(1)));
  CHECK(sameKey(d.factors[1].second, landmark(2)));  // iSAM: landmarks are their own id space
  CHECK(d.factors[1].measurement == vec({11.5, -3.25}));
  CHECK(d.factors[1].information == Eigen::MatrixXd(omega2));
  CHECK(d.factors[2].information == Eigen::MatrixXd(Eigen::Vector3d(1e4, 25e4, 25e4).asDiagonal()));
  CHECK(d.factors[3].information(0, 0) == 1.581139 * 1.581139);
  CHECK(d.factors[3].information(0, 1) == 0.0);
}

TEST_CASE("iSAM 3D: EDGE3 Euler angles -> quaternion, sqrt-information in (x y z yaw pitch roll)") {
  const double roll = 0.3;
  const double pitch = -0.7;
  const double yaw = 2.5;
  // A full upper-triangular S in the file's order (x y z roll pitch yaw).
  Eigen::MatrixXd f = Eigen::MatrixXd::Zero(6, 6);
  for (int a = 0; a < 6; ++a) {
    for (int b = a; b < 6; ++b) f(a, b) = a == b ? 10.0 + a : 0.125 * (a + 1) - 0.0625 * b;
  }
  const ModelDataset d = parse(
      {
          "EDGE3 0 1 1 -2 0.5 0.3 -0.7 2.5 " + upperText(f),
          "POINT3 1 0 -2.5 7 -2 10 1 2 20 3 30",
          "POINT3 1 4 1 2 3",
          "EDGE3 1 2 0 0 0 0 0 0",
      },
      "t.txt");
  CHECK(d.format == DatasetFormat::Isam);
  CHECK(d.convention == ObjectiveConvention::Isam);
  CHECK(d.dimension == 3);
  REQUIRE(d.factors.size() == 4);
  const ModelFactor& e = d.factors[0];
  CHECK(e.kind == FactorKind::BetweenSE3);
  CHECK(sameKey(e.first, pose(0)));
  CHECK(sameKey(e.second, pose(1)));
  REQUIRE(e.measurement.size() == 7);
  CHECK(e.measurement.head<3>() == Eigen::Vector3d(1, -2, 0.5));
  CHECK(std::abs(e.measurement.tail<4>().norm() - 1.0) < 1e-15);
  const Eigen::Matrix3d rot =
      Eigen::Quaterniond(e.measurement[6], e.measurement[3], e.measurement[4], e.measurement[5])
          .toRotationMatrix();
  CHECK((rot - zyx(yaw, pitch, roll)).cwiseAbs().maxCoeff() < 1e-15);
  // iSAM's loader: translation rows as in the file, rotation block reversed to (yaw pitch roll):
  // S(3 + a, 3 + b) = F(5 - b, 5 - a).
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(6, 6);
  s.topRows(3) = f.topRows(3);
  for (int a = 0; a < 3; ++a) {
    for (int b = a; b < 3; ++b) s(3 + a, 3 + b) = f(5 - b, 5 - a);
  }
  const Eigen::MatrixXd omega = s.transpose() * s;
  CHECK((e.information - omega).cwiseAbs().maxCoeff() <= 1e-13 * omega.cwiseAbs().maxCoeff());
  CHECK(e.information == e.information.transpose());
  // A diagonal S (every real file) is the file's diagonal reordered.
  const ModelDataset diag = parse(
      Lines{"EDGE3 0 1 1 0 0 0 0 0 20 0 0 0 0 0 20 0 0 0 0 100 0 0 0 200 0 0 200 0 100"}, "t.txt");
  CHECK(diag.factors[0].information ==
        Eigen::MatrixXd(
            (Eigen::VectorXd(6) << 400, 400, 1e4, 1e4, 4e4, 4e4).finished().asDiagonal()));

  const ModelFactor& p = d.factors[1];
  CHECK(p.kind == FactorKind::PointXYZ3);
  CHECK(sameKey(p.first, pose(1)));
  CHECK(sameKey(p.second, landmark(0)));  // POINT3 ids are their own space
  CHECK(p.measurement == vec({-2.5, 7, -2}));
  Eigen::Matrix3d r;
  r << 10, 1, 2, 0, 20, 3, 0, 0, 30;
  CHECK(p.information == Eigen::MatrixXd(r.transpose() * r));
  CHECK(d.factors[2].information == Eigen::MatrixXd::Identity(3, 3));  // no sqrt-info: identity
  CHECK(d.factors[3].information == Eigen::MatrixXd::Identity(6, 6));
  CHECK(d.factors[3].measurement == vec({0, 0, 0, 0, 0, 0, 1}));
}

TEST_CASE("iSAM 3D: EDGE3 i j with i > j is stored j -> i with the inverse measurement") {
  const ModelDataset d = parse(
      Lines{"EDGE3 5 2 1 -2 0.5 0.3 -0.7 2.5 1 0 0 0 0 0 2 0 0 0 0 3 0 0 0 4 0 0 5 0 6"}, "t.txt");
  REQUIRE(d.factors.size() == 1);
  const ModelFactor& e = d.factors[0];
  CHECK(sameKey(e.first, pose(2)));
  CHECK(sameKey(e.second, pose(5)));
  Eigen::Isometry3d z = Eigen::Isometry3d::Identity();
  z.linear() = zyx(2.5, -0.7, 0.3);
  z.translation() = Eigen::Vector3d(1, -2, 0.5);
  const Eigen::Isometry3d inv = z.inverse();
  CHECK((isometry(e.measurement).matrix() - inv.matrix()).cwiseAbs().maxCoeff() < 1e-14);
  // The information is not transformed (iSAM's loader keeps the sqrt-information).
  CHECK(e.information ==
        Eigen::MatrixXd((Eigen::VectorXd(6) << 1, 4, 9, 36, 25, 16).finished().asDiagonal()));
  // Inverted, a translation keeps its length, not its coordinates' bound: (1e9, 1e9, 0) under a
  // yaw of pi/4 comes back as about (-1.41e9, 0, 0), an error at its line; stored as read, fine.
  CHECK_NOTHROW(parse(Lines{"EDGE3 0 1 1e9 1e9 0 0 0 0.7853981633974483"}, "t.txt"));
  expectError({"EDGE3 0 1 1 0 0 0 0 0", "EDGE3 2 1 1e9 1e9 0 0 0 0.7853981633974483"}, "t.txt", 2,
              {"EDGE3", "inverse measurement's translation", "beyond the coordinate range"});
}

// ---- errors ----

TEST_CASE("errors: quaternions, information, field counts and numbers give their line") {
  const std::string id6 = "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1";
  const std::string v0 = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1";
  const std::string v1 = "VERTEX_SE3:QUAT 1 0 0 0 0 0 0 1";
  expectError({v0, "VERTEX_SE3:QUAT 1 0 0 0 0 0 0 1.2"}, "t.g2o", 2,
              {"VERTEX_SE3:QUAT", "quaternion norm 1.2 is not 1 (tolerance 1e-05)"});
  expectError({v0, v1, "EDGE_SE3:QUAT 0 1 0 0 0 0.5 0.5 0.5 0.5001 " + id6}, "t.g2o", 3,
              {"EDGE_SE3:QUAT", "quaternion norm", "is not 1"});
  // Within the tolerance: accepted and stored as read.
  CHECK(parse(Lines{v0, "VERTEX_SE3:QUAT 1 0 0 0 0 0 0 1.000009"}).vertices[1].value[6] ==
        1.000009);
  expectError(
      {v0, v1, "EDGE_SE3:QUAT 0 1 0 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 -1"},
      "t.g2o", 3, {"EDGE_SE3:QUAT", "not positive definite", "smallest eigenvalue -1"});
  expectError({v0, v1, "EDGE_SE3:QUAT 0 1 0 0 0 0 0 0 1 " + id6.substr(0, 20)}, "t.g2o", 3,
              {"expected 31 fields, got 20", "truncated"});
  expectError({v0, v1, "EDGE_SE3:QUAT 0 1 0 0 0 0 0 0 1 " + id6 + " 5"}, "t.g2o", 3,
              {"trailing garbage '5'", "expected 31 fields, got 32"});
  expectError({v0, v1, "EDGE_SE3:QUAT 0 1 0 0 0 0 0 0 1x " + id6}, "t.g2o", 3,
              {"EDGE_SE3:QUAT field qw", "'1x' is not a number"});
  expectError({v0, "EDGE_SE3:QUAT 0 0 0 0 0 0 0 0 1 " + id6}, "t.g2o", 2, {"to itself"});
  expectError({"VERTEX_SE2 0 0 0 0", "VERTEX_XY 1 0 0", "EDGE_SE2_XY 0 1 1 1 2 3 1"}, "t.g2o", 3,
              {"EDGE_SE2_XY", "not positive definite"});
  expectError({"VERTEX_SE2 0 0 0 0", "VERTEX_XY 1 0 nan"}, "t.g2o", 2,
              {"VERTEX_XY field y", "'nan'"});
  expectError({"VERTEX_SE2 0 0 0 0", "EDGE_SE2_XY 0 0 1 1 1 0 1"}, "t.g2o", 2,
              {"same id 0", "one space"});
  expectError({"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", "LANDMARK 1 2 1 1 0 0 1"}, "t.txt", 2,
              {"LANDMARK", "not positive definite", "R11 = 0"});
  expectError({"EDGE3 0 1 0 0 0 0 0 0 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 0 0 1"}, "t.txt", 1,
              {"EDGE3", "not positive definite", "S55 = 0"});
  expectError({"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", "EDGE3 1 2 0 0 0 0 0 0 1 0 0"}, "t.txt", 2,
              {"record 'EDGE3' is a 3D record, but the file is 2D (first 2D record at line 1)"});
  expectError({"EDGE3 0 1 0 0 0 0 0 0", "EDGE3 1 2 0 0 0 0 0 0 1 1 1"}, "t.txt", 2,
              {"expected 30 fields (or 9 without square-root information), got 12"});
  expectError({"EDGE3 0 0 0 0 0 0 0 0"}, "t.txt", 1, {"EDGE3", "to itself"});
  expectError({"EDGE3 0 1 0 0 0 0 1.6 0"}, "t.txt", 1, {"EDGE3", "pitch 1.6", "[-pi/2, pi/2]"});
  CHECK_NOTHROW(parse(Lines{"EDGE3 0 1 0 0 0 0 -1.5707963267948966 0"}, "t.txt"));
  expectError({"EDGE3 0 1 0 0 0 0 0 0", "POINT3 1 0 1 2 3 1 0 0 1 0"}, "t.txt", 2,
              {"POINT3", "expected 12 fields (or 6 without square-root information), got 11"});
  expectError({"EDGE3 0 1 0 0 0 0 0 0", "POINT3 1 0 1 2 3 1 0 0 1 0 1 9"}, "t.txt", 2,
              {"trailing garbage '9'"});
  expectError({"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", "LANDMARK 1 x 1 1 1 0 1"}, "t.txt", 2,
              {"LANDMARK field landmark", "'x' is not an integer id"});
  expectError({"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", "LANDMARK 1 2 1 1 1e200 0 1e200"}, "t.txt", 2,
              {"overflows"});
}

TEST_CASE("errors: a position, translation or range beyond the coordinate range gives its line") {
  // lslam::kMaxCoordinate (1e9 m) is read; the next double above it, in any position field of any
  // record, is the solver's InvalidArgument, reported here at its line.
  const std::string id3 = "1 0 0 1 0 1";
  const std::string id6 = "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1";
  const std::string at = "1e9";
  const std::string past = "1000000000.0000001";
  REQUIRE(std::stod(past) == std::nextafter(lslam::kMaxCoordinate, 2e9));
  const std::string se2 = "VERTEX_SE2 0 0 0 0";
  const std::string se3 = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1";
  struct Case {
    Lines lines;  // the last line holds `@`, replaced by `at` (read) and by `past` (rejected)
    std::string name;
    std::string field;
  };
  const std::vector<Case> cases = {
      {{"VERTEX_SE2 0 @ 0 0"}, "t.g2o", "VERTEX_SE2 field x"},
      {{se2, "VERTEX_XY 1 0 -@"}, "t.g2o", "VERTEX_XY field y"},
      {{se2, "VERTEX_SE2 1 0 0 0", "EDGE_SE2 0 1 1 @ 0 1 0 0 1 0 1"}, "t.g2o", "EDGE_SE2 field dy"},
      {{se2, "VERTEX_XY 1 0 0", "EDGE_SE2_XY 0 1 -@ 0 1 0 1"}, "t.g2o", "EDGE_SE2_XY field dx"},
      {{se2, "VERTEX_XY 1 0 0", "EDGE_SE2_RANGE_BEARING 0 1 @ 0.5 1 0 1"},
       "t.g2o",
       "EDGE_SE2_RANGE_BEARING field range"},
      {{"VERTEX_SE3:QUAT 0 0 0 @ 0 0 0 1"}, "t.g2o", "VERTEX_SE3:QUAT field z"},
      {{se3, "VERTEX_TRACKXYZ 1 @ 0 0"}, "t.g2o", "VERTEX_TRACKXYZ field x"},
      {{se3, "VERTEX_SE3:QUAT 1 0 0 0 0 0 0 1", "EDGE_SE3:QUAT 0 1 0 -@ 0 0 0 0 1 " + id6},
       "t.g2o",
       "EDGE_SE3:QUAT field y"},
      {{se3, "VERTEX_TRACKXYZ 1 0 0 0", "EDGE_SE3_TRACKXYZ 0 1 0 0 @ " + id3},
       "t.g2o",
       "EDGE_SE3_TRACKXYZ field z"},
      {{"VERTEX2 0 @ 0 0"}, "t.graph", "VERTEX2 field x"},
      {{"ODOMETRY 0 1 @ 0 0 1 0 0 1 0 1"}, "t.txt", "ODOMETRY field dx"},
      {{"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", "LANDMARK 1 2 1 -@ 1 0 1"}, "t.txt", "LANDMARK field dy"},
      {{"EDGE3 0 1 0 @ 0 0 0 0"}, "t.txt", "EDGE3 field y"},
      {{"EDGE3 0 1 0 0 0 0 0 0", "POINT3 1 0 1 2 @ " + id3}, "t.txt", "POINT3 field z"},
  };
  for (const Case& c : cases) {
    const auto with = [&](const std::string& value) {
      Lines lines = c.lines;
      std::string& last = lines.back();
      last.replace(last.find('@'), 1, value);
      return lines;
    };
    CAPTURE(c.field);
    CHECK_NOTHROW(parse(with(at), c.name));
    expectError(with(past), c.name, c.lines.size(),
                {c.field, past + "'", "beyond the coordinate range"});
  }
}

TEST_CASE("errors: sensor offsets of EDGE_SE3_TRACKXYZ") {
  const std::string v0 = "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1";
  const std::string p = "VERTEX_TRACKXYZ 1 0 0 0";
  expectError({v0, p, "EDGE_SE3_TRACKXYZ 0 1 0 1 2 3 1 0 0 1 0 1"}, "t.g2o", 3,
              {"sensor offset parameter 0", "PARAMS_SE3OFFSET"});
  expectError({"PARAMS_SE3OFFSET 0 0.1 0 0 0 0 0 1"}, "t.g2o", 1, {"identity sensor offset"});
  expectError({"PARAMS_SE3OFFSET 0 0 0 0 0 0 0 2"}, "t.g2o", 1, {"quaternion norm 2"});
  expectError({"PARAMS_SE3OFFSET 3 0 0 0 0 0 0 1", "PARAMS_SE3OFFSET 3 0 0 0 0 0 0 1"}, "t.g2o", 2,
              {"duplicate parameter id 3", "line 1"});
  expectError({v0, p, "EDGE_SE3_TRACKXYZ 0 1 1 2 3 1 0 0 1 0"}, "t.g2o", 3,
              {"expected 12 fields (or 13 with a sensor offset id), got 11"});
  expectError({v0, p, "EDGE_SE3_TRACKXYZ 0 1 1 2 3 1 0 0 1 0 1 0 0"}, "t.g2o", 3,
              {"trailing garbage '0'", "got 14"});
}

TEST_CASE("errors: ids: duplicates, kinds, declarations, roles, FIX") {
  // One id space for all g2o vertices.
  expectError({"VERTEX_SE2 3 0 0 0", "VERTEX_XY 3 1 1"}, "t.g2o", 2,
              {"VERTEX_XY: duplicate vertex id 3", "line 1", "VERTEX_SE2"});
  expectError({"VERTEX_SE3:QUAT 3 0 0 0 0 0 0 1", "VERTEX_TRACKXYZ 3 1 1 1"}, "t.g2o", 2,
              {"duplicate vertex id 3"});
  // An edge naming a vertex of the wrong kind.
  expectError({"VERTEX_SE2 0 0 0 0", "VERTEX_SE2 3 0 0 0", "EDGE_SE2_XY 0 3 1 1 1 0 1"}, "t.g2o", 3,
              {"EDGE_SE2_XY 0 -> 3 names landmark 3", "VERTEX_SE2 at line 2", "as a pose"});
  expectError({"VERTEX_SE2 0 0 0 0", "EDGE_SE2 0 3 1 0 0 1 0 0 1 0 1", "VERTEX_XY 3 0 0"}, "t.g2o",
              2, {"EDGE_SE2 0 -> 3 names pose 3", "VERTEX_XY at line 3", "as a landmark"});
  // Undeclared ids (vertices may follow the edges; the earliest bad line is reported).
  expectError({"VERTEX_SE2 0 0 0 0", "EDGE_SE2_XY 0 5 1 1 1 0 1"}, "t.g2o", 2,
              {"names landmark 5", "no VERTEX_XY line declares"});
  expectError({"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1", "FIX 0", "FIX 4",
               "EDGE_SE3_TRACKXYZ 0 8 1 2 3 1 0 0 1 0 1"},
              "t.g2o", 3, {"FIX names id 4", "no vertex line declares"});
  expectError(
      {"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1", "EDGE_SE3_TRACKXYZ 0 8 1 2 3 1 0 0 1 0 1", "FIX 4"},
      "t.g2o", 2, {"names landmark 8", "no VERTEX_TRACKXYZ line declares"});
  // Edge-only g2o files: an id is a pose or a landmark, not both.
  expectError({"EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1", "EDGE_SE2_XY 0 1 1 1 1 0 1"}, "t.g2o", 2,
              {"uses id 1 as a landmark", "line 1 uses it as a pose"});
  const ModelDataset edges_only =
      parse(Lines{"EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1", "EDGE_SE2_XY 0 2 1 1 1 0 1", "FIX 2 0 9"});
  REQUIRE(edges_only.fixed.size() == 3);
  CHECK(sameKey(edges_only.fixed[0], landmark(2)));  // the role of the id's use
  CHECK(sameKey(edges_only.fixed[1], pose(0)));
  CHECK(sameKey(edges_only.fixed[2], pose(9)));  // unused: a pose
  // iSAM: landmarks are their own id space, so an id may be a pose and a landmark.
  const ModelDataset isam =
      parse(Lines{"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", "LANDMARK 1 1 1 1 1 0 1"}, "t.txt");
  CHECK(sameKey(isam.factors[1].second, landmark(1)));
}

TEST_CASE("errors: EDGE_SE2_RANGE_BEARING gives its line") {
  const std::string v = "VERTEX_SE2 0 0 0 0";
  const std::string l = "VERTEX_XY 4 1 1";
  const std::string tag = "EDGE_SE2_RANGE_BEARING";
  CHECK_NOTHROW(parse(Lines{v, l, tag + " 0 4 1.5 0.5 1 0 1"}));
  // Field counts.
  expectError({v, l, tag + " 0 4 1.5 0.5 1 0"}, "t.g2o", 3,
              {"EDGE_SE2_RANGE_BEARING: expected 8 fields, got 7", "truncated"});
  expectError({v, l, tag + " 0 4 1.5 0.5 1 0 1 2"}, "t.g2o", 3,
              {"trailing garbage '2'", "expected 8 fields, got 9"});
  // Numbers: not finite, not numbers.
  expectError({v, l, tag + " 0 4 nan 0.5 1 0 1"}, "t.g2o", 3,
              {"EDGE_SE2_RANGE_BEARING field range", "'nan'"});
  expectError({v, l, tag + " 0 4 1.5 inf 1 0 1"}, "t.g2o", 3,
              {"EDGE_SE2_RANGE_BEARING field bearing", "'inf'"});
  expectError({v, l, tag + " 0 4 1.5 0.5 1 0 1e400"}, "t.g2o", 3,
              {"EDGE_SE2_RANGE_BEARING field I22", "'1e400'"});
  expectError({v, l, tag + " 0 x 1.5 0.5 1 0 1"}, "t.g2o", 3,
              {"EDGE_SE2_RANGE_BEARING field landmark", "'x' is not an integer id"});
  // Range > 0.
  for (const std::string range : {"0", "-0", "-1.5", "-1e-300"}) {
    expectError({v, l, tag + " 0 4 " + range + " 0.5 1 0 1"}, "t.g2o", 3,
                {"EDGE_SE2_RANGE_BEARING: range", "is not positive"});
  }
  // Bearing in (-pi, pi]: the doubles just outside the rounded pi, degrees, a full turn.
  for (const std::string bearing :
       {"3.1415926535897936", "-3.1415926535897936", "90", "6.283185307179586"}) {
    expectError({v, l, tag + " 0 4 1 " + bearing + " 1 0 1"}, "t.g2o", 3,
                {"EDGE_SE2_RANGE_BEARING: bearing", "outside (-pi, pi]"});
  }
  // Information: symmetric upper triangle, positive definite.
  expectError({v, l, tag + " 0 4 1.5 0.5 1 0 -1"}, "t.g2o", 3,
              {"EDGE_SE2_RANGE_BEARING: information matrix is not positive definite",
               "smallest eigenvalue -1"});
  expectError({v, l, tag + " 0 4 1.5 0.5 0 0 1"}, "t.g2o", 3, {"not positive definite"});
  expectError({v, l, tag + " 0 4 1.5 0.5 1 2 1"}, "t.g2o", 3, {"not positive definite"});
  // Ids: the same id for both, undeclared ids, a landmark id that is a pose and the reverse.
  expectError({v, tag + " 0 0 1.5 0.5 1 0 1"}, "t.g2o", 2, {"same id 0", "one space"});
  expectError({v, l, tag + " 0 5 1.5 0.5 1 0 1"}, "t.g2o", 3,
              {"EDGE_SE2_RANGE_BEARING 0 -> 5 names landmark 5", "no VERTEX_XY line declares"});
  expectError({v, l, tag + " 3 4 1.5 0.5 1 0 1"}, "t.g2o", 3,
              {"EDGE_SE2_RANGE_BEARING 3 -> 4 names pose 3", "no VERTEX_SE2 line declares"});
  expectError(
      {v, "VERTEX_SE2 2 0 0 0", tag + " 0 2 1.5 0.5 1 0 1"}, "t.g2o", 3,
      {"EDGE_SE2_RANGE_BEARING 0 -> 2 names landmark 2", "VERTEX_SE2 at line 2", "as a pose"});
  expectError(
      {v, l, tag + " 4 0 1.5 0.5 1 0 1"}, "t.g2o", 3,
      {"EDGE_SE2_RANGE_BEARING 4 -> 0 names pose 4", "VERTEX_XY at line 2", "as a landmark"});
  // The earliest bad line is reported, also when the vertices come after the edges.
  expectError({tag + " 0 4 1.5 0.5 1 0 1", tag + " 0 9 1.5 0.5 1 0 1", v, l}, "t.g2o", 2,
              {"names landmark 9"});
  // Edge-only: an id is a pose or a landmark.
  expectError({"EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1", tag + " 0 1 1.5 0.5 1 0 1"}, "t.g2o", 2,
              {"uses id 1 as a landmark", "line 1 uses it as a pose"});
  // A duplicate landmark vertex.
  expectError({v, l, "VERTEX_XY 4 2 2", tag + " 0 4 1.5 0.5 1 0 1"}, "t.g2o", 3,
              {"duplicate vertex id 4", "line 2"});
  // A g2o 2D record: not in iSAM or TORO files, nor in 3D files.
  expectError({"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", tag + " 1 5 1.5 0.5 1 0 1"}, "t.txt", 2,
              {"record 'EDGE_SE2_RANGE_BEARING' is a g2o record, but the file is read as iSAM"});
  expectError({"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1", tag + " 0 5 1.5 0.5 1 0 1"}, "t.g2o", 2,
              {"record 'EDGE_SE2_RANGE_BEARING' is a 2D record, but the file is 3D"});
}

TEST_CASE("errors: formats, dimensions and unknown records give their line") {
  expectError({"VERTEX_SE2 0 0 0 0", "EDGE3 0 1 0 0 0 0 0 0"}, "t.g2o", 2,
              {"record 'EDGE3' is a iSAM record, but the file is read as g2o (first g2o record at "
               "line 1)"});
  expectError({"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", "VERTEX_XY 1 0 0"}, "t.txt", 2,
              {"record 'VERTEX_XY' is a g2o record, but the file is read as iSAM"});
  expectError({"VERTEX2 0 0 0 0", "LANDMARK 0 1 1 1 1 0 1"}, "t.txt", 2,
              {"'LANDMARK' is a iSAM record", "TORO"});
  expectError({"VERTEX_SE2 0 0 0 0", "", "# c", "VERTEX_SE3:QUAT 1 0 0 0 0 0 0 1"}, "t.g2o", 4,
              {"record 'VERTEX_SE3:QUAT' is a 3D record, but the file is 2D (first 2D record at "
               "line 1)"});
  expectError({"FIX 0", "VERTEX_TRACKXYZ 0 0 0 0", "EDGE_SE2_XY 0 1 1 1 1 0 1"}, "t.g2o", 3,
              {"is a 2D record, but the file is 3D (first 3D record at line 2)"});
  expectError({"VERTEX_SE2 0 0 0 0", "EDGE_SE2_POINTXY 0 1 1 1 1 0 1"}, "t.g2o", 2,
              {"unsupported record 'EDGE_SE2_POINTXY'"});
  expectError({"FOO"}, "t.txt", 1, {"unsupported record 'FOO'"});
  expectError({"VERTEX_SE2 0 0 0 0", "FIX"}, "t.g2o", 2, {"FIX", "no id"});
}

TEST_CASE("readModelDataset: missing file, directory") {
  const std::string missing = "/nonexistent/dir/none.g2o";
  try {
    lslam::sim::readModelDataset(missing);
    FAIL("no error");
  } catch (const DatasetError& e) {
    CHECK(e.line() == 0);
    CHECK(e.file() == missing);
    CHECK(e.reason().find("cannot open") != std::string::npos);
  }
  try {
    lslam::sim::readModelDataset(std::filesystem::temp_directory_path().string());
    FAIL("no error");
  } catch (const DatasetError& e) {
    CHECK(e.line() == 0);
    CHECK(e.reason().find("directory") != std::string::npos);
  }
}

TEST_CASE("random single-token corruptions parse or throw DatasetError within the file") {
  const std::vector<std::pair<std::string, Lines>> files = {
      {"t.g2o",
       {"VERTEX_SE2 0 0 0 0", "VERTEX_SE2 1 1 0 0.5", "VERTEX_XY 5 2 1", "FIX 0",
        "EDGE_SE2 0 1 1 0 0.5 10 0 0 10 0 20", "EDGE_SE2_XY 1 5 1 1 4 0.5 9",
        "EDGE_SE2_RANGE_BEARING 0 5 2.5 0.4 4 0.5 9"}},
      {"t.g2o",
       {"PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1", "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1",
        "VERTEX_SE3:QUAT 1 1 0 0 0 0 0.6 0.8", "VERTEX_TRACKXYZ 2 1 2 3",
        "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0.6 0.8 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 4 0 0 4 0 4",
        "EDGE_SE3_TRACKXYZ 1 2 0 1 2 3 1 0 0 1 0 1"}},
      {"t.txt",
       {"ODOMETRY 0 1 1 0 0.1 10 0 0 10 0 20", "LANDMARK 1 2 3 4 1.5 0 1.5",
        "EDGE2 1 3 1 0 0 10 0 0 10 0 20"}},
      {"t.txt",
       {"EDGE3 0 1 1 0 0 0.1 0.2 0.3 20 0 0 0 0 0 20 0 0 0 0 100 0 0 0 200 0 0 200 0 100",
        "POINT3 1 0 1 2 3 10 0 0 10 0 10", "EDGE3 3 1 1 0 0 0 0 0"}},
  };
  const std::vector<std::string> replacements = {
      "nan",    "1e400", "-1", "x",      "0",         "1.5", "2147483648", "\x01", "EDGE3",
      "0.9999", "-0",    "+1", "1e-320", "VERTEX_XY", "FIX", "3",          "#"};
  std::mt19937 rng(12345);
  for (const auto& [name, lines] : files) {
    CHECK_NOTHROW(parse(lines, name));  // the uncorrupted file is valid
    for (int trial = 0; trial < 400; ++trial) {
      Lines corrupted = lines;
      std::string& line = corrupted[rng() % corrupted.size()];
      std::vector<std::string> tokens;
      std::istringstream split(line);
      for (std::string t; split >> t;) tokens.push_back(t);
      const std::size_t at = rng() % tokens.size();
      const auto action = rng() % 3;
      if (action == 0) {
        tokens[at] = replacements[rng() % replacements.size()];
      } else if (action == 1) {
        tokens.erase(tokens.begin() + static_cast<std::ptrdiff_t>(at));
      } else {
        tokens.insert(tokens.begin() + static_cast<std::ptrdiff_t>(at), tokens[at]);
      }
      line.clear();
      for (const std::string& t : tokens) line += (line.empty() ? "" : " ") + t;
      try {
        parse(corrupted, name);
      } catch (const DatasetError& e) {
        INFO(join(corrupted) << e.what());
        CHECK(e.line() >= 1);
        CHECK(e.line() <= corrupted.size());
      }
    }
  }
}

// ---- writer ----

namespace {

// Values that print with many digits or none, tiny, signed zero, subnormal; the largest is within
// the coordinate range (lslam::kMaxCoordinate) at every k used here (k / 7 <= 1).
double awkward(int k) {
  const double base[] = {0.1 + 0.2, 1.0 / 3.0, -2.0 / 7.0, 1e-300, 4.87654321e8, -0.0, 5e-324};
  return base[k % 7] * (1 + k / 7);
}

ModelDataset landmarks2d() {
  ModelDataset d;
  d.dimension = 2;
  for (int k = 0; k < 4; ++k) {
    ModelVertex v;
    v.key = pose(k);
    v.kind = VariableKind::SE2;
    // (An angle is not bounded: pose 0's is a large exponent form.)
    v.value = vec({awkward(k), awkward(k + 1), k == 0 ? 6.02214076e23 : awkward(k + 2) * 1e-20});
    d.vertices.push_back(v);
  }
  ModelVertex l;
  l.key = landmark(10);
  l.kind = VariableKind::Point2;
  l.value = vec({awkward(3), awkward(4)});
  d.vertices.push_back(l);
  for (int k = 0; k < 3; ++k) {
    ModelFactor f;
    f.kind = FactorKind::BetweenSE2;
    f.first = pose(k + 1);
    f.second = pose(k);
    f.measurement = vec({awkward(k + 5), awkward(k + 6), awkward(k)});
    f.information = spd(3, 0.1 * k);
    d.factors.push_back(f);
  }
  ModelFactor o;
  o.kind = FactorKind::PointXY2;
  o.first = pose(2);
  o.second = landmark(10);
  o.measurement = vec({awkward(1), awkward(2)});
  o.information = spd(2, 0.7);
  d.factors.push_back(o);
  d.fixed = {pose(0), landmark(10)};
  return d;
}

// landmarks2d() with two more landmarks observed as range and bearing: awkward positive ranges
// (down to the smallest subnormal) and bearings including -0 and the bounds of (-pi, pi].
ModelDataset rangeBearing2d() {
  ModelDataset d = landmarks2d();
  for (int k = 0; k < 2; ++k) {
    ModelVertex l;
    l.key = landmark(11 + k);
    l.kind = VariableKind::Point2;
    l.value = vec({awkward(k + 2), awkward(k + 5)});
    d.vertices.push_back(l);
  }
  const double pi = std::acos(-1.0);
  const std::vector<std::pair<double, double>> zs = {{std::abs(awkward(0)), awkward(2)},
                                                     {std::abs(awkward(1)), awkward(3)},
                                                     {std::abs(awkward(4)), awkward(5)},
                                                     {awkward(6), awkward(6)},
                                                     {awkward(10), pi},
                                                     {std::abs(awkward(9)), -pi},
                                                     {awkward(7), std::nextafter(pi, 0.0)}};
  for (std::size_t k = 0; k < zs.size(); ++k) {
    ModelFactor f;
    f.kind = FactorKind::RangeBearing2;
    f.first = pose(static_cast<std::int64_t>(k % 4));
    f.second = landmark(11 + static_cast<std::int64_t>(k % 2));
    f.measurement = vec({zs[k].first, zs[k].second});
    f.information = spd(2, 0.9 + 0.4 * static_cast<double>(k));
    d.factors.push_back(f);
  }
  return d;
}

ModelDataset points3d() {
  ModelDataset d;
  d.dimension = 3;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Quaterniond q =
        Eigen::Quaterniond(awkward(k) + 1, awkward(k + 1), 0.25 * k, -0.5).normalized();
    ModelVertex v;
    v.key = pose(2 * k);
    v.kind = VariableKind::SE3;
    v.value = vec({awkward(k), awkward(k + 2), awkward(k + 4), q.x(), q.y(), q.z(), q.w()});
    d.vertices.push_back(v);
  }
  ModelVertex p;
  p.key = landmark(1);
  p.kind = VariableKind::Point3;
  p.value = vec({awkward(5), awkward(6), awkward(7)});
  d.vertices.push_back(p);
  for (int k = 0; k < 2; ++k) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(1, 0.1 * k, awkward(k), 0.3).normalized();
    ModelFactor f;
    f.kind = FactorKind::BetweenSE3;
    f.first = pose(2 * k);
    f.second = pose(2 * k + 2);
    f.measurement = vec({awkward(k + 1), awkward(k + 3), 1e-7, q.x(), q.y(), q.z(), q.w()});
    f.information = spd(6, 0.3 * k);
    d.factors.push_back(f);
  }
  ModelFactor o;
  o.kind = FactorKind::PointXYZ3;
  o.first = pose(4);
  o.second = landmark(1);
  o.measurement = vec({awkward(2), awkward(3), awkward(4)});
  o.information = spd(3, 2.5);
  d.factors.push_back(o);
  d.fixed = {pose(2)};
  return d;
}

// writeModelG2o must throw std::invalid_argument mentioning `fragment` and write nothing.
void expectRejected(const ModelDataset& d, const std::string& fragment) {
  std::ostringstream out;
  try {
    writeModelG2o(out, d);
    FAIL("not rejected: " << fragment);
  } catch (const std::invalid_argument& e) {
    INFO("message: " << e.what());
    CHECK(std::string(e.what()).find(fragment) != std::string::npos);
  }
  CHECK(out.str().empty());
}

}  // namespace

TEST_CASE("writeModelG2o -> parseModelDataset is bit-exact (2D, 3D, landmarks, edge-only)") {
  const ModelDataset d2 = landmarks2d();
  expectSameContents(roundTrip(d2), d2);
  const ModelDataset d3 = points3d();
  const ModelDataset back3 = roundTrip(d3);
  expectSameContents(back3, d3);
  CHECK(back3.format == DatasetFormat::G2o);
  CHECK(back3.convention == ObjectiveConvention::G2o);
  std::ostringstream text;
  writeModelG2o(text, d3);
  CHECK(text.str().rfind("PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n", 0) == 0);
  CHECK(text.str().find("EDGE_SE3_TRACKXYZ 4 1 0 ") != std::string::npos);

  // Edge-only (as read from iSAM 2D, landmarks in the shared space): the edges alone.
  ModelDataset edges = d2;
  edges.vertices.clear();
  edges.convention = ObjectiveConvention::Isam;
  edges.fixed = {landmark(10)};
  expectSameContents(roundTrip(edges), edges);

  // Range-bearing observations, with vertices and edge-only.
  const ModelDataset rb = rangeBearing2d();
  REQUIRE(rb.factors.size() == 11);
  for (std::size_t k = 4; k < rb.factors.size(); ++k) REQUIRE(rb.factors[k].measurement[0] > 0.0);
  const ModelDataset rb_back = roundTrip(rb);
  expectSameContents(rb_back, rb);
  CHECK(rb_back.factors[6].measurement[1] == 0.0);
  CHECK(std::signbit(rb_back.factors[6].measurement[1]));  // -0 stays -0
  std::ostringstream rb_text;
  writeModelG2o(rb_text, rb);
  CHECK(rb_text.str().find("\nEDGE_SE2_RANGE_BEARING 0 11 ") != std::string::npos);
  CHECK(rb_text.str().find(
            "\nEDGE_SE2_RANGE_BEARING 0 11 0.30000000000000004 -0.2857142857142857 ") !=
        std::string::npos);
  ModelDataset rb_edges = rb;
  rb_edges.vertices.clear();
  rb_edges.fixed = {landmark(12), pose(1)};
  expectSameContents(roundTrip(rb_edges), rb_edges);

  // A file written to disk reads back the same.
  const std::string path =
      (std::filesystem::temp_directory_path() / "lslam_test_model_dataset_io.g2o").string();
  lslam::sim::writeModelG2oFile(path, d3);
  const ModelDataset from_file = lslam::sim::readModelDataset(path);
  CHECK(from_file.name == path);
  expectSameContents(from_file, d3);
  std::filesystem::remove(path);
}

TEST_CASE("writeModelG2o rejects what the reader would reject, before writing anything") {
  {
    ModelDataset d = points3d();
    d.vertices[1].value[6] *= 1.001;
    expectRejected(d, "quaternion norm");
  }
  {
    ModelDataset d = points3d();
    d.factors[0].measurement[3] = 0.5;
    expectRejected(d, "quaternion norm");
  }
  {
    ModelDataset d = points3d();
    d.convention = ObjectiveConvention::Isam;
    expectRejected(d, "Euler");
  }
  {
    ModelDataset d = points3d();
    d.dimension = 2;
    expectRejected(d, "not a 2D");
  }
  {
    ModelDataset d = landmarks2d();
    d.vertices[4].key = landmark(3);  // the id of a pose
    expectRejected(d, "duplicate vertex id");
  }
  {
    ModelDataset d = landmarks2d();
    d.vertices[4].key = pose(10);
    expectRejected(d, "role");
  }
  {
    ModelDataset d = landmarks2d();
    d.factors[3].second = landmark(11);
    expectRejected(d, "not declared");
  }
  {
    ModelDataset d = landmarks2d();
    d.factors[0].second = pose(1);
    expectRejected(d, "equal");
  }
  {
    ModelDataset d = landmarks2d();
    d.factors[0].information(0, 1) = 1e3;  // the upper triangle written is indefinite
    expectRejected(d, "not positive definite");
  }
  {
    ModelDataset d = landmarks2d();
    d.factors[1].measurement[0] = std::nan("");
    expectRejected(d, "non-finite");
  }
  {
    const double beyond = std::nextafter(lslam::kMaxCoordinate, 2e9);
    ModelDataset d = landmarks2d();
    d.factors[1].measurement[1] = -beyond;
    expectRejected(d, "beyond the coordinate range");
    d = points3d();
    d.vertices[3].value[2] = beyond;  // the landmark's z
    expectRejected(d, "beyond the coordinate range");
    d = points3d();
    d.factors[0].measurement[0] = beyond;  // an SE3 translation; its quaternion is not bounded
    expectRejected(d, "beyond the coordinate range");
    d = rangeBearing2d();
    d.factors[5].measurement[0] = beyond;  // a range
    expectRejected(d, "beyond the coordinate range");
  }
  {
    ModelDataset d = landmarks2d();
    d.factors[1].kind = FactorKind::PriorSE2;
    expectRejected(d, "no g2o record");
  }
  {
    ModelDataset d = landmarks2d();
    d.factors[1].kind = FactorKind::RangeBearing2;  // between two poses
    expectRejected(d, "keys must be a pose and a landmark");
  }
  for (const double range : {0.0, -0.0, -1.0}) {
    ModelDataset d = rangeBearing2d();
    d.factors[5].measurement[0] = range;
    expectRejected(d, "is not positive");
  }
  for (const double bearing :
       {std::nextafter(std::acos(-1.0), 4.0), std::nextafter(-std::acos(-1.0), -4.0), 90.0}) {
    ModelDataset d = rangeBearing2d();
    d.factors[5].measurement[1] = bearing;
    expectRejected(d, "outside (-pi, pi]");
  }
  {
    ModelDataset d = rangeBearing2d();
    d.factors[5].measurement[1] = std::numeric_limits<double>::infinity();
    expectRejected(d, "non-finite");
  }
  {
    ModelDataset d = rangeBearing2d();
    d.factors[5].measurement = vec({1, 0.5, 0});
    expectRejected(d, "3 values, expected 2");
  }
  {
    ModelDataset d = rangeBearing2d();
    d.factors[5].second = landmark(2);  // a pose's id
    expectRejected(d, "not declared by a Point2 vertex");
  }
  {
    ModelDataset d = rangeBearing2d();
    d.factors[5].information = spd(3, 0.0);
    expectRejected(d, "information is 3x3, expected 2x2");
  }
  {
    ModelDataset d = rangeBearing2d();
    d.factors[5].information(0, 1) = 1e3;
    expectRejected(d, "not positive definite");
  }
  {
    ModelDataset d = landmarks2d();
    d.fixed.push_back(pose(10));
    expectRejected(d, "would read back as a landmark");
  }
  {
    ModelDataset d = landmarks2d();
    d.vertices[0].key.id = -1;
    expectRejected(d, "out of range");
  }
  {
    ModelDataset d = landmarks2d();
    d.vertices.clear();
    d.factors[0].second = landmark(2);  // id 2 is a pose in the other edges
    d.factors[0].kind = FactorKind::PointXY2;
    d.factors[0].measurement = vec({1, 2});
    d.factors[0].information = spd(2, 0.0);
    expectRejected(d, "both as a pose and as a landmark");
  }
  {
    ModelDataset d = points3d();
    d.factors[2].information = spd(6, 0.0);
    expectRejected(d, "information is 6x6, expected 3x3");
  }
}

// ---- a range-bearing file run end to end ----

namespace {

double wrapped(double a) {
  return std::atan2(std::sin(a), std::cos(a));
}

Eigen::Matrix3d poseMatrix(const Eigen::Vector3d& x) {
  Eigen::Matrix3d t;
  t << std::cos(x[2]), -std::sin(x[2]), x[0],  //
      std::sin(x[2]), std::cos(x[2]), x[1],    //
      0, 0, 1;
  return t;
}

}  // namespace

TEST_CASE("EDGE_SE2_RANGE_BEARING file: incremental run agrees with the batch solver") {
  // Six poses along a gentle curve, three landmarks seen from several poses each; landmark 22 is
  // behind pose 0 and 1, so that its bearings sit near +-pi and one noisy measurement wraps.
  std::vector<Eigen::Vector3d> x;
  for (int i = 0; i < 6; ++i) x.emplace_back(1.0 * i, 0.05 * i * i, 0.12 * i);
  std::vector<std::pair<std::int64_t, Eigen::Vector2d>> lms;
  lms.emplace_back(20, Eigen::Vector2d(2.0, 1.5));
  lms.emplace_back(21, Eigen::Vector2d(4.5, -1.0));
  lms.emplace_back(22, Eigen::Vector2d(-2.0, -0.05));
  const auto lm = [&](std::int64_t id) {
    for (const auto& [k, p] : lms) {
      if (k == id) return p;
    }
    FAIL("no landmark " << id);
    return Eigen::Vector2d(0, 0);
  };
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss(0.0, 1.0);
  Eigen::Matrix3d odo_info;
  odo_info << 2500, 40, 0, 40, 2500, 30, 0, 30, 10000;
  Eigen::Matrix2d rb_info;
  rb_info << 400, 30, 30, 2500;

  // The file, and beside it each factor's error at the true values (computed here) for its chi2.
  std::ostringstream text;
  text.precision(17);
  double chi2_truth = 0.0;
  for (int i = 0; i < 6; ++i) text << "VERTEX_SE2 " << i << " " << x[i].transpose() << "\n";
  for (const auto& [id, p] : lms) text << "VERTEX_XY " << id << " 0 0\n";
  for (int i = 0; i + 1 < 6; ++i) {
    const Eigen::Matrix3d rel = poseMatrix(x[i]).inverse() * poseMatrix(x[i + 1]);
    const Eigen::Vector3d z(rel(0, 2) + 0.02 * gauss(rng), rel(1, 2) + 0.02 * gauss(rng),
                            wrapped(std::atan2(rel(1, 0), rel(0, 0)) + 0.01 * gauss(rng)));
    text << "EDGE_SE2 " << i << " " << i + 1 << " " << z.transpose() << " " << odo_info(0, 0) << " "
         << odo_info(0, 1) << " " << odo_info(0, 2) << " " << odo_info(1, 1) << " "
         << odo_info(1, 2) << " " << odo_info(2, 2) << "\n";
    // g2o's EdgeSE2 error at the truth: (x, y, theta) of Z^-1 Xi^-1 Xj.
    const Eigen::Matrix3d err = poseMatrix(z).inverse() * rel;
    const Eigen::Vector3d e(err(0, 2), err(1, 2), std::atan2(err(1, 0), err(0, 0)));
    chi2_truth += e.dot(odo_info * e);
  }
  const std::vector<std::pair<int, std::int64_t>> observations = {
      {0, 20}, {0, 22}, {1, 20}, {1, 22}, {2, 20}, {2, 21}, {3, 21}, {4, 21}, {5, 21}, {5, 20}};
  bool wrapped_one = false;
  for (const auto& [i, id] : observations) {
    const Eigen::Vector3d local = poseMatrix(x[i]).inverse() * lm(id).homogeneous();
    const double true_bearing = std::atan2(local.y(), local.x());
    // Pose 0 sees landmark 22 at about -3.117: a -0.05 error takes it past -pi.
    const double noise = (i == 0 && id == 22) ? -0.05 : 0.01 * gauss(rng);
    const double range = local.head<2>().norm() + 0.03 * gauss(rng);
    const double bearing = wrapped(true_bearing + noise);
    wrapped_one = wrapped_one || bearing > 3.0;
    text << "EDGE_SE2_RANGE_BEARING " << i << " " << id << " " << range << " " << bearing << " "
         << rb_info(0, 0) << " " << rb_info(0, 1) << " " << rb_info(1, 1) << "\n";
    const Eigen::Vector2d e(local.head<2>().norm() - range, wrapped(true_bearing - bearing));
    chi2_truth += e.dot(rb_info * e);
  }
  REQUIRE(wrapped_one);

  const ModelDataset d = parse(text.str(), "rb.g2o");
  REQUIRE(d.factors.size() == 5 + observations.size());
  CHECK(countKind(d, FactorKind::RangeBearing2) == observations.size());

  // The objective of the file is the one computed above (range first, bearing wrapped).
  lslam::sim::ModelEstimate truth;
  for (int i = 0; i < 6; ++i) truth[pose(i)] = x[i];
  for (const auto& [id, p] : lms) truth[landmark(id)] = p;
  CHECK(lslam::sim::chi2(d, truth) == doctest::Approx(chi2_truth).epsilon(1e-9));

  lslam::sim::IncrementalOptions options;
  options.solver.backsubstitution_tolerance = 0.0;  // exact back-substitution
  const lslam::sim::ModelRun run = lslam::sim::runModelIncremental(d, options);
  CHECK(run.poses == 6);
  CHECK(run.landmarks == 3);
  REQUIRE(run.anchor == pose(0));
  // Landmark 22 enters at its first (wrapped) observation from pose 0, at the vertex's pose.
  REQUIRE(run.initial.count(landmark(22)) == 1);
  CHECK((run.initial.at(landmark(22)) - lm(22)).norm() < 0.2);

  lslam::sim::BatchOptions batch_options;
  batch_options.fixed.push_back(0);
  const lslam::sim::ModelBatchResult batch =
      lslam::sim::solveModelBatch(d, run.initial, batch_options);
  REQUIRE(batch.converged);
  const double chi2 = lslam::sim::chi2(d, run.estimate);
  CAPTURE(chi2);
  CAPTURE(batch.chi2);
  CAPTURE(chi2_truth);
  CHECK(batch.chi2 < chi2_truth);  // the optimum is below the truth's objective
  CHECK(std::abs(chi2 - batch.chi2) <= 1e-3 * batch.chi2);
  double worst = 0.0;
  for (const auto& [key, value] : run.estimate) {
    worst =
        std::max(worst, (value.head<2>() - batch.values.at(key).head<2>()).cwiseAbs().maxCoeff());
  }
  CHECK(worst < 1e-3);
}

// ---- real files ----

TEST_CASE("real files read with their published counts") {
  struct Expected {
    const char* file;
    std::size_t vertices;
    std::size_t factors;
  };
  for (const Expected& e :
       {Expected{"3d/sphere2500.g2o", 2500, 4949}, Expected{"3d/parking-garage.g2o", 1661, 6275},
        Expected{"3d/smallGrid3D.g2o", 125, 297}}) {
    const std::string path = datasetPath(e.file);
    if (!present(path)) continue;
    INFO(path);
    const ModelDataset d = lslam::sim::readModelDataset(path);
    CHECK(d.dimension == 3);
    CHECK(d.format == DatasetFormat::G2o);
    CHECK(d.vertices.size() == e.vertices);
    CHECK(d.factors.size() == e.factors);
    CHECK(countKind(d, FactorKind::BetweenSE3) == e.factors);
    expectSameContents(roundTrip(d), d);
  }
  {
    const std::string path = datasetPath("2d/victoriaPark.txt");
    if (present(path)) {
      const ModelDataset d = lslam::sim::readModelDataset(path);
      CHECK(d.dimension == 2);
      CHECK(d.format == DatasetFormat::Isam);
      CHECK(d.convention == ObjectiveConvention::Isam);
      CHECK(distinctLandmarks(d) == 151);
      CHECK(countKind(d, FactorKind::PointXY2) == 3640);
      CHECK(countKind(d, FactorKind::BetweenSE2) == 6968);
      // sqrt-information 100 / 500 / 500 and 1.581139 (landmarks).
      CHECK(d.factors[0].information(0, 0) == 1e4);
      CHECK(d.factors[0].information(2, 2) == 25e4);
    }
  }
  {
    const std::string path = datasetPath("3d/torus2000Points.txt");
    if (present(path)) {
      const ModelDataset d = lslam::sim::readModelDataset(path);
      CHECK(d.dimension == 3);
      CHECK(d.convention == ObjectiveConvention::Isam);
      CHECK(distinctLandmarks(d) == 20);
      CHECK(countKind(d, FactorKind::PointXYZ3) == 1039);
      CHECK(countKind(d, FactorKind::BetweenSE3) == 2034);
      // S = diag(20 20 100 | roll 200, pitch 200, yaw 100), in the order x y z yaw pitch roll.
      const Eigen::VectorXd expected =
          (Eigen::VectorXd(6) << 400, 400, 1e4, 1e4, 4e4, 4e4).finished();
      CHECK(d.factors[0].information == Eigen::MatrixXd(expected.asDiagonal()));
    }
  }
  for (const char* file : {"2d/intel.g2o", "2d/pose2example.txt", "3d/tinyGrid3D.g2o",
                           "3d/pose3example.txt", "groundtruth/city10000_groundtruth.txt"}) {
    const std::string path = datasetPath(file);
    if (!present(path)) continue;
    INFO(path);
    CHECK_NOTHROW(lslam::sim::readModelDataset(path));
  }
}

// The EDGE3 convention (roll pitch yaw in the file, R = Rz(yaw) Ry(pitch) Rx(roll)): the
// noise-free sphere2500 measurements composed along the odometry reproduce every loop closure.
TEST_CASE("EDGE3 convention: groundtruth/sphere2500 loop closures match its composed odometry") {
  const std::string path = datasetPath("groundtruth/sphere2500_groundtruth.txt");
  if (!present(path)) return;
  const ModelDataset d = lslam::sim::readModelDataset(path);
  REQUIRE(d.factors.size() == 4949);
  std::unordered_map<std::int64_t, Eigen::Isometry3d> poses;
  poses[0] = Eigen::Isometry3d::Identity();
  for (const ModelFactor& f : d.factors) {
    if (f.second.id == f.first.id + 1 && poses.count(f.first.id) && !poses.count(f.second.id)) {
      poses[f.second.id] = poses[f.first.id] * isometry(f.measurement);
    }
  }
  REQUIRE(poses.size() == 2500);
  double max_translation = 0.0;
  double max_angle = 0.0;
  std::size_t loops = 0;
  for (const ModelFactor& f : d.factors) {
    if (f.second.id == f.first.id + 1) continue;
    const Eigen::Isometry3d residual =
        isometry(f.measurement).inverse() * poses[f.first.id].inverse() * poses[f.second.id];
    max_translation = std::max(max_translation, residual.translation().norm());
    max_angle = std::max(max_angle, Eigen::AngleAxisd(residual.linear()).angle());
    ++loops;
  }
  CHECK(loops == 2450);
  MESSAGE("sphere2500 groundtruth loop closures: max translation residual "
          << max_translation << ", max rotation residual " << max_angle);
  // Print precision (6 digits) accumulated along up to 2500 odometry steps; a wrong convention
  // misses by metres (yaw-pitch-roll order: 163 m; X-Y-Z composition: 15 m).
  CHECK(max_translation < 1e-3);
  CHECK(max_angle < 1e-4);
}
