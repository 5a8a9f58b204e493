#pragma once
// The public datasets' paths for the host tests (LSLAM_DATASETS_DIR, set by tests/CMakeLists.txt),
// and the check that skips a test, with a "SKIP: ..." message, when a file is absent.
#include <doctest/doctest.h>

#include <filesystem>
#include <string>

namespace lslam::sim::test {

inline std::string datasetPath(const std::string& relative) {
  return std::string(LSLAM_DATASETS_DIR) + "/" + relative;
}

inline bool present(const std::string& path) {
  if (std::filesystem::exists(path)) return true;
  MESSAGE("SKIP: " << path << " not found");
  return false;
}

}  // namespace lslam::sim::test
