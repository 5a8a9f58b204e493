#include "host_sim/dataset.h"

#include <utility>

namespace lslam::sim {

DatasetError::DatasetError(std::string file, std::size_t line, std::string reason)
    : std::runtime_error(file + ":" + std::to_string(line) + ": " + reason),
      file_(std::move(file)),
      line_(line),
      reason_(std::move(reason)) {}

}  // namespace lslam::sim
