// Tests of the 2D dataset readers and the g2o writer (host_sim/dataset_io.h): every malformed-line
// case of the three formats throws DatasetError with its 1-based line and a reason that names the
// problem; the three formats read one hand-written graph to the same measurements and information
// (the iSAM square-root information computed here with Eigen, independently of the reader); format
// detection; writeG2o -> parseDataset2D is bit-exact; random single-token corruptions never crash.
// Also the command-line helpers of lslam-sim (host_sim/cli_args.h).
#include <doctest/doctest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <optional>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "host_sim/cli_args.h"
#include "host_sim/dataset_io.h"
#include "lslam/geometry/coordinate_range.h"

using lslam::sim::Dataset2D;
using lslam::sim::DatasetError;
using lslam::sim::DatasetFormat;
using lslam::sim::Edge2D;
using lslam::sim::FixedPose;
using lslam::sim::parseDataset2D;
using lslam::sim::Vertex2D;
using lslam::sim::writeG2o;
using namespace std::string_literals;

namespace {

using Lines = std::vector<std::string>;

std::string join(const Lines& lines) {
  std::string text;
  for (const std::string& l : lines) text += l + "\n";
  return text;
}

Dataset2D parse(const std::string& text, const std::string& name,
                std::optional<DatasetFormat> format = std::nullopt) {
  std::istringstream in(text);
  return format ? parseDataset2D(in, name, *format) : parseDataset2D(in, name);
}

// The DatasetError that parsing `text` throws; nullopt if it parses. Any other exception escapes
// (and fails the test case).
std::optional<DatasetError> parseError(const std::string& text, const std::string& name,
                                       std::optional<DatasetFormat> format = std::nullopt) {
  try {
    parse(text, name, format);
  } catch (const DatasetError& e) {
    return e;
  }
  return std::nullopt;
}

bool printable(const std::string& s) {
  for (const char c : s) {
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) >= 0x7f) return false;
  }
  return true;
}

// Parsing must throw DatasetError at `line` with a printable reason containing every fragment.
void expectError(const std::string& text, const std::string& name, std::size_t line,
                 const std::vector<std::string>& fragments,
                 std::optional<DatasetFormat> format = std::nullopt) {
  const std::optional<DatasetError> e = parseError(text, name, format);
  REQUIRE_MESSAGE(e.has_value(), "no DatasetError for:\n" << text);
  INFO("reason: " << e->reason());
  CHECK(e->file() == name);
  CHECK(e->line() == line);
  CHECK_FALSE(e->reason().empty());
  CHECK(printable(e->reason()));
  CHECK(std::string(e->what()) == name + ":" + std::to_string(line) + ": " + e->reason());
  for (const std::string& f : fragments) {
    CHECK_MESSAGE(e->reason().find(f) != std::string::npos, "missing '" << f << "'");
  }
}

// ---- the three formats ----

struct Format {
  const char* label;
  std::string file_name;
  std::string vertex_tag;  // empty: no vertex records (iSAM)
  std::string edge_tag;
  bool comments;  // '#' comment lines keep the format (they would make an iSAM EDGE2 file TORO)
};

const Format kG2o{"g2o", "t.g2o", "VERTEX_SE2", "EDGE_SE2", true};
const Format kToro{"TORO", "t.graph", "VERTEX2", "EDGE2", true};
const Format kIsam{"iSAM", "t.txt", "", "EDGE2", false};
const Format kIsamOdometry{"iSAM ODOMETRY", "t.txt", "", "ODOMETRY", false};

std::string vertexLine(const Format& f, int id) {
  return f.vertex_tag + " " + std::to_string(id) + " " + std::to_string(id) + ".5 -2 0.25";
}

// An edge with identity information (in the format's layout) as fields 1..11.
Lines edgeFields(const Format& f, int from, int to) {
  Lines fields = {std::to_string(from), std::to_string(to), "1", "0.5", "0.1"};
  const bool toro = f.label == std::string("TORO");  // xx xy yy thth xth yth
  const Lines identity =
      toro ? Lines{"1", "0", "1", "1", "0", "0"} : Lines{"1", "0", "0", "1", "0", "1"};
  fields.insert(fields.end(), identity.begin(), identity.end());
  return fields;
}

std::string edgeLine(const Format& f, const Lines& fields) {
  std::string s = f.edge_tag;
  for (const std::string& t : fields) s += " " + t;
  return s;
}

std::string edgeLine(const Format& f, int from, int to) {
  return edgeLine(f, edgeFields(f, from, to));
}

// Prefixes put before the bad line (poses 0..3, declared in the prefix or in the suffix), so that
// the bad line is line 1, after a few good lines, or after good, comment and blank lines.
std::vector<Lines> prefixes(const Format& f) {
  if (f.vertex_tag.empty()) {
    return {{}, {edgeLine(f, 0, 1), edgeLine(f, 1, 2)}, {"", edgeLine(f, 0, 1), " \t ", ""}};
  }
  return {{},
          {vertexLine(f, 0), vertexLine(f, 1), vertexLine(f, 2), vertexLine(f, 3)},
          {"# a comment", "", vertexLine(f, 0), "  \t", vertexLine(f, 1), "#", vertexLine(f, 2),
           vertexLine(f, 3), edgeLine(f, 0, 1), "   # indented comment"}};
}

Lines suffix(const Format& f, const Lines& prefix) {
  Lines s;
  if (!f.vertex_tag.empty() && prefix.empty()) {
    for (int id = 0; id < 4; ++id) s.push_back(vertexLine(f, id));
  }
  s.push_back(edgeLine(f, 2, 3));
  s.push_back(edgeLine(f, 1, 3));
  return s;
}

struct BadLine {
  std::string line;
  std::vector<std::string> fragments;
  bool needs_records_before = false;  // the first record fixes the format: not at line 1
};

// Places `bad` after each prefix (and good lines after it) and checks the error's line.
void checkAtEveryPosition(const Format& f, const BadLine& bad) {
  for (const Lines& prefix : prefixes(f)) {
    if (bad.needs_records_before && prefix.empty()) continue;
    Lines lines = prefix;
    lines.push_back(bad.line);
    for (const std::string& s : suffix(f, prefix)) lines.push_back(s);
    CAPTURE(bad.line);
    CAPTURE(prefix.size());
    expectError(join(lines), f.file_name, prefix.size() + 1, bad.fragments);
  }
}

// Field k (1-based, the tag is 0) of a good edge replaced by `token`.
std::string edgeWith(const Format& f, std::size_t k, const std::string& token) {
  Lines fields = edgeFields(f, 0, 1);
  fields[k - 1] = token;
  return edgeLine(f, fields);
}

