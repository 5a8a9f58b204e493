#pragma once
// A 2D pose-graph dataset as read from a file, in file order, before any solver sees it.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace lslam::sim {

enum class DatasetFormat { G2o, Toro, Isam };

struct Pose2D {
  double x = 0.0;
  double y = 0.0;
  double theta = 0.0;
};

struct Vertex2D {
  std::int64_t id = 0;
  Pose2D pose;
  std::size_t line = 0;  // 1-based line in the file (0: not from a file)
};

// A relative-pose measurement z of pose `to` in the frame of pose `from`, with its information
// matrix (always the information, whatever the file stored: the readers convert).
struct Edge2D {
  std::int64_t from = 0;
  std::int64_t to = 0;
  Pose2D measurement;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  std::size_t line = 0;
};

// A pose named by a FIX line, and that line (0: not from a file).
struct FixedPose {
  std::int64_t id = 0;
  std::size_t line = 0;
  bool operator==(const FixedPose& other) const { return id == other.id && line == other.line; }
};

struct Dataset2D {
  std::string name;  // file name as given
  DatasetFormat format = DatasetFormat::G2o;
  std::vector<Vertex2D> vertices;  // file order; empty for edge-only files (iSAM)
  std::vector<Edge2D> edges;       // file order
  std::vector<FixedPose> fixed;    // every id named by FIX lines, in file order
};

// Thrown by the readers: which file, which line (1-based), and why.
class DatasetError : public std::runtime_error {
 public:
  DatasetError(std::string file, std::size_t line, std::string reason);
  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }
  const std::string& reason() const { return reason_; }

 private:
  std::string file_;
  std::size_t line_;
  std::string reason_;
};

}  // namespace lslam::sim
