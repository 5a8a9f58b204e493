// lslam-stream-header: writes the C++ header that embeds a dataset's online step stream and the
// host's reference results for the target programs (see host_sim/stream_header.h).
//
//   lslam-stream-header DATASET OUT.h
// The namespace inside lslam::stream is the dataset's file name without its extension, e.g.
// data/manhattan_world_500.g2o -> lslam::stream::manhattan_world_500.
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>

#include "host_sim/dataset_io.h"
#include "host_sim/stream_header.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: lslam-stream-header DATASET OUT.h\n");
    return 2;
  }
  try {
    const std::filesystem::path source(argv[1]);
    const std::string header = lslam::sim::streamHeader(
        lslam::sim::readDataset2D(argv[1]), source.filename().string(), source.stem().string());
    std::ofstream out(argv[2], std::ios::binary);
    out << header;
    if (!out.flush()) throw std::runtime_error(std::string("cannot write ") + argv[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lslam-stream-header: %s\n", e.what());
    return 1;
  }
  return 0;
}
