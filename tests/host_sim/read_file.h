#pragma once
// A whole file as a string, for the tests that compare generated text with a committed file.
#include <doctest/doctest.h>

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

}  // namespace lslam::test
