#pragma once
// Private to host_sim/src: the file scan, the line tokenizer and the strict field parsing shared by
// the dataset readers (dataset_io.cpp, model_dataset_io.cpp), and the shortest round-trip number
// formatting shared by their writers. Every parse failure throws DatasetError(file, line, reason).
#include <algorithm>
#include <array>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <istream>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "host_sim/dataset.h"
#include "lslam/geometry/coordinate_range.h"

namespace lslam::sim::parsing {

inline constexpr std::int64_t kMaxId = std::numeric_limits<std::int32_t>::max();  // 2^31 - 1

inline bool isBlank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

inline std::vector<std::string_view> tokenize(std::string_view s) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && isBlank(s[i])) ++i;
    if (i >= s.size()) break;
    const std::size_t start = i;
    while (i < s.size() && !isBlank(s[i])) ++i;
    out.push_back(s.substr(start, i - start));
  }
  return out;
}

// The file opened for reading, or DatasetError(path, 0, why): a directory, or open's errno.
inline std::ifstream openDatasetFile(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw DatasetError(path, 0, "cannot read: is a directory");
  }
  std::ifstream in(path, std::ios::in | std::ios::binary);
  if (!in) {
    const int err = errno;
    throw DatasetError(path, 0,
                       std::string("cannot open file") + (err != 0 ? ": " : "") +
                           (err != 0 ? std::strerror(err) : ""));
  }
  return in;
}

// One significant line of a file: its number, its tokens (views into ScannedFile::lines) and tag.
template <class Tag>
struct TaggedRecord {
  std::size_t line = 0;
  std::vector<std::string_view> tokens;
  Tag tag = Tag::Other;
};

inline bool hasGraphExtension(const std::string& name) {
  std::string ext = std::filesystem::path(name).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](char c) {
    return (c >= 'A' && c <= 'Z') ? static_cast<char>(c - 'A' + 'a') : c;
  });
  return ext == ".graph";
}

// A file read whole (the EDGE2 rule looks at all of it), its blank and '#' lines dropped.
template <class Tag>
struct ScannedFile {
  // Move-only: a copy's tokens would view the original's lines.
  ScannedFile() = default;
  ScannedFile(ScannedFile&&) = default;
  ScannedFile& operator=(ScannedFile&&) = default;
  ScannedFile(const ScannedFile&) = delete;
  ScannedFile& operator=(const ScannedFile&) = delete;

  std::vector<std::string> lines;  // the text the records' tokens view
  std::vector<TaggedRecord<Tag>> records;
  bool has_vertex2 = false;
  bool has_comment = false;
  bool has_graph_name = false;  // the file's name ends in ".graph" (any case)

  // EDGE2 (dataset_io.h's rule): TORO if the file has VERTEX2 lines, '#' comments or a ".graph"
  // name, iSAM otherwise.
  DatasetFormat edge2Format() const {
    return has_vertex2 || has_comment || has_graph_name ? DatasetFormat::Toro : DatasetFormat::Isam;
  }
};

// classify(tag token) -> Tag, a reader's enum with Vertex2 (TORO's VERTEX2) and Other.
template <class Tag, class Classify>
ScannedFile<Tag> scanFile(std::istream& in, const std::string& name, Classify classify) {
  ScannedFile<Tag> file;
  file.has_graph_name = hasGraphExtension(name);
  // Every line first: the tokens view them, so the vector must not grow after.
  std::string line;
  while (std::getline(in, line)) file.lines.push_back(line);
  if (in.bad()) throw DatasetError(name, 0, "read error");
  for (std::size_t i = 0; i < file.lines.size(); ++i) {
    TaggedRecord<Tag> r;
    r.line = i + 1;
    r.tokens = tokenize(file.lines[i]);
    if (r.tokens.empty()) continue;
    if (r.tokens[0][0] == '#') {
      file.has_comment = true;
      continue;
    }
    r.tag = classify(r.tokens[0]);
    if (r.tag == Tag::Vertex2) file.has_vertex2 = true;
    file.records.push_back(std::move(r));
  }
  return file;
}

// Printable form of a token for an error message (long or binary tokens shortened/escaped).
inline std::string show(std::string_view token) {
  std::string out = "'";
  const std::size_t n = std::min<std::size_t>(token.size(), 40);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(token[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      static const char* const kHex = "0123456789abcdef";
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 0xf];
    }
  }
  if (token.size() > n) out += "...";
  out += "'";
  return out;
}

