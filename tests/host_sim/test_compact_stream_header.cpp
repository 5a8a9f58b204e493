// The committed data/grid2d_20000_compact.h (the Cortex-M7's compact-map stream, see
// host_sim/compact_stream_header.h) must be exactly what the host generates now from
// `lslam-sim simulate grid2d grid2d_20000.g2o --steps 20000 --landmarks 0 --seed 3`, so that the
// target is checked against the current host; and the generator refuses what it cannot stream.
#include <doctest/doctest.h>

#include "read_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "host_sim/compact_stream_header.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/trajectory_error.h"
#include "host_sim/worlds.h"

using namespace lslam::sim;

namespace {

using lslam::test::readFile;

// The world as `simulate` writes it, read back as `lslam-stream-header` reads it.
struct WrittenWorld {
  ModelDataset dataset;
  ModelEstimate truth;
};

WrittenWorld writtenGrid(int steps, const std::string& name) {
  WorldOptions o = defaultWorldOptions(WorldKind::Grid2D);
  o.steps = steps;
  o.landmarks = 0;
  o.seed = 3;
  const SimulatedWorld world = simulateWorld(WorldKind::Grid2D, o);
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "lslam_compact_header";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / (name + ".g2o")).string();
  const std::string truth = (dir / (name + ".truth.g2o")).string();
  writeModelG2oFile(path, world.dataset);
  writeModelG2oFile(truth, world.truth);
  return WrittenWorld{readModelDataset(path), readGroundTruth(truth)};
}

}  // namespace

TEST_CASE("data/grid2d_20000_compact.h is what the host generates now") {
  const WrittenWorld w = writtenGrid(20000, "grid2d_20000");
  const std::string generated =
      compactStreamHeader(w.dataset, w.truth, 100, "grid2d_20000.g2o", "grid2d_20000_compact");
  const std::string committed = readFile(std::string(LSLAM_DATA_DIR) + "/grid2d_20000_compact.h");
  CHECK_MESSAGE(generated == committed,
                "regenerate it: lslam-sim simulate grid2d grid2d_20000.g2o --steps 20000 "
                "--landmarks 0 --seed 3 && lslam-stream-header --compact 100 grid2d_20000.g2o "
                "grid2d_20000.truth.g2o data/grid2d_20000_compact.h");
}

TEST_CASE("the compact stream generator refuses what it cannot stream") {
  const WrittenWorld w = writtenGrid(300, "grid2d_300");
  CHECK_THROWS_AS(compactStreamHeader(w.dataset, w.truth, 300, "g", "g"), std::invalid_argument);
  CHECK_THROWS_AS(compactStreamHeader(w.dataset, w.truth, 1, "g", "g"), std::invalid_argument);
  CHECK_THROWS_AS(compactStreamHeader(w.dataset, w.truth, 50, "g", "1g"), std::invalid_argument);
  ModelDataset other = w.dataset;
  for (ModelFactor& f : other.factors) {
    if (f.first.id == 150 && f.second.id == 151) f.information(0, 0) *= 2.0;  // one odometry
  }
  CHECK_THROWS_AS(compactStreamHeader(other, w.truth, 50, "g", "g"), std::invalid_argument);
  ModelEstimate partial = w.truth;
  partial.erase(VariableKey{VariableRole::Pose, 7});
  CHECK_THROWS_AS(compactStreamHeader(w.dataset, partial, 50, "g", "g"), std::invalid_argument);
  CHECK_NOTHROW(compactStreamHeader(w.dataset, w.truth, 50, "g", "g"));
}