std::vector<BadLine> edgeCases(const Format& f) {
  const std::string& t = f.edge_tag;
  std::vector<BadLine> cases;
  // Truncated: every shorter line, down to the tag alone.
  Lines fields = edgeFields(f, 0, 1);
  for (std::size_t n = 0; n < fields.size(); ++n) {
    const Lines head(fields.begin(), fields.begin() + static_cast<std::ptrdiff_t>(n));
    cases.push_back(
        {edgeLine(f, head), {t, "expected 12 fields, got " + std::to_string(n + 1), "truncated"}});
  }
  // A number cut in the middle keeps the count but not the number.
  cases.push_back({edgeWith(f, 11, "1e"), {"is not a number", "'1e'"}});
  // Too many fields.
  cases.push_back({edgeLine(f, 0, 1) + " 7", {"trailing garbage '7'", "got 13"}});
  cases.push_back({edgeLine(f, 0, 1) + " # comment", {"trailing garbage '#'"}});
  // Non-numbers, NaN, Inf and out-of-range values in every numeric field.
  const char* const names_g2o[] = {"dx", "dy", "dtheta", "I11", "I12", "I13", "I22", "I23", "I33"};
  const char* const names_toro[] = {"dx",     "dy",     "dtheta", "inf_ff", "inf_fs",
                                    "inf_ss", "inf_rr", "inf_fr", "inf_sr"};
  const char* const names_isam[] = {"dx", "dy", "dtheta", "R11", "R12", "R13", "R22", "R23", "R33"};
  const char* const* names = f.label == std::string("g2o")    ? names_g2o
                             : f.label == std::string("TORO") ? names_toro
                                                              : names_isam;
  for (std::size_t k = 3; k <= 11; ++k) {
    const std::string field = "field " + std::string(names[k - 3]);
    for (const char* token :
         {"1.5abc", "0x10", "abc", "--1", "++1", "+", "1,5", ".", "1e+", "e5"}) {
      cases.push_back(
          {edgeWith(f, k, token), {field, "'" + std::string(token) + "'", "not a number"}});
    }
    for (const char* token : {"nan", "NaN", "-nan", "inf", "-Inf", "infinity"}) {
      cases.push_back({edgeWith(f, k, token), {field, "non-finite value"}});
    }
    for (const char* token : {"1e400", "-1e400", "1e99999"}) {
      cases.push_back({edgeWith(f, k, token), {field, "out of the range of a double"}});
    }
  }
  // Ids: not integers, negative, beyond 2^31 - 1, huge.
  for (std::size_t k = 1; k <= 2; ++k) {
    const std::string field = k == 1 ? "field from" : "field to";
    for (const char* token : {"1.5", "1.0", "1e3", "abc", "0x10", "+1", "1a", "nan", "inf"}) {
      cases.push_back({edgeWith(f, k, token), {field, "is not an integer id"}});
    }
    for (const char* token :
         {"-1", "-2147483648", "2147483648", "4294967296", "9223372036854775807",
          "9223372036854775808", "99999999999999999999999999"}) {
      cases.push_back({edgeWith(f, k, token), {field, "id out of range", "0..2147483647"}});
    }
  }
  // An edge from a pose to itself.
  cases.push_back({edgeLine(f, 2, 2), {"edge from pose 2 to itself"}});
  // Information that is not positive definite (as written in each layout).
  if (f.vertex_tag.empty()) {  // iSAM: R upper triangular; R^T R is singular iff diag(R) has a 0
    cases.push_back({edgeLine(f, {"0", "1", "1", "0", "0", "0", "0", "0", "0", "0", "0"}),
                     {"not positive definite", "R11 = 0", "R22 = 0", "R33 = 0"}});
    cases.push_back({edgeLine(f, {"0", "1", "1", "0", "0", "1", "2", "3", "0", "5", "6"}),
                     {"not positive definite", "R22 = 0"}});
    cases.push_back({edgeLine(f, {"0", "1", "1", "0", "0", "1e-200", "0", "0", "1", "0", "1"}),
                     {"not positive definite"}});  // R^T R underflows to a zero pivot
  } else {
    const bool toro = f.label == std::string("TORO");
    // g2o: I11 I12 I13 I22 I23 I33; TORO: xx xy yy thth xth yth.
    const auto info = [&](double xx, double xy, double xt, double yy, double yt, double tt) {
      Lines v = {"0", "1", "1", "0", "0"};
      const double g2o[] = {xx, xy, xt, yy, yt, tt};
      const double tor[] = {xx, xy, yy, tt, xt, yt};
      for (const double x : toro ? tor : g2o) {
        std::ostringstream s;
        s << x;
        v.push_back(s.str());
      }
      return edgeLine(f, v);
    };
    cases.push_back({info(0, 0, 0, 0, 0, 0), {"not positive definite", "smallest eigenvalue 0"}});
    cases.push_back({info(-1, 0, 0, 1, 0, 1), {"not positive definite", "smallest eigenvalue -1"}});
    cases.push_back({info(1, 0, 0, 1, 0, -2), {"not positive definite", "smallest eigenvalue -2"}});
    cases.push_back({info(1, 2, 0, 1, 0, 1), {"not positive definite", "smallest eigenvalue -"}});
    cases.push_back({info(1, 1, 0, 1, 0, 1), {"not positive definite"}});  // PSD, singular
    cases.push_back({info(1, 0, 0, 1, 0, 0), {"not positive definite"}});  // no angle information
    cases.push_back({info(4, 0, 3, 1, 0, 2), {"not positive definite"}});  // 3x3 indefinite
    // Indefinite, and Cholesky's pivots overflow into Inf * 0 = NaN, which "pivot <= 0" misses.
    cases.push_back({info(1e-320, 0, 1e300, 1, 0, 1), {"not positive definite"}});
  }
  return cases;
}

