#include "host_sim/dataset_io.h"

#include <Eigen/Eigenvalues>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <istream>
#include <limits>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string_view>
#include <unordered_map>

#include "lslam/factors/information.h"
#include "lslam/geometry/coordinate_range.h"
#include "record_parsing.h"

namespace lslam::sim {

namespace {

using parsing::appendNumber;
using parsing::FieldParser;
using parsing::formatDouble;
using parsing::kMaxId;
using parsing::show;

// The record kinds the readers know. Edge2 is resolved to TORO or iSAM per file.
enum class Tag { VertexSE2, EdgeSE2, Fix, Vertex2, Edge2, Odometry, Other };

Tag classify(std::string_view tag) {
  if (tag == "VERTEX_SE2") return Tag::VertexSE2;
  if (tag == "EDGE_SE2") return Tag::EdgeSE2;
  if (tag == "FIX") return Tag::Fix;
  if (tag == "VERTEX2") return Tag::Vertex2;
  if (tag == "EDGE2") return Tag::Edge2;
  if (tag == "ODOMETRY") return Tag::Odometry;
  return Tag::Other;
}

bool contains(std::string_view s, std::string_view part) {
  return s.find(part) != std::string_view::npos;
}

// Reason for a tag that is not a supported 2D pose record (the tag escaped: it may be binary).
std::string unsupportedReason(std::string_view tag) {
  const std::string quoted = show(tag);
  const bool is_3d = contains(tag, "SE3") || contains(tag, "XYZ") || tag == "EDGE3" ||
                     tag == "VERTEX3" || tag == "POINT3" || tag == "POSE3";
  if (is_3d) return "unsupported record " + quoted + " (3D records are not supported)";
  const bool is_landmark = tag == "LANDMARK" || tag == "POINT2" || contains(tag, "_XY") ||
                           contains(tag, "POINTXY") || contains(tag, "BEARING");
  if (is_landmark) {
    return "unsupported record " + quoted + " (2D landmarks are not supported yet)";
  }
  return "unknown record " + quoted +
         " (expected g2o VERTEX_SE2/EDGE_SE2/FIX, TORO VERTEX2/EDGE2 or iSAM EDGE2/ODOMETRY)";
}

using Record = parsing::TaggedRecord<Tag>;

// The information must be symmetric positive definite (the solvers factorize it): the solver's
// own check, so that the reader rejects, with its line, exactly what the solver would.
bool isPositiveDefinite(const Eigen::Matrix3d& m) {
  return lslam::checkInformation(m) == lslam::Status::Ok;
}

std::string smallestEigenvalueText(const Eigen::Matrix3d& m) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(m, Eigen::EigenvaluesOnly);
  if (eig.info() != Eigen::Success) return "eigenvalues not computable";
  return "smallest eigenvalue " + formatDouble(eig.eigenvalues().minCoeff());
}

constexpr std::array<const char*, 6> kInfoFieldsG2o = {"I11", "I12", "I13", "I22", "I23", "I33"};
constexpr std::array<const char*, 6> kInfoFieldsToro = {"inf_ff", "inf_fs", "inf_ss",
                                                        "inf_rr", "inf_fr", "inf_sr"};
constexpr std::array<const char*, 6> kInfoFieldsIsam = {"R11", "R12", "R13", "R22", "R23", "R33"};

Vertex2D parseVertex(const std::string& file, const Record& r) {
  const FieldParser p(file, r.line, r.tokens);
  p.expectFields(5);
  Vertex2D v;
  v.id = p.id(1, "id");
  v.pose.x = p.coordinate(2, "x");
  v.pose.y = p.coordinate(3, "y");
  v.pose.theta = p.number(4, "theta");
  v.line = r.line;
  return v;
}

// EDGE_SE2 / EDGE2 / ODOMETRY: i j dx dy dth + 6 matrix entries, interpreted per `format`.
Edge2D parseEdge(const std::string& file, const Record& r, DatasetFormat format) {
  const FieldParser p(file, r.line, r.tokens);
  p.expectFields(12);
  Edge2D e;
  e.from = p.id(1, "from");
  e.to = p.id(2, "to");
  e.measurement.x = p.coordinate(3, "dx");
  e.measurement.y = p.coordinate(4, "dy");
  e.measurement.theta = p.number(5, "dtheta");
  const auto& names = format == DatasetFormat::G2o    ? kInfoFieldsG2o
                      : format == DatasetFormat::Toro ? kInfoFieldsToro
                                                      : kInfoFieldsIsam;
  std::array<double, 6> a{};
  for (std::size_t k = 0; k < 6; ++k) a[k] = p.number(6 + k, names[k]);
  if (e.from == e.to) {
    p.fail(std::string(r.tokens[0]) + ": edge from pose " + std::to_string(e.from) +
           " to itself (from == to)");
  }
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  switch (format) {
    case DatasetFormat::G2o:  // I11 I12 I13 I22 I23 I33
      m << a[0], a[1], a[2],  //
          a[1], a[3], a[4],   //
          a[2], a[4], a[5];
      break;
    case DatasetFormat::Toro:  // xx xy yy thth xth yth
      m << a[0], a[1], a[4],   //
          a[1], a[2], a[5],    //
          a[4], a[5], a[3];
      break;
    case DatasetFormat::Isam: {  // R (upper triangular, row-major), information = R^T R
      const double sr[3][3] = {{a[0], a[1], a[2]}, {0.0, a[3], a[4]}, {0.0, 0.0, a[5]}};
      for (int i = 0; i < 3; ++i) {
        for (int j = i; j < 3; ++j) {
          double sum = 0.0;
          for (int k = 0; k <= i; ++k) sum += sr[k][i] * sr[k][j];  // R(k,i) = 0 for k > i
          m(i, j) = sum;
          m(j, i) = sum;
        }
      }
      if (!m.allFinite()) p.fail("information R^T R overflows (square-root information too large)");
      break;
    }
  }
  if (!isPositiveDefinite(m)) {
    std::string reason = std::string(r.tokens[0]) + ": information matrix is not positive definite";
    if (format == DatasetFormat::Isam) {
      // R^T R is singular exactly when R (triangular) has a zero on its diagonal; otherwise the
      // product under- or overflowed.
      std::string zeros;
      for (std::size_t k : {0u, 3u, 5u}) {
        if (a[k] == 0.0) zeros += std::string(zeros.empty() ? "" : ", ") + names[k] + " = 0";
      }
      reason += " (information = R^T R; " +
                (zeros.empty() ? std::string("R^T R underflows or loses rank in rounding")
                               : "square-root information R is singular: " + zeros) +
                "; " + smallestEigenvalueText(m) + ")";
    } else {
      reason += " (" + smallestEigenvalueText(m) + ")";
    }
    p.fail(reason);
  }
  e.information = m;
  e.line = r.line;
  return e;
}

// The format a record belongs to (Tag::Edge2 resolved with `edge2`); nullopt for Tag::Other.
std::optional<DatasetFormat> recordFormat(Tag tag, DatasetFormat edge2) {
  switch (tag) {
    case Tag::VertexSE2:
    case Tag::EdgeSE2:
    case Tag::Fix:
      return DatasetFormat::G2o;
    case Tag::Vertex2:
      return DatasetFormat::Toro;
    case Tag::Odometry:
      return DatasetFormat::Isam;
    case Tag::Edge2:
      return edge2;
    case Tag::Other:
      break;
  }
  return std::nullopt;
}

// A file with vertex lines declares its poses: every id an edge or a FIX names must be one of
// them. Vertices may come after the edges, so this runs after the whole file was read; it reports
// the earliest offending line. Files without vertex lines (iSAM) declare nothing.
void checkDeclared(const Dataset2D& d,
                   const std::unordered_map<std::int64_t, std::size_t>& vertex_line) {
  if (d.vertices.empty()) return;
  const std::string vertex_tag = d.format == DatasetFormat::Toro ? "VERTEX2" : "VERTEX_SE2";
  const auto declared = [&](std::int64_t id) { return vertex_line.count(id) != 0; };
  std::size_t bad_line = 0;
  std::string reason;
  for (const Edge2D& e : d.edges) {
    if (declared(e.from) && declared(e.to)) continue;
    const std::int64_t id = declared(e.from) ? e.to : e.from;
    bad_line = e.line;
    reason = "edge " + std::to_string(e.from) + " -> " + std::to_string(e.to) + " names pose " +
             std::to_string(id) + ", which no " + vertex_tag + " line declares";
    break;  // edges are in file order: the first is the earliest
  }
  for (const FixedPose& f : d.fixed) {
    if (declared(f.id) || (bad_line != 0 && f.line >= bad_line)) continue;
    bad_line = f.line;
    reason =
        "FIX names pose " + std::to_string(f.id) + ", which no " + vertex_tag + " line declares";
    break;
  }
  if (!reason.empty()) throw DatasetError(d.name, bad_line, reason);
}

Dataset2D parseImpl(std::istream& in, const std::string& name,
                    std::optional<DatasetFormat> forced) {
  const auto file = parsing::scanFile<Tag>(in, name, classify);

  // EDGE2 resolution (see the header); a forced format decides by itself.
  DatasetFormat edge2 = file.edge2Format();
  if (forced) edge2 = *forced == DatasetFormat::G2o ? DatasetFormat::G2o : *forced;

  Dataset2D d;
  d.name = name;
  d.format = forced ? *forced : (file.has_graph_name ? DatasetFormat::Toro : DatasetFormat::G2o);
  std::size_t format_line = 0;  // line of the record that fixed the format (0: forced/none yet)
  bool format_known = forced.has_value();

  std::unordered_map<std::int64_t, std::size_t> vertex_line;  // id -> line of its definition
  for (const Record& r : file.records) {
    if (r.tag == Tag::Other) throw DatasetError(name, r.line, unsupportedReason(r.tokens[0]));
    DatasetFormat f = *recordFormat(r.tag, edge2);
    if (forced && r.tag == Tag::Edge2 && *forced == DatasetFormat::G2o) {
      throw DatasetError(name, r.line, "record 'EDGE2' is not a g2o record (file read as g2o)");
    }
    if (!format_known) {
      d.format = f;
      format_line = r.line;
      format_known = true;
    } else if (f != d.format) {
      std::string reason = "record '" + std::string(r.tokens[0]) + "' is a " + formatName(f) +
                           " record, but the file is read as " + formatName(d.format);
      if (format_line > 0) {
        reason += " (first " + std::string(formatName(d.format)) + " record at line " +
                  std::to_string(format_line) + ")";
      } else {
        reason += " (format given explicitly)";
      }
      throw DatasetError(name, r.line, reason);
    }

    switch (r.tag) {
      case Tag::VertexSE2:
      case Tag::Vertex2: {
        Vertex2D v = parseVertex(name, r);
        const auto [it, inserted] = vertex_line.emplace(v.id, v.line);
        if (!inserted) {
          throw DatasetError(name, r.line,
                             std::string(r.tokens[0]) + ": duplicate vertex id " +
                                 std::to_string(v.id) + " (first defined at line " +
                                 std::to_string(it->second) + ")");
        }
        d.vertices.push_back(v);
        break;
      }
      case Tag::EdgeSE2:
      case Tag::Edge2:
      case Tag::Odometry:
        d.edges.push_back(parseEdge(name, r, f));
        break;
      case Tag::Fix: {
        const FieldParser p(name, r.line, r.tokens);
        if (r.tokens.size() < 2) p.fail("FIX: expected at least 2 fields, got 1 (no id)");
        for (std::size_t k = 1; k < r.tokens.size(); ++k) {
          d.fixed.push_back(FixedPose{p.id(k, "id"), r.line});
        }
        break;
      }
      case Tag::Other:
        break;
    }
  }
  checkDeclared(d, vertex_line);
  return d;
}

Dataset2D readImpl(const std::string& path, std::optional<DatasetFormat> forced) {
  std::ifstream in = parsing::openDatasetFile(path);
  return parseImpl(in, path, forced);
}

// ---- writer ----

void appendId(std::string& out, std::int64_t v) {
  out += std::to_string(v);
}

void checkId(std::int64_t id, const std::string& what) {
  if (id < 0 || id > kMaxId) {
    throw std::invalid_argument("writeG2o: " + what + ": id " + std::to_string(id) +
                                " out of range (0.." + std::to_string(kMaxId) + ")");
  }
}

void checkFinite(double v, const std::string& what) {
  if (!std::isfinite(v)) throw std::invalid_argument("writeG2o: " + what + ": non-finite value");
}

// A position or translation coordinate: finite and within the readers' coordinate range.
void checkCoordinate(double v, const std::string& what) {
  checkFinite(v, what);
  if (!withinCoordinateRange(v)) {
    throw std::invalid_argument("writeG2o: " + what + ": " +
                                parsing::beyondCoordinateRange("coordinate " + formatDouble(v)));
  }
}

}  // namespace

