#pragma once
// A whole file as a string, and where two texts first differ: for the tests that compare
// generated text with a committed file.
#include <doctest/doctest.h>

#include <cstddef>
#include <fstream>
#include <sstream>
#include <string>

namespace lslam::test {

inline std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE_MESSAGE(in.good(), "cannot read " << path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// 1-based number of the first line where a and b differ (0 if they are equal).
inline int firstDifferingLine(const std::string& a, const std::string& b) {
  if (a == b) return 0;
  int line = 1;
  for (std::size_t i = 0; i < a.size() && i < b.size() && a[i] == b[i]; ++i) line += a[i] == '\n';
  return line;
}

}  // namespace lslam::test