std::vector<BadLine> otherCases(const Format& f) {
  std::vector<BadLine> cases;
  // Unknown and unsupported tags.
  for (const char* tag : {"FOO", "edge_se2", "VERTEX", "EDGE", "EDGE_SE2_XY"}) {
    cases.push_back({std::string(tag) + " 0 1 2", {"'" + std::string(tag) + "'", "record"}});
  }
  cases.push_back({"LANDMARK 0 5 1 2 10 0 10", {"'LANDMARK'", "2D landmarks are not supported"}});
  cases.push_back({"VERTEX_XY 5 1 2", {"'VERTEX_XY'", "2D landmarks are not supported"}});
  cases.push_back({"EDGE_SE2_XY 0 5 1 2 1 0 1", {"2D landmarks are not supported"}});
  cases.push_back({"EDGE_SE3:QUAT 0 1 0 0 0 0 0 0 1", {"'EDGE_SE3:QUAT'", "3D records"}});
  cases.push_back({"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1", {"3D records"}});
  cases.push_back({"EDGE3 0 1 0 0 0 0 0 0", {"'EDGE3'", "3D records"}});
  // Binary garbage: a record of raw bytes, escaped in the reason.
  cases.push_back({"\x00\x01\x02"s, {"'\\x00\\x01\\x02'", "unknown record"}});
  cases.push_back({"\xff\xfe\x7f garbage"s, {"'\\xff\\xfe\\x7f'"}});
  cases.push_back({"\x01" + std::string(100, 'A'), {"'\\x01AAA", "...'"}});
  cases.push_back({edgeWith(f, 4, "\x01\x80"s), {"'\\x01\\x80'", "not a number"}});
  cases.push_back({edgeWith(f, 1, "\x00"s), {"'\\x00'", "not an integer id"}});
  // Records of another format than the file's.
  const std::string& label = f.label;
  if (label == "g2o") {
    cases.push_back({"VERTEX2 9 0 0 0", {"'VERTEX2' is a TORO record", "read as g2o"}, true});
    cases.push_back({"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", {"'ODOMETRY' is a iSAM record"}, true});
    cases.push_back({"EDGE2 0 1 1 0 0 1 0 0 1 0 1", {"'EDGE2' is a", "read as g2o"}, true});
  } else if (label == "TORO") {
    cases.push_back({"VERTEX_SE2 9 0 0 0", {"'VERTEX_SE2' is a g2o record", "read as TORO"}, true});
    cases.push_back({"FIX 0", {"'FIX' is a g2o record"}, true});
    cases.push_back({"ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", {"'ODOMETRY' is a iSAM record"}, true});
  } else {
    cases.push_back({"EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1", {"'EDGE_SE2' is a g2o record"}, true});
    cases.push_back({"VERTEX_SE2 0 0 0 0", {"'VERTEX_SE2' is a g2o record", "iSAM"}, true});
    cases.push_back({"FIX 0", {"'FIX' is a g2o record"}, true});
  }
  return cases;
}

std::vector<BadLine> vertexCases(const Format& f) {
  const std::string& t = f.vertex_tag;
  std::vector<BadLine> cases;
  const Lines fields = {"2", "1", "2", "0.5"};
  for (std::size_t n = 0; n < fields.size(); ++n) {
    std::string line = t;
    for (std::size_t k = 0; k < n; ++k) line += " " + fields[k];
    cases.push_back({line, {t, "expected 5 fields, got " + std::to_string(n + 1)}});
  }
  cases.push_back({t + " 2 1 2 0.5 9", {"trailing garbage '9'"}});
  for (const char* token : {"1.5abc", "0x10", "abc", "nan", "inf", "1e400"}) {
    for (std::size_t k = 2; k <= 4; ++k) {
      Lines v = {t, "2", "1", "2", "0.5"};
      v[k] = token;
      std::string line = v[0];
      for (std::size_t i = 1; i < v.size(); ++i) line += " " + v[i];
      const char* field = k == 2 ? "field x" : k == 3 ? "field y" : "field theta";
      cases.push_back({line, {field, "'" + std::string(token) + "'"}});
    }
  }
  for (const char* token : {"-1", "2147483648", "123456789012345678901234567890"}) {
    cases.push_back({t + " " + token + " 0 0 0", {"field id", "id out of range"}});
  }
  for (const char* token : {"2.0", "x", "0x2"}) {
    cases.push_back({t + " " + token + " 0 0 0", {"field id", "not an integer id"}});
  }
  return cases;
}

}  // namespace

TEST_CASE("readers: malformed edge lines give their line number (g2o, TORO, iSAM)") {
  for (const Format* f : {&kG2o, &kToro, &kIsam, &kIsamOdometry}) {
    const std::string label = f->label;
    CAPTURE(label);
    for (const BadLine& bad : edgeCases(*f)) checkAtEveryPosition(*f, bad);
  }
}

TEST_CASE("readers: unknown, unsupported, binary and mixed-format records give their line") {
  for (const Format* f : {&kG2o, &kToro, &kIsam, &kIsamOdometry}) {
    const std::string label = f->label;
    CAPTURE(label);
    for (const BadLine& bad : otherCases(*f)) checkAtEveryPosition(*f, bad);
  }
}

TEST_CASE("readers: malformed vertex lines and duplicate vertex ids (g2o, TORO)") {
  for (const Format* f : {&kG2o, &kToro}) {
    const std::string label = f->label;
    CAPTURE(label);
    for (const BadLine& bad : vertexCases(*f)) checkAtEveryPosition(*f, bad);
    // A duplicate is reported at its second definition, naming the first.
    for (const Lines& prefix : prefixes(*f)) {
      if (prefix.empty()) continue;
      Lines lines = prefix;
      std::size_t first = 0;
      for (std::size_t k = 0; k < prefix.size(); ++k) {
        if (prefix[k].rfind(f->vertex_tag + " 2 ", 0) == 0) first = k + 1;
      }
      REQUIRE(first > 0);
      lines.push_back(f->vertex_tag + " 2 0 0 0");
      for (const std::string& s : suffix(*f, prefix)) lines.push_back(s);
      expectError(join(lines), f->file_name, prefix.size() + 1,
                  {"duplicate vertex id 2", "first defined at line " + std::to_string(first)});
    }
  }
}

TEST_CASE("readers: FIX lines") {
  const Lines v = {vertexLine(kG2o, 0), vertexLine(kG2o, 1), edgeLine(kG2o, 0, 1)};
  const auto with = [&](const std::string& fix) {
    Lines l = v;
    l.insert(l.begin() + 2, fix);
    return join(l);
  };
  expectError(with("FIX"), "f.g2o", 3, {"FIX", "no id"});
  expectError(with("FIX abc"), "f.g2o", 3, {"'abc' is not an integer id"});
  expectError(with("FIX 1.5"), "f.g2o", 3, {"not an integer id"});
  expectError(with("FIX -1"), "f.g2o", 3, {"id out of range"});
  expectError(with("FIX 0 2147483648"), "f.g2o", 3, {"id out of range"});
  // Declared ids are accepted, several per line, each with its line.
  const Dataset2D d = parse(with("FIX 0 1") + "FIX 0\n", "f.g2o");
  CHECK(d.fixed == std::vector<FixedPose>{{0, 3}, {1, 3}, {0, 5}});
}

