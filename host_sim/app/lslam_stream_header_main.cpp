// lslam-stream-header: writes the C++ header that embeds a dataset's online step stream and the
// host's reference results for the target programs (see host_sim/stream_header.h for 2D pose
// graphs, host_sim/model_stream_header.h for 3D datasets with landmarks).
//
//   lslam-stream-header DATASET OUT.h
//   lslam-stream-header --landmarks-3d OUT.g2o   (writes the synthetic 3D landmark dataset of
//                                                 host_sim/synthetic_3d.h, default options)
//   lslam-stream-header --compact N DATASET TRUTH OUT.h   (a long 2D pose graph mapped on N
//                                                 poses: host_sim/compact_stream_header.h)
// The namespace inside lslam::stream is the dataset's file name without its extension, e.g.
// data/manhattan_world_500.g2o -> lslam::stream::manhattan_world_500.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "host_sim/compact_stream_header.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/model_run.h"
#include "host_sim/model_stream_header.h"
#include "host_sim/stream_header.h"
#include "host_sim/synthetic_3d.h"
#include "host_sim/trajectory_error.h"

namespace {

std::string header(const std::string& path) {
  const std::filesystem::path source(path);
  const std::string file = source.filename().string(), name = source.stem().string();
  const lslam::sim::ModelDataset d = lslam::sim::readModelDataset(path);
  if (lslam::sim::isPoseGraph2D(d)) {
    return lslam::sim::streamHeader(d, file, name);
  }
  return lslam::sim::modelStreamHeader(d, file, name);
}

// The text written to OUT.h, or (--landmarks-3d) the dataset written.
std::string run(int argc, char** argv) {
  const std::string first = argv[1];
  if (argc == 3 && first == "--landmarks-3d") {
    lslam::sim::writeModelG2oFile(argv[2], lslam::sim::generateLandmarkWorld3D());
    return {};
  }
  if (argc == 6 && first == "--compact") {
    const std::filesystem::path source(argv[3]);
    const int max_poses = std::stoi(argv[2]);
    return lslam::sim::compactStreamHeader(
        lslam::sim::readModelDataset(argv[3]), lslam::sim::readGroundTruth(argv[4]), max_poses,
        source.filename().string(), std::filesystem::path(argv[5]).stem().string());
  }
  return header(first);
}

}  // namespace

int main(int argc, char** argv) {
  const bool compact = argc == 6 && std::string(argv[1]) == "--compact";
  if (argc != 3 && !compact) {
    std::fprintf(stderr,
                 "usage: lslam-stream-header DATASET OUT.h\n"
                 "       lslam-stream-header --landmarks-3d OUT.g2o\n"
                 "       lslam-stream-header --compact N DATASET TRUTH OUT.h\n");
    return 2;
  }
  try {
    const std::string text = run(argc, argv);
    if (text.empty()) return 0;
    const char* path = argv[argc - 1];
    std::ofstream out(path, std::ios::binary);
    out << text;
    if (!out.flush()) throw std::runtime_error(std::string("cannot write ") + path);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lslam-stream-header: %s\n", e.what());
    return 1;
  }
  return 0;
}
