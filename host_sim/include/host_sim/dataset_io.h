#pragma once
// Readers for the 2D pose-graph file formats (g2o, TORO, iSAM) and a g2o writer. Host-only.
//
// Records (one per line; tokens separated by blanks or tabs; blank lines and lines whose first
// non-blank character is '#' are skipped):
//   g2o   VERTEX_SE2 id x y theta
//         EDGE_SE2 i j dx dy dtheta I11 I12 I13 I22 I23 I33   (upper triangle of the information)
//         FIX id [id ...]
//   TORO  VERTEX2 id x y theta
//         EDGE2 i j dx dy dtheta inf_xx inf_xy inf_yy inf_thth inf_xth inf_yth
//         (same information, different order from g2o)
//   iSAM  EDGE2 i j dx dy dtheta R11 R12 R13 R22 R23 R33
//         ODOMETRY i j dx dy dtheta R11 R12 R13 R22 R23 R33
//         (R = upper-triangular square-root information, row-major; information = R^T R)
// Edge2D::information is always the full symmetric 3x3 information matrix, whatever the file held.
//
// Format detection (when no format is given): each line's tag decides its format, and a file may
// not mix formats (the first supported record fixes the format of the file). The tag EDGE2 is
// both TORO and iSAM; it is resolved once per file:
//   - TORO if the file has a VERTEX2 line, or a '#' comment line, or its name ends in ".graph";
//   - iSAM otherwise (e.g. the edges-only iSAM "*.txt" files).
// Use the overloads taking a DatasetFormat to override the rule (then only that format's records
// are accepted). A file with no records is G2o (Toro for a ".graph" name) unless a format is given.
//
// Errors: every malformed line throws DatasetError(file, line, reason) with a 1-based line number:
// wrong number of fields ("expected 12 fields, got 7"), trailing fields, a field that is not a
// number (strict: the whole token must parse, "1.5abc" and "0x10" are errors), NaN/Inf, values
// out of the range of a double ("1e400"), a position or translation (x, y, dx, dy) beyond the
// solver's coordinate range (|value| <= lslam::kMaxCoordinate, 1e9 m), ids that are not integers, negative or > 2^31-1 ("id out
// of range"), an edge from a pose to itself, a vertex id defined twice, records of another format
// than the file's, unsupported records (2D landmarks, 3D records, unknown tags), e.g.
//   "unsupported record 'LANDMARK' (2D landmarks are not supported yet)",
// and an information matrix that is not positive definite (Eigen's Cholesky factorization fails:
// a zero, negative, indefinite or singular matrix; for iSAM an R with a zero on its diagonal).
// Tokens quoted in a reason show non-printable bytes as \xNN. A file with VERTEX lines declares its
// poses: an edge or FIX naming an id that no vertex line declares throws at the edge's (FIX's)
// line, the earliest such line of the file (vertices may come after the edges that use them);
// files without vertex lines (iSAM) need no declarations.
// A file that cannot be opened or read throws DatasetError(path, 0, reason).
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "host_sim/dataset.h"

namespace lslam::sim {

// "g2o", "TORO" or "iSAM".
const char* formatName(DatasetFormat format);

// Reads a file; Dataset2D::name is `path` as given. Format detected as described above.
Dataset2D readDataset2D(const std::string& path);
// Reads a file as the given format (no detection).
Dataset2D readDataset2D(const std::string& path, DatasetFormat format);

// Parses a stream; `name` is used in error messages, as Dataset2D::name and (its extension) for
// format detection.
Dataset2D parseDataset2D(std::istream& in, const std::string& name);
Dataset2D parseDataset2D(std::istream& in, const std::string& name, DatasetFormat format);

// Writes VERTEX_SE2 lines (given order), then one "FIX id" line per fixed id, then EDGE_SE2 lines
// (given order, information as its upper triangle I11 I12 I13 I22 I23 I33). Numbers are written
// in the shortest form that reads back to the identical double (std::to_chars), so write -> read
// is exact; the file loads in g2o and GTSAM's readG2o. Throws std::invalid_argument (before
// writing anything) for a non-finite value, a position or translation beyond the coordinate range
// (as the readers), an id outside 0..2^31-1, an edge with from == to or
// an information whose upper triangle (the symmetric matrix written) is not positive definite,
// which the readers would reject; std::runtime_error if the stream fails.
void writeG2o(std::ostream& out, const std::vector<Vertex2D>& vertices,
              const std::vector<Edge2D>& edges, const std::vector<std::int64_t>& fixed);
// Same for a whole dataset (its vertices, edges and fixed ids).
void writeG2o(std::ostream& out, const Dataset2D& dataset);
// Writes the dataset to a file (std::runtime_error if the file cannot be written).
void writeG2oFile(const std::string& path, const Dataset2D& dataset);

}  // namespace lslam::sim