TEST_CASE("readers: an edge or FIX naming a pose no vertex line declares (g2o, TORO)") {
  for (const Format* f : {&kG2o, &kToro}) {
    const std::string label = f->label;
    CAPTURE(label);
    const std::string vt = f->vertex_tag;
    // Vertices may follow the edges: accepted when every id is declared somewhere.
    const Dataset2D late = parse(join({edgeLine(*f, 0, 1), vertexLine(*f, 1), edgeLine(*f, 1, 2),
                                       vertexLine(*f, 0), vertexLine(*f, 2)}),
                                 f->file_name);
    CHECK(late.edges.size() == 2);
    CHECK(late.vertices.size() == 3);
    // Undeclared `to`, undeclared `from`, reported at the edge even when vertex lines follow.
    expectError(join({vertexLine(*f, 0), vertexLine(*f, 1), edgeLine(*f, 0, 1), edgeLine(*f, 1, 7),
                      vertexLine(*f, 2)}),
                f->file_name, 4, {"edge 1 -> 7 names pose 7", "no " + vt + " line declares"});
    expectError(join({"# c", vertexLine(*f, 0), edgeLine(*f, 9, 0), vertexLine(*f, 1)}),
                f->file_name, 3, {"edge 9 -> 0 names pose 9"});
    // The earliest offending line wins, whatever is found first.
    expectError(join({vertexLine(*f, 0), edgeLine(*f, 0, 5), edgeLine(*f, 0, 6)}), f->file_name, 2,
                {"pose 5"});
    if (f == &kG2o) {
      expectError(join({vertexLine(*f, 0), vertexLine(*f, 1), "FIX 3", edgeLine(*f, 0, 1)}),
                  f->file_name, 3, {"FIX names pose 3", "no VERTEX_SE2 line declares"});
      expectError(join({vertexLine(*f, 0), "FIX 0 4", edgeLine(*f, 0, 8), "FIX 9"}), f->file_name,
                  2, {"FIX names pose 4"});
      expectError(join({vertexLine(*f, 0), edgeLine(*f, 0, 8), "FIX 4"}), f->file_name, 2,
                  {"pose 8"});
      // A FIX before the vertex it names is fine.
      CHECK(parse(join({"FIX 1", vertexLine(*f, 0), vertexLine(*f, 1), edgeLine(*f, 0, 1)}),
                  f->file_name)
                .fixed == std::vector<FixedPose>{{1, 1}});
    }
  }
  // Without any vertex line (iSAM, or an edges-only g2o file) ids need no declaration.
  CHECK(parse(join({edgeLine(kIsam, 0, 1), edgeLine(kIsam, 1, 70)}), "t.txt").edges.size() == 2);
  CHECK(parse(join({edgeLine(kG2o, 0, 1), edgeLine(kG2o, 1, 70)}), "t.g2o").edges.size() == 2);
}

