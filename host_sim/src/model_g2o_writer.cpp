#include "host_sim/model_dataset_io.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <ostream>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <utility>

#include "lslam/geometry/coordinate_range.h"
#include "model_records.h"
#include "record_parsing.h"

namespace lslam::sim {

namespace {

using parsing::appendNumber;
using parsing::formatDouble;
using parsing::kMaxId;
using records::factorTag;
using records::isPositiveDefinite;
using records::rangeBearingProblem;
using records::vertexTag;

[[noreturn]] void reject(const std::string& what, const std::string& why) {
  throw std::invalid_argument("writeModelG2o: " + what + ": " + why);
}

void checkId(std::int64_t id, const std::string& what) {
  if (id < 0 || id > kMaxId) {
    reject(what, "id " + std::to_string(id) + " out of range (0.." + std::to_string(kMaxId) + ")");
  }
}

// The values of a `kind` (a vertex's, or the measurement of a factor that predicts one): their
// count, finite, the position (the first dimensionOf(kind) values) within the readers' coordinate
// range, and a unit quaternion for SE3.
void checkValues(const Eigen::VectorXd& v, VariableKind kind, const std::string& what) {
  const Eigen::Index size = parameterCount(kind);
  if (v.size() != size) {
    reject(what, std::to_string(v.size()) + " values, expected " + std::to_string(size));
  }
  if (!v.allFinite()) reject(what, "non-finite value");
  const auto position = v.head(dimensionOf(kind));
  if (checkCoordinates(position) != Status::Ok) {
    reject(what, parsing::beyondCoordinateRange("coordinate " +
                                                formatDouble(position.cwiseAbs().maxCoeff())));
  }
  const bool has_quaternion = kind == VariableKind::SE3;
  if (has_quaternion) {
    const double norm = v.tail<4>().norm();
    if (!(std::abs(norm - 1.0) <= kQuaternionNormTolerance)) {
      reject(what, "quaternion norm " + formatDouble(norm) + " is not 1 (tolerance " +
                       formatDouble(kQuaternionNormTolerance) + ")");
    }
  }
}

// Validates everything the reader would reject or read back differently (see the header).
void validate(const ModelDataset& d) {
  if (d.dimension != 2 && d.dimension != 3) {
    reject("dataset", "dimension " + std::to_string(d.dimension) + " is not 2 or 3");
  }
  std::unordered_map<std::int64_t, std::size_t> vertex_index;
  for (std::size_t k = 0; k < d.vertices.size(); ++k) {
    const ModelVertex& v = d.vertices[k];
    const std::string what = "vertex #" + std::to_string(k) + " (id " + std::to_string(v.key.id) +
                             ", " + variableKindName(v.kind) + ")";
    checkId(v.key.id, what);
    if (v.key.role != roleOf(v.kind)) {
      reject(what, std::string("a ") + variableKindName(v.kind) + " must have the role " +
                       roleName(roleOf(v.kind)));
    }
    if (dimensionOf(v.kind) != d.dimension) {
      reject(what, "not a " + std::to_string(d.dimension) + "D variable (dataset dimension)");
    }
    checkValues(v.value, v.kind, what);
    if (!vertex_index.emplace(v.key.id, k).second) {
      reject(what, "duplicate vertex id (poses and landmarks share one g2o id space)");
    }
  }
  std::unordered_map<std::int64_t, VariableRole> used;  // edge-only: each id's role
  for (std::size_t k = 0; k < d.factors.size(); ++k) {
    const ModelFactor& f = d.factors[k];
    const std::string what = "factor #" + std::to_string(k) + " (" + factorKindName(f.kind) + " " +
                             std::to_string(f.first.id) + " -> " + std::to_string(f.second.id) +
                             ")";
    const bool writable = f.kind == FactorKind::BetweenSE2 || f.kind == FactorKind::PointXY2 ||
                          f.kind == FactorKind::RangeBearing2 || f.kind == FactorKind::BetweenSE3 ||
                          f.kind == FactorKind::PointXYZ3;
    if (!writable) reject(what, "no g2o record is written for this factor kind");
    const auto [kind1, kind2] = endpointKinds(f.kind);
    if (dimensionOf(kind1) != d.dimension) {
      reject(what, "not a " + std::to_string(d.dimension) + "D factor (dataset dimension)");
    }
    if (f.kind == FactorKind::BetweenSE3 && d.convention == ObjectiveConvention::Isam) {
      reject(what,
             "the dataset has the iSAM convention: its SE3 information is in Euler coordinates, "
             "not g2o's");
    }
    checkId(f.first.id, what);
    checkId(f.second.id, what);
    if (f.first.role != roleOf(kind1) || f.second.role != roleOf(kind2)) {
      reject(what, std::string("keys must be a ") + roleName(roleOf(kind1)) + " and a " +
                       roleName(roleOf(kind2)));
    }
    if (f.first.id == f.second.id) {
      reject(what, "both ids are equal (g2o ids are one space; no edge from a pose to itself)");
    }
    checkValues(f.measurement, kind2, what + " measurement");  // the kind it predicts
    if (f.kind == FactorKind::RangeBearing2) {
      const std::string why = rangeBearingProblem(f.measurement[0], f.measurement[1]);
      if (!why.empty()) reject(what + " measurement", why);
    }
    const Eigen::Index n = errorDimension(f.kind);
    if (f.information.rows() != n || f.information.cols() != n) {
      reject(what, "information is " + std::to_string(f.information.rows()) + "x" +
                       std::to_string(f.information.cols()) + ", expected " + std::to_string(n) +
                       "x" + std::to_string(n));
    }
    if (!f.information.allFinite()) reject(what, "non-finite information");
    // What is written is the upper triangle, read back as a symmetric matrix.
    Eigen::MatrixXd written = f.information;
    for (Eigen::Index a = 0; a < n; ++a) {
      for (Eigen::Index b = 0; b < a; ++b) written(a, b) = written(b, a);
    }
    if (!isPositiveDefinite(written)) {
      reject(what, "information (upper triangle) is not positive definite");
    }
    for (const auto& [key, kind] : {std::pair{f.first, kind1}, std::pair{f.second, kind2}}) {
      if (!d.vertices.empty()) {
        const auto it = vertex_index.find(key.id);
        if (it == vertex_index.end() || d.vertices[it->second].kind != kind) {
          reject(what, std::string("id ") + std::to_string(key.id) + " is not declared by a " +
                           variableKindName(kind) + " vertex");
        }
      } else {
        const auto [it, inserted] = used.emplace(key.id, key.role);
        if (!inserted && it->second != key.role) {
          reject(what, "id " + std::to_string(key.id) +
                           " is used both as a pose and as a landmark (g2o ids are one space)");
        }
      }
    }
  }
  for (const VariableKey& key : d.fixed) {
    const std::string what = "fixed key " + std::to_string(key.id);
    checkId(key.id, what);
    VariableRole role = VariableRole::Pose;  // the role the reader gives this FIX
    if (!d.vertices.empty()) {
      const auto it = vertex_index.find(key.id);
      if (it == vertex_index.end()) reject(what, "no vertex has this id");
      role = d.vertices[it->second].key.role;
    } else if (const auto u = used.find(key.id); u != used.end()) {
      role = u->second;
    }
    if (key.role != role) {
      reject(what, std::string("would read back as a ") + roleName(role) + ", not a " +
                       roleName(key.role));
    }
  }
}

void appendValues(std::string& buf, const Eigen::VectorXd& v) {
  for (Eigen::Index k = 0; k < v.size(); ++k) {
    buf += ' ';
    appendNumber(buf, v[k]);
  }
}

}  // namespace

void writeModelG2o(std::ostream& out, const ModelDataset& d) {
  validate(d);  // before anything is written

  std::string buf;
  buf.reserve(256);
  const auto flush = [&] {
    buf += '\n';
    out.write(buf.data(), static_cast<std::streamsize>(buf.size()));
  };
  const bool has_points3 =
      std::any_of(d.factors.begin(), d.factors.end(),
                  [](const ModelFactor& f) { return f.kind == FactorKind::PointXYZ3; });
  if (has_points3) {
    buf = "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1";  // the identity sensor offset the edges name
    flush();
  }
  for (const ModelVertex& v : d.vertices) {
    buf = vertexTag(v.kind, DatasetFormat::G2o);
    buf += ' ';
    buf += std::to_string(v.key.id);
    appendValues(buf, v.value);
    flush();
  }
  for (const VariableKey& key : d.fixed) {
    buf = "FIX " + std::to_string(key.id);
    flush();
  }
  for (const ModelFactor& f : d.factors) {
    buf = factorTag(f.kind, DatasetFormat::G2o);
    buf += ' ';
    buf += std::to_string(f.first.id);
    buf += ' ';
    buf += std::to_string(f.second.id);
    if (f.kind == FactorKind::PointXYZ3) buf += " 0";
    appendValues(buf, f.measurement);
    const Eigen::MatrixXd& m = f.information;
    for (Eigen::Index a = 0; a < m.rows(); ++a) {
      for (Eigen::Index b = a; b < m.cols(); ++b) {
        buf += ' ';
        appendNumber(buf, m(a, b));
      }
    }
    flush();
  }
  if (!out) throw std::runtime_error("writeModelG2o: stream write failed");
}

void writeModelG2oFile(const std::string& path, const ModelDataset& d) {
  validate(d);  // before the file is created or truncated
  std::ofstream out(path, std::ios::out | std::ios::binary | std::ios::trunc);
  if (!out) throw std::runtime_error("writeModelG2oFile: cannot open '" + path + "' for writing");
  writeModelG2o(out, d);
  out.flush();
  if (!out) throw std::runtime_error("writeModelG2oFile: write to '" + path + "' failed");
}

}  // namespace lslam::sim