const char* formatName(DatasetFormat format) {
  switch (format) {
    case DatasetFormat::G2o:
      return "g2o";
    case DatasetFormat::Toro:
      return "TORO";
    case DatasetFormat::Isam:
      return "iSAM";
  }
  return "unknown";
}

Dataset2D readDataset2D(const std::string& path) {
  return readImpl(path, std::nullopt);
}

Dataset2D readDataset2D(const std::string& path, DatasetFormat format) {
  return readImpl(path, format);
}

Dataset2D parseDataset2D(std::istream& in, const std::string& name) {
  return parseImpl(in, name, std::nullopt);
}

Dataset2D parseDataset2D(std::istream& in, const std::string& name, DatasetFormat format) {
  return parseImpl(in, name, format);
}

void writeG2o(std::ostream& out, const std::vector<Vertex2D>& vertices,
              const std::vector<Edge2D>& edges, const std::vector<std::int64_t>& fixed) {
  // Validate everything first so that nothing is written for bad input.
  for (std::size_t k = 0; k < vertices.size(); ++k) {
    const Vertex2D& v = vertices[k];
    const std::string what = "vertex #" + std::to_string(k) + " (id " + std::to_string(v.id) + ")";
    checkId(v.id, what);
    checkCoordinate(v.pose.x, what);
    checkCoordinate(v.pose.y, what);
    checkFinite(v.pose.theta, what);
  }
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const Edge2D& e = edges[k];
    const std::string what = "edge #" + std::to_string(k) + " (" + std::to_string(e.from) + "->" +
                             std::to_string(e.to) + ")";
    checkId(e.from, what);
    checkId(e.to, what);
    if (e.from == e.to) throw std::invalid_argument("writeG2o: " + what + ": from == to");
    checkCoordinate(e.measurement.x, what);
    checkCoordinate(e.measurement.y, what);
    checkFinite(e.measurement.theta, what);
    if (!e.information.allFinite()) {
      throw std::invalid_argument("writeG2o: " + what + ": non-finite information");
    }
    // What is written is the upper triangle, read back as a symmetric matrix.
    const Eigen::Matrix3d& m = e.information;
    Eigen::Matrix3d written;
    written << m(0, 0), m(0, 1), m(0, 2),  //
        m(0, 1), m(1, 1), m(1, 2),         //
        m(0, 2), m(1, 2), m(2, 2);
    if (!isPositiveDefinite(written)) {
      throw std::invalid_argument("writeG2o: " + what +
                                  ": information (upper triangle) is not positive definite");
    }
  }
  for (std::int64_t id : fixed) checkId(id, "FIX");

  std::string buf;
  buf.reserve(128);
  for (const Vertex2D& v : vertices) {
    buf = "VERTEX_SE2 ";
    appendId(buf, v.id);
    for (double x : {v.pose.x, v.pose.y, v.pose.theta}) {
      buf += ' ';
      appendNumber(buf, x);
    }
    buf += '\n';
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  }
  for (std::int64_t id : fixed) {
    buf = "FIX ";
    appendId(buf, id);
    buf += '\n';
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  }
  for (const Edge2D& e : edges) {
    buf = "EDGE_SE2 ";
    appendId(buf, e.from);
    buf += ' ';
    appendId(buf, e.to);
    const Eigen::Matrix3d& m = e.information;
    for (double x : {e.measurement.x, e.measurement.y, e.measurement.theta, m(0, 0), m(0, 1),
                     m(0, 2), m(1, 1), m(1, 2), m(2, 2)}) {
      buf += ' ';
      appendNumber(buf, x);
    }
    buf += '\n';
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  }
  if (!out) throw std::runtime_error("writeG2o: stream write failed");
}

void writeG2o(std::ostream& out, const Dataset2D& dataset) {
  std::vector<std::int64_t> fixed;
  for (const FixedPose& f : dataset.fixed) fixed.push_back(f.id);
  writeG2o(out, dataset.vertices, dataset.edges, fixed);
}

void writeG2oFile(const std::string& path, const Dataset2D& dataset) {
  std::ofstream out(path, std::ios::out | std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error("writeG2oFile: cannot open '" + path + "' for writing");
  writeG2o(out, dataset);
  out.flush();
  if (!out) throw std::runtime_error("writeG2oFile: write to '" + path + "' failed");
}

}  // namespace lslam::sim