TEST_CASE("readers: a truncated last line without a newline, CRLF line ends, tabs") {
  const std::string good = vertexLine(kG2o, 0) + "\n" + vertexLine(kG2o, 1) + "\n";
  expectError(good + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0", "t.g2o", 3, {"expected 12 fields, got 11"});
  expectError(good + "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1.5e", "t.g2o", 3, {"'1.5e' is not a number"});
  expectError(good + "VERTEX_SE2 2 1.5 2.", "t.g2o", 3, {"expected 5 fields, got 4"});
  const Dataset2D crlf =
      parse("VERTEX_SE2 0 0 0 0\r\nVERTEX_SE2\t1 1\t0 0\r\n\r\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\r\n",
            "t.g2o");
  REQUIRE(crlf.edges.size() == 1);
  CHECK(crlf.edges[0].line == 4);
  CHECK(crlf.vertices[1].pose.x == 1.0);
  // A line of only a CR is blank; a CR inside a line is a separator, not part of a number.
  expectError(good + "\r\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0\r\n", "t.g2o", 4, {"got 11"});
}

namespace {

// A small graph written by hand: measurements and full information matrices with every entry
// distinct, so that any mix-up of the information layouts shows.
struct HandEdge {
  int from, to;
  double dx, dy, dth;
  Eigen::Matrix3d info;
};

std::vector<HandEdge> handGraph() {
  Eigen::Matrix3d a, b, c;
  a << 40.0, 2.5, -3.0,  //
      2.5, 31.0, 5.25,   //
      -3.0, 5.25, 700.0;
  b << 11.0, -1.5, 0.5,  //
      -1.5, 23.0, -2.0,  //
      0.5, -2.0, 1000.0;
  c << 2.0, 0.75, 0.125,  //
      0.75, 3.0, 0.375,   //
      0.125, 0.375, 5.0;
  return {{0, 1, 1.0, 0.25, -0.125, a}, {1, 2, 0.5, -1.75, 1.5, b}, {2, 0, -1.25, 1.0, 3.0, c}};
}

std::string num(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

}  // namespace

TEST_CASE("readers: one hand-written graph in g2o, TORO and iSAM reads to the same values") {
  const std::vector<HandEdge> graph = handGraph();
  std::string g2o = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 1 1 0\n";
  std::string toro = "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nVERTEX2 2 1 1 0\n";
  std::string isam;
  std::vector<Eigen::Matrix3d> isam_info;  // R^T R as computed here from the R written
  for (const HandEdge& e : graph) {
    const std::string head = std::to_string(e.from) + " " + std::to_string(e.to) + " " + num(e.dx) +
                             " " + num(e.dy) + " " + num(e.dth);
    const Eigen::Matrix3d& m = e.info;
    g2o += "EDGE_SE2 " + head;
    for (double x : {m(0, 0), m(0, 1), m(0, 2), m(1, 1), m(1, 2), m(2, 2)}) g2o += " " + num(x);
    g2o += "\n";
    toro += "EDGE2 " + head;  // TORO: xx xy yy thth xth yth
    for (double x : {m(0, 0), m(0, 1), m(1, 1), m(2, 2), m(0, 2), m(1, 2)}) toro += " " + num(x);
    toro += "\n";
    // iSAM: R upper triangular with R^T R = information: the transposed Cholesky factor.
    const Eigen::LLT<Eigen::Matrix3d> llt(m);
    REQUIRE(llt.info() == Eigen::Success);
    const Eigen::Matrix3d r = llt.matrixU();
    isam += std::string(e.from == 2 ? "EDGE2 " : "ODOMETRY ") + head;
    for (double x : {r(0, 0), r(0, 1), r(0, 2), r(1, 1), r(1, 2), r(2, 2)}) isam += " " + num(x);
    isam += "\n";
    Eigen::Matrix3d written;  // R as the text holds it (17 digits read back exactly)
    written << std::stod(num(r(0, 0))), std::stod(num(r(0, 1))), std::stod(num(r(0, 2))), 0.0,
        std::stod(num(r(1, 1))), std::stod(num(r(1, 2))), 0.0, 0.0, std::stod(num(r(2, 2)));
    isam_info.push_back(written.transpose() * written);
  }
  const Dataset2D dg = parse(g2o, "hand.g2o");
  const Dataset2D dt = parse(toro, "hand.graph");
  const Dataset2D di = parse(isam, "hand.txt");
  CHECK(dg.format == DatasetFormat::G2o);
  CHECK(dt.format == DatasetFormat::Toro);
  CHECK(di.format == DatasetFormat::Isam);
  CHECK(di.vertices.empty());
  REQUIRE(dg.edges.size() == graph.size());
  REQUIRE(dt.edges.size() == graph.size());
  REQUIRE(di.edges.size() == graph.size());
  REQUIRE(dg.vertices.size() == 3);
  REQUIRE(dt.vertices.size() == 3);
  for (std::size_t k = 0; k < graph.size(); ++k) {
    CAPTURE(k);
    const HandEdge& h = graph[k];
    for (const Dataset2D* d : {&dg, &dt, &di}) {
      const Edge2D& e = d->edges[k];
      CHECK(e.from == h.from);
      CHECK(e.to == h.to);
      CHECK(e.line == (d == &di ? k + 1 : k + 4));
      CHECK(e.measurement.x == h.dx);
      CHECK(e.measurement.y == h.dy);
      CHECK(e.measurement.theta == h.dth);
    }
    // g2o and TORO hold the information itself: exact.
    CHECK(dg.edges[k].information == h.info);
    CHECK(dt.edges[k].information == h.info);
    // iSAM holds R: the information is R^T R (rounding aside), and equals the original.
    const Eigen::Matrix3d& got = di.edges[k].information;
    CHECK(got.transpose() == got);
    CHECK((got - isam_info[k]).cwiseAbs().maxCoeff() <= 1e-14 * isam_info[k].cwiseAbs().maxCoeff());
    CHECK((got - h.info).cwiseAbs().maxCoeff() <= 1e-12 * h.info.cwiseAbs().maxCoeff());
  }
  for (std::size_t k = 0; k < 3; ++k) {
    CHECK(dg.vertices[k].id == dt.vertices[k].id);
    CHECK(dg.vertices[k].pose.x == dt.vertices[k].pose.x);
    CHECK(dg.vertices[k].pose.y == dt.vertices[k].pose.y);
    CHECK(dg.vertices[k].line == k + 1);
  }
  // A negative diagonal of R still gives a positive definite R^T R.
  const Dataset2D neg = parse("EDGE2 0 1 1 0 0 -2 0 0 3 0 -4\n", "n.txt");
  CHECK(neg.edges[0].information == Eigen::Vector3d(4.0, 9.0, 16.0).asDiagonal().toDenseMatrix());
}

TEST_CASE("readers: format detection") {
  const std::string e2 = "EDGE2 0 1 1 0 0 2 0 0 3 0 4\n";  // R = diag(2, 3, 4) or TORO's layout
  const Eigen::Matrix3d isam_info = Eigen::Vector3d(4.0, 9.0, 16.0).asDiagonal();
  // EDGE2 alone: iSAM (edges-only .txt files).
  Dataset2D d = parse(e2, "x.txt");
  CHECK(d.format == DatasetFormat::Isam);
  CHECK(d.edges[0].information == isam_info);
  // ...unless the name ends in .graph (any case), or there is a '#' comment or a VERTEX2 line:
  // TORO, whose layout makes this particular matrix indefinite (yy = 0).
  for (const std::string& text : {e2, "# c\n" + e2, e2 + "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\n"}) {
    for (const std::string name : {"x.graph", "X.GRAPH", "x.txt"}) {
      if (text == e2 && name == "x.txt") continue;
      CAPTURE(text);
      CAPTURE(name);
      expectError(text, name, text[0] == '#' ? 2 : 1, {"not positive definite"});
    }
  }
  const std::string toro_edge = "EDGE2 0 1 1 0 0 2 0.5 3 4 0.25 0.125\n";
  Eigen::Matrix3d toro_expected;
  toro_expected << 2.0, 0.5, 0.25, 0.5, 3.0, 0.125, 0.25, 0.125, 4.0;
  CHECK(parse(toro_edge, "x.graph").format == DatasetFormat::Toro);
  CHECK(parse(toro_edge, "x.graph").edges[0].information == toro_expected);
  CHECK(parse("# hog-man\n" + toro_edge, "x.txt").edges[0].information == toro_expected);
  CHECK(parse(toro_edge + "VERTEX2 1 0 0 0\nVERTEX2 0 0 0 0\n", "x").format == DatasetFormat::Toro);
  // ODOMETRY is iSAM; EDGE2 with it too.
  d = parse("ODOMETRY 0 1 1 0 0 2 0 0 3 0 4\n" + e2, "x.g2o");
  CHECK(d.format == DatasetFormat::Isam);
  CHECK(d.edges[1].information == isam_info);
  // g2o tags.
  CHECK(parse("EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n", "x.graph").format == DatasetFormat::G2o);
  // No records: g2o, TORO for a .graph name.
  for (const std::string& text : {""s, "\n\n"s, "# only a comment\n  # another\n"s, " \t\r\n"s}) {
    CHECK(parse(text, "e.g2o").format == DatasetFormat::G2o);
    CHECK(parse(text, "e.graph").format == DatasetFormat::Toro);
    CHECK(parse(text, "e.txt").edges.empty());
    CHECK(parse(text, "e.g2o", DatasetFormat::Isam).format == DatasetFormat::Isam);
  }
  // The first record fixes the format.
  expectError("VERTEX_SE2 0 0 0 0\n" + e2, "x.txt", 2,
              {"'EDGE2' is a iSAM record", "read as g2o", "first g2o record at line 1"});
  expectError("\n" + e2 + "VERTEX_SE2 0 0 0 0\n", "x.txt", 3,
              {"'VERTEX_SE2' is a g2o record", "first iSAM record at line 2"});
  // A given format overrides detection, and only its records are accepted.
  CHECK(parse("# c\n" + e2, "x.graph", DatasetFormat::Isam).edges[0].information == isam_info);
  CHECK(parse(toro_edge, "x.txt", DatasetFormat::Toro).edges[0].information == toro_expected);
  expectError(e2, "x.txt", 1, {"'EDGE2' is not a g2o record"}, DatasetFormat::G2o);
  expectError("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\n", "x.txt", 1, {"format given explicitly"},
              DatasetFormat::Toro);
  expectError("\nVERTEX_SE2 0 0 0 0\n", "x.g2o", 2, {"'VERTEX_SE2' is a g2o record"},
              DatasetFormat::Isam);
  CHECK(std::string(lslam::sim::formatName(DatasetFormat::G2o)) == "g2o");
  CHECK(std::string(lslam::sim::formatName(DatasetFormat::Toro)) == "TORO");
  CHECK(std::string(lslam::sim::formatName(DatasetFormat::Isam)) == "iSAM");
}

namespace {

// Any finite double: random bits (every exponent, subnormals, signed zero), or a few specials.
double randomDouble(std::mt19937_64& rng) {
  std::uniform_int_distribution<int> kind(0, 9);
  switch (kind(rng)) {
    case 0:
      return -0.0;
    case 1:
      return std::numeric_limits<double>::denorm_min() *
             static_cast<double>(std::uniform_int_distribution<int>(1, 1000)(rng));
    case 2:
      return std::numeric_limits<double>::max();
    case 3:
      return std::uniform_real_distribution<double>(-100.0, 100.0)(rng);
    default:
      for (;;) {
        const std::uint64_t bits = rng();
        double v = 0.0;
        std::memcpy(&v, &bits, sizeof v);
        if (std::isfinite(v)) return v;
      }
  }
}

// A position coordinate of every kind randomDouble draws, within the readers' coordinate range
// (lslam::kMaxCoordinate), the bound itself included.
double randomCoordinate(std::mt19937_64& rng) {
  if (std::uniform_int_distribution<int>(0, 9)(rng) == 0) {
    return std::uniform_int_distribution<int>(0, 1)(rng) == 0 ? lslam::kMaxCoordinate
                                                              : -lslam::kMaxCoordinate;
  }
  for (;;) {
    const double v = randomDouble(rng);
    if (std::abs(v) <= lslam::kMaxCoordinate) return v;
  }
}

// A symmetric positive definite information over a wide range of scales, exactly symmetric.
Eigen::Matrix3d randomInformation(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-100, 100);
  for (;;) {
    Eigen::Matrix3d l = Eigen::Matrix3d::Zero();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c <= r; ++c) l(r, c) = r == c ? 0.1 + std::abs(u(rng)) : u(rng);
    }
    const double scale = std::pow(10.0, exponent(rng));
    Eigen::Matrix3d m = scale * (l * l.transpose());
    for (int r = 1; r < 3; ++r) {
      for (int c = 0; c < r; ++c) m(r, c) = m(c, r);
    }
    const Eigen::LLT<Eigen::Matrix3d> llt(m);
    if (llt.info() == Eigen::Success && llt.matrixLLT().allFinite()) return m;
  }
}

