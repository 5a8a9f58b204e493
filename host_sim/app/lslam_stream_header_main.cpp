// lslam-stream-header: writes the C++ header that embeds a dataset's online step stream and the
// host's reference results for the target programs (see host_sim/stream_header.h for 2D pose
// graphs, host_sim/model_stream_header.h for 3D datasets with landmarks).
//
//   lslam-stream-header DATASET OUT.h
//   lslam-stream-header --landmarks-3d OUT.g2o   (writes the synthetic 3D landmark dataset of
//                                                 host_sim/synthetic_3d.h, default options)
// The namespace inside lslam::stream is the dataset's file name without its extension, e.g.
// data/manhattan_world_500.g2o -> lslam::stream::manhattan_world_500.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "host_sim/model_dataset_io.h"
#include "host_sim/model_run.h"
#include "host_sim/model_stream_header.h"
#include "host_sim/stream_header.h"
#include "host_sim/synthetic_3d.h"

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

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr,
                 "usage: lslam-stream-header DATASET OUT.h\n"
                 "       lslam-stream-header --landmarks-3d OUT.g2o\n");
    return 2;
  }
  try {
    if (std::string(argv[1]) == "--landmarks-3d") {
      lslam::sim::writeModelG2oFile(argv[2], lslam::sim::generateLandmarkWorld3D());
      return 0;
    }
    const std::string text = header(argv[1]);
    std::ofstream out(argv[2], std::ios::binary);
    out << text;
    if (!out.flush()) throw std::runtime_error(std::string("cannot write ") + argv[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lslam-stream-header: %s\n", e.what());
    return 1;
  }
  return 0;
}