// The shortest text that reads back to the identical double (std::to_chars).
inline void appendNumber(std::string& out, double v) {
  std::array<char, 64> buf{};
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  out.append(buf.data(), res.ptr);
}

inline std::string formatDouble(double v) {
  std::string out;
  appendNumber(out, v);
  return out;
}

// "<value> is beyond the coordinate range (|value| <= 1e+09 m)": why a position, translation or
// range past lslam::kMaxCoordinate (the solver's bound) is refused, for readers and writers alike.
inline std::string beyondCoordinateRange(const std::string& value) {
  return value + " is beyond the coordinate range (|value| <= " + formatDouble(kMaxCoordinate) +
         " m)";
}

// Parses the fields of one record (tokens[0] is its tag); every failure names the file and line.
class FieldParser {
 public:
  FieldParser(const std::string& file, std::size_t line,
              const std::vector<std::string_view>& tokens)
      : file_(file), line_(line), tokens_(tokens) {}

  [[noreturn]] void fail(const std::string& reason) const {
    throw DatasetError(file_, line_, reason);
  }

  void expectFields(std::size_t n) const {
    const std::size_t got = tokens_.size();
    if (got == n) return;
    const std::string tag(tokens_[0]);
    if (got < n) {
      fail(tag + ": expected " + std::to_string(n) + " fields, got " + std::to_string(got) +
           " (truncated line?)");
    }
    fail(tag + ": trailing garbage " + show(tokens_[n]) + " (expected " + std::to_string(n) +
         " fields, got " + std::to_string(got) + ")");
  }

  // An integer id in 0..kMaxId.
  std::int64_t id(std::size_t i, const char* field) const {
    const std::string_view t = tokens_[i];
    std::int64_t v = 0;
    const char* end = t.data() + t.size();
    const auto res = std::from_chars(t.data(), end, v);
    if (res.ec == std::errc::result_out_of_range && res.ptr == end) {
      fail(where(field) + ": id out of range " + show(t) + " (ids must be in 0.." +
           std::to_string(kMaxId) + ")");
    }
    if (res.ec != std::errc() || res.ptr != end) {
      fail(where(field) + ": " + show(t) + " is not an integer id");
    }
    if (v < 0 || v > kMaxId) {
      fail(where(field) + ": id out of range " + show(t) + " (ids must be in 0.." +
           std::to_string(kMaxId) + ")");
    }
    return v;
  }

  // A finite double; the whole token must parse ("1.5abc", "0x10", "nan", "1e400" are errors).
  double number(std::size_t i, const char* field) const {
    const std::string_view t = tokens_[i];
    std::string_view body = t;
    // An explicit '+' is accepted (std::from_chars does not take it), but only once.
    if (!body.empty() && body[0] == '+') {
      body.remove_prefix(1);
      if (body.empty() || body[0] == '+' || body[0] == '-') {
        fail(where(field) + ": " + show(t) + " is not a number");
      }
    }
    double v = 0.0;
    const char* end = body.data() + body.size();
    const auto res = std::from_chars(body.data(), end, v, std::chars_format::general);
    if (res.ptr != end || res.ec == std::errc::invalid_argument) {
      fail(where(field) + ": " + show(t) + " is not a number");
    }
    if (res.ec == std::errc::result_out_of_range) {
      fail(where(field) + ": value " + show(t) + " is out of the range of a double");
    }
    if (res.ec != std::errc()) fail(where(field) + ": " + show(t) + " is not a number");
    if (!std::isfinite(v)) {
      fail(where(field) + ": non-finite value " + show(t));
    }
    return v;
  }

  // A position coordinate, a translation or a range (metres): a number() within the solver's
  // bound (lslam::kMaxCoordinate), so that the reader rejects at its line what the solver would.
  double coordinate(std::size_t i, const char* field) const {
    const double v = number(i, field);
    if (!withinCoordinateRange(v))
      fail(where(field) + ": " + beyondCoordinateRange(show(tokens_[i])));
    return v;
  }

 private:
  // "EDGE_SE2 field dx"
  std::string where(const char* field) const { return std::string(tokens_[0]) + " field " + field; }

  const std::string& file_;
  std::size_t line_;
  const std::vector<std::string_view>& tokens_;
};

}  // namespace lslam::sim::parsing