bool sameBits(double a, double b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

}  // namespace

TEST_CASE("writeG2o -> parseDataset2D is bit-exact") {
  std::mt19937_64 rng(20240611);
  std::uniform_int_distribution<std::int64_t> any_id(0, std::numeric_limits<std::int32_t>::max());
  int cases = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<Vertex2D> vertices;
    std::vector<std::int64_t> ids = {0, std::numeric_limits<std::int32_t>::max()};
    while (ids.size() < 12) {
      const std::int64_t id = any_id(rng);
      if (std::find(ids.begin(), ids.end(), id) == ids.end()) ids.push_back(id);
    }
    std::shuffle(ids.begin(), ids.end(), rng);
    for (const std::int64_t id : ids) {
      vertices.push_back(
          Vertex2D{id, {randomCoordinate(rng), randomCoordinate(rng), randomDouble(rng)}, 0});
    }
    std::vector<Edge2D> edges;
    std::uniform_int_distribution<std::size_t> pick(0, ids.size() - 1);
    for (int k = 0; k < 20; ++k) {
      Edge2D e;
      e.from = ids[pick(rng)];
      do {
        e.to = ids[pick(rng)];
      } while (e.to == e.from);
      e.measurement = {randomCoordinate(rng), randomCoordinate(rng), randomDouble(rng)};
      e.information = randomInformation(rng);
      edges.push_back(e);
    }
    const std::vector<std::int64_t> fixed = {ids[pick(rng)], ids[pick(rng)]};
    std::ostringstream out;
    writeG2o(out, vertices, edges, fixed);
    const Dataset2D d = parse(out.str(), "round.g2o");
    CHECK(d.format == DatasetFormat::G2o);
    REQUIRE(d.vertices.size() == vertices.size());
    REQUIRE(d.edges.size() == edges.size());
    REQUIRE(d.fixed.size() == fixed.size());
    for (std::size_t k = 0; k < fixed.size(); ++k) CHECK(d.fixed[k].id == fixed[k]);
    for (std::size_t k = 0; k < vertices.size(); ++k) {
      const Vertex2D& a = vertices[k];
      const Vertex2D& b = d.vertices[k];
      CHECK(a.id == b.id);
      CHECK(sameBits(a.pose.x, b.pose.x));
      CHECK(sameBits(a.pose.y, b.pose.y));
      CHECK(sameBits(a.pose.theta, b.pose.theta));
      CHECK(b.line == k + 1);
    }
    for (std::size_t k = 0; k < edges.size(); ++k) {
      const Edge2D& a = edges[k];
      const Edge2D& b = d.edges[k];
      CHECK(a.from == b.from);
      CHECK(a.to == b.to);
      CHECK(sameBits(a.measurement.x, b.measurement.x));
      CHECK(sameBits(a.measurement.y, b.measurement.y));
      CHECK(sameBits(a.measurement.theta, b.measurement.theta));
      bool info_same = true;
      for (int i = 0; i < 9; ++i)
        info_same = info_same && sameBits(a.information(i), b.information(i));
      CHECK(info_same);
      CHECK(b.line == vertices.size() + fixed.size() + k + 1);
    }
    // Written again, the text is the same.
    std::ostringstream again;
    writeG2o(again, d);
    CHECK(again.str() == out.str());
    ++cases;
  }
  CHECK(cases == 300);
}

TEST_CASE("writeG2o rejects what the readers would reject, before writing anything") {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::int64_t too_big = std::int64_t{std::numeric_limits<std::int32_t>::max()} + 1;
  const std::vector<Vertex2D> good_v = {Vertex2D{0, {0, 0, 0}, 0}, Vertex2D{1, {1, 0, 0}, 0}};
  Edge2D good_e;
  good_e.from = 0;
  good_e.to = 1;
  const auto rejects = [&](const std::vector<Vertex2D>& v, const std::vector<Edge2D>& e,
                           const std::vector<std::int64_t>& fixed, const char* fragment) {
    std::ostringstream out;
    bool threw = false;
    try {
      writeG2o(out, v, e, fixed);
    } catch (const std::invalid_argument& ex) {
      threw = true;
      CHECK(std::string(ex.what()).find(fragment) != std::string::npos);
    }
    CHECK(threw);
    CHECK(out.str().empty());
  };
  // The good case writes.
  std::ostringstream ok;
  writeG2o(ok, good_v, {good_e}, {0});
  CHECK(ok.str() ==
        "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nFIX 0\nEDGE_SE2 0 1 0 0 0 1 0 0 1 0 1\n");
  for (const double bad : {nan, inf, -inf}) {
    for (int field = 0; field < 3; ++field) {
      std::vector<Vertex2D> v = good_v;
      (field == 0 ? v[1].pose.x : field == 1 ? v[1].pose.y : v[1].pose.theta) = bad;
      rejects(v, {good_e}, {}, "non-finite");
      Edge2D e = good_e;
      (field == 0 ? e.measurement.x : field == 1 ? e.measurement.y : e.measurement.theta) = bad;
      rejects(good_v, {e}, {}, "non-finite");
    }
    for (int i = 0; i < 9; ++i) {
      Edge2D e = good_e;
      e.information(i) = bad;
      rejects(good_v, {e}, {}, "non-finite information");
    }
  }
  // A position beyond the coordinate range, either sign; an angle is not bounded (it is wrapped).
  const double beyond = std::nextafter(lslam::kMaxCoordinate, inf);
  for (const double bad : {beyond, -beyond}) {
    for (int field = 0; field < 2; ++field) {
      std::vector<Vertex2D> v = good_v;
      (field == 0 ? v[1].pose.x : v[1].pose.y) = bad;
      rejects(v, {good_e}, {}, "beyond the coordinate range");
      Edge2D e = good_e;
      (field == 0 ? e.measurement.x : e.measurement.y) = bad;
      rejects(good_v, {e}, {}, "beyond the coordinate range");
    }
  }
  for (const std::int64_t id : {std::int64_t{-1}, too_big, std::numeric_limits<std::int64_t>::min(),
                                std::numeric_limits<std::int64_t>::max()}) {
    std::vector<Vertex2D> v = good_v;
    v[0].id = id;
    rejects(v, {}, {}, "out of range");
    Edge2D e = good_e;
    e.from = id;
    rejects(good_v, {e}, {}, "out of range");
    e = good_e;
    e.to = id;
    rejects(good_v, {e}, {}, "out of range");
    rejects(good_v, {good_e}, {0, id}, "FIX");
  }
  for (const double d : {0.0, -1.0}) {
    Edge2D e = good_e;
    e.information(2, 2) = d;
    rejects(good_v, {e}, {}, "not positive definite");
  }
  Edge2D lower_ignored = good_e;  // only the upper triangle is written: [1 2; 2 1] is indefinite
  lower_ignored.information(0, 1) = 2.0;
  rejects(good_v, {lower_ignored}, {}, "not positive definite");
  lower_ignored.information(0, 1) = 0.0;
  lower_ignored.information(1, 0) = 2.0;  // the lower triangle is not written: accepted
  std::ostringstream lower_out;
  writeG2o(lower_out, good_v, {lower_ignored}, {});
  CHECK(lower_out.str().find("EDGE_SE2 0 1 0 0 0 1 0 0 1 0 1\n") != std::string::npos);
  Edge2D self = good_e;
  self.to = 0;
  rejects(good_v, {good_e, self}, {}, "from == to");
  // A failed stream: std::runtime_error.
  std::ostringstream broken;
  broken.setstate(std::ios::badbit);
  CHECK_THROWS_AS(writeG2o(broken, good_v, {good_e}, {}), std::runtime_error);
}

namespace {

// Corrupts one token of `text` (replaced, deleted, or a token inserted).
std::string corruptOneToken(const std::string& text, std::mt19937_64& rng) {
  static const std::vector<std::string> pool = {"abc",
                                                "1.5abc",
                                                "0x10",
                                                "nan",
                                                "-inf",
                                                "1e400",
                                                "-1e400",
                                                "1e-400",
                                                "4.9e-324",
                                                "-1",
                                                "0",
                                                "7",
                                                "2147483647",
                                                "2147483648",
                                                "99999999999999999999",
                                                "1.5",
                                                "-0",
                                                "1e308",
                                                "-1e308",
                                                "+",
                                                "-",
                                                "+-1",
                                                "#",
                                                "#x",
                                                "\x00\xff"s,
                                                "\x01",
                                                "EDGE_SE2",
                                                "VERTEX_SE2",
                                                "EDGE2",
                                                "VERTEX2",
                                                "ODOMETRY",
                                                "FIX",
                                                "LANDMARK",
                                                "EDGE_SE3:QUAT",
                                                std::string(300, '9'),
                                                std::string(50, 'x'),
                                                "0.0",
                                                "1e-300",
                                                "3",
                                                "2"};
  Lines lines;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  std::uniform_int_distribution<std::size_t> pick_line(0, lines.size() - 1);
  std::string& line = lines[pick_line(rng)];
  // Token boundaries of the line.
  std::vector<std::pair<std::size_t, std::size_t>> tokens;
  for (std::size_t i = 0; i < line.size();) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) tokens.emplace_back(start, i - start);
  }
  std::uniform_int_distribution<std::size_t> pick_pool(0, pool.size() - 1);
  std::string token = pool[pick_pool(rng)];
  if (std::uniform_int_distribution<int>(0, 4)(rng) == 0 && !tokens.empty()) {
    // A token taken from elsewhere on the line (a shifted field).
    const auto [s, n] =
        tokens[std::uniform_int_distribution<std::size_t>(0, tokens.size() - 1)(rng)];
    token = line.substr(s, n);
  }
  const int op = std::uniform_int_distribution<int>(0, 2)(rng);
  if (tokens.empty() || op == 2) {  // insert
    const std::size_t at =
        tokens.empty()
            ? 0
            : tokens[std::uniform_int_distribution<std::size_t>(0, tokens.size() - 1)(rng)].first;
    line.insert(at, token + " ");
  } else {
    const auto [s, n] =
        tokens[std::uniform_int_distribution<std::size_t>(0, tokens.size() - 1)(rng)];
    line.replace(s, n, op == 0 ? token : "");
  }
  return join(lines);
}

std::size_t lineCount(const std::string& text) {
  std::istringstream in(text);
  std::size_t n = 0;
  for (std::string l; std::getline(in, l);) ++n;
  return n;
}

}  // namespace

TEST_CASE("readers: random single-token corruptions parse or throw DatasetError within the file") {
  const std::string g2o =
      "# a small g2o graph\n"
      "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0.1\nVERTEX_SE2 2 2 0.5 0.2\n\n"
      "VERTEX_SE2 3 2.5 1 1.5\nFIX 0\n"
      "EDGE_SE2 0 1 1 0 0.1 40 2 3 30 5 700\nEDGE_SE2 1 2 1 0.5 0.1 10 0 0 10 0 100\n"
      "EDGE_SE2 2 3 0.5 0.5 1.3 1 0.5 0.25 2 0.125 3\nEDGE_SE2 3 0 -2 -1 -1.5 1 0 0 1 0 1\n";
  const std::string toro =
      "# TORO\nVERTEX2 0 0 0 0\nVERTEX2 1 1 0 0.1\nVERTEX2 2 2 0.5 0.2\nVERTEX2 3 2.5 1 1.5\n"
      "EDGE2 0 1 1 0 0.1 40 2 30 700 3 5\nEDGE2 1 2 1 0.5 0.1 10 0 10 100 0 0\n"
      "EDGE2 2 3 0.5 0.5 1.3 1 0.5 2 3 0.25 0.125\nEDGE2 3 0 -2 -1 -1.5 1 0 1 1 0 0\n";
  const std::string isam =
      "ODOMETRY 0 1 1 0 0.1 6 0.3 0.4 5 0.7 26\nODOMETRY 1 2 1 0.5 0.1 3 0 0 3 0 10\n\n"
      "EDGE2 2 3 0.5 0.5 1.3 1 0.5 0.25 2 0.125 3\nEDGE2 3 0 -2 -1 -1.5 -1 0 0 1 0 1\n";
  struct Source {
    const std::string* text;
    const char* name;
  };
  std::mt19937_64 rng(77);
  for (const Source& src :
       {Source{&g2o, "p.g2o"}, Source{&toro, "p.graph"}, Source{&isam, "p.txt"}}) {
    CAPTURE(src.name);
    REQUIRE(parse(*src.text, src.name).edges.size() == 4);  // the uncorrupted file is valid
    int parsed = 0, rejected = 0;
    std::string failure;
    for (int trial = 0; trial < 4000 && failure.empty(); ++trial) {
      const std::string text = corruptOneToken(*src.text, rng);
      const std::size_t lines = lineCount(text);
      try {
        const Dataset2D d = parse(text, src.name);
        ++parsed;
        // What parses is well formed.
        for (const Edge2D& e : d.edges) {
          const Eigen::LLT<Eigen::Matrix3d> llt(e.information);
          const bool ok = e.from != e.to && e.from >= 0 && e.to >= 0 && e.line >= 1 &&
                          e.line <= lines && std::abs(e.measurement.x) <= lslam::kMaxCoordinate &&
                          std::abs(e.measurement.y) <= lslam::kMaxCoordinate &&
                          std::isfinite(e.measurement.theta) && e.information.allFinite() &&
                          llt.info() == Eigen::Success;
          if (!ok)
            failure = "accepted a bad edge at line " + std::to_string(e.line) + " of\n" + text;
        }
      } catch (const DatasetError& e) {
        ++rejected;
        if (e.line() < 1 || e.line() > lines || e.reason().empty() || !printable(e.reason())) {
          failure = "DatasetError line " + std::to_string(e.line()) + " of " +
                    std::to_string(lines) + " (" + e.reason() + ") for\n" + text;
        }
      } catch (const std::exception& e) {
        failure = std::string("other exception: ") + e.what() + " for\n" + text;
      } catch (...) {
        failure = "unknown exception for\n" + text;
      }
    }
    INFO(failure);
    CHECK(failure.empty());
    CHECK(parsed > 100);  // the corruptions exercise both outcomes
    CHECK(rejected > 1000);
  }
}

TEST_CASE("a position or translation beyond the coordinate range is an error at its line") {
  // lslam::kMaxCoordinate (1e9 m) is read; the next double above it is not, in any position field
  // of any 2D record (an angle is only wrapped: not bounded).
  const std::string at = "1e9";
  const std::string past = "1000000000.0000001";
  REQUIRE(std::stod(past) == std::nextafter(lslam::kMaxCoordinate, 2e9));
  struct Case {
    Lines lines;  // the last line holds `@`, replaced by `at` (read) and by `past` (rejected)
    std::string name;
    std::string field;
  };
  const std::vector<Case> cases = {
      {{"VERTEX_SE2 0 @ 0 0"}, "t.g2o", "VERTEX_SE2 field x"},
      {{"VERTEX_SE2 0 0 0 0", "VERTEX_SE2 1 0 -@ 1e300"}, "t.g2o", "VERTEX_SE2 field y"},
      {{"VERTEX_SE2 0 0 0 0", "VERTEX_SE2 1 0 0 0", "EDGE_SE2 0 1 -@ 0 0 1 0 0 1 0 1"},
       "t.g2o",
       "EDGE_SE2 field dx"},
      {{"VERTEX2 0 0 @ 0"}, "t.graph", "VERTEX2 field y"},
      {{"VERTEX2 0 0 0 0", "VERTEX2 1 0 0 0", "EDGE2 0 1 0 @ 0 1 0 1 1 0 0"},
       "t.graph",
       "EDGE2 field dy"},
      {{"ODOMETRY 0 1 0 -@ 0 1 0 0 1 0 1"}, "t.txt", "ODOMETRY field dy"},
  };
  for (const Case& c : cases) {
    const auto with = [&](const std::string& value) {
      Lines lines = c.lines;
      std::string& last = lines.back();
      last.replace(last.find('@'), 1, value);
      return join(lines);
    };
    CAPTURE(c.field);
    CHECK_FALSE(parseError(with(at), c.name).has_value());
    expectError(with(past), c.name, c.lines.size(),
                {c.field, past + "'", "beyond the coordinate range"});
  }
}

// ---- lslam-sim's option values and JSON strings ----

TEST_CASE("parseIntegerArg and parseRealArg take whole, finite, in-range tokens only") {
  using lslam::sim::parseIntegerArg;
  using lslam::sim::parseRealArg;
  CHECK(parseIntegerArg("1", 1, 10) == std::optional<std::int64_t>(1));
  CHECK(parseIntegerArg("10", 1, 10) == std::optional<std::int64_t>(10));
  CHECK(parseIntegerArg("-5", -10, 10) == std::optional<std::int64_t>(-5));
  for (const char* bad : {"", "0", "11", "1x", "x1", " 1", "1 ", "+1", "1.0", "1e1", "0x5", "abc",
                          "99999999999999999999999"}) {
    CAPTURE(bad);
    CHECK_FALSE(parseIntegerArg(bad, 1, 10).has_value());
  }
  CHECK(parseRealArg("0.01", 0.0, 1.0) == std::optional<double>(0.01));
  CHECK(parseRealArg("1e-4", 0.0, 1.0) == std::optional<double>(1e-4));
  CHECK(parseRealArg("0", 0.0, 1.0) == std::optional<double>(0.0));
  CHECK(parseRealArg("1", 0.0, 1.0) == std::optional<double>(1.0));
  for (const char* bad : {"", "abc", "1x", "0.5 ", " 0.5", "+0.5", "nan", "inf", "-inf", "1e400",
                          "-0.5", "1.5", "0x0.1", "0.5.5"}) {
    CAPTURE(bad);
    CHECK_FALSE(parseRealArg(bad, 0.0, 1.0).has_value());
  }
  CHECK(parseRealArg("1e308", 0.0, std::numeric_limits<double>::max()).has_value());
}

TEST_CASE("jsonString escapes quotes, backslashes and control characters") {
  using lslam::sim::jsonString;
  CHECK(jsonString("a/b.g2o") == "\"a/b.g2o\"");
  CHECK(jsonString("we\"ird\\name") == "\"we\\\"ird\\\\name\"");
  CHECK(jsonString("a\nb\tc\rd\be\ff") == "\"a\\nb\\tc\\rd\\be\\ff\"");
  CHECK(jsonString("\x00\x01\x1f\x7f"s) == "\"\\u0000\\u0001\\u001f\\u007f\"");
  CHECK(jsonString("caf\xc3\xa9") == "\"caf\xc3\xa9\"");  // UTF-8 passes through
  CHECK(jsonString("") == "\"\"");
}
