// Tests of the 3D landmark stream header the target programs embed
// (host_sim/model_stream_header.h): the committed data/landmarks_3d_300_stream.h must be exactly
// what the host generates now from data/landmarks_3d_300.g2o, and that file what the generator
// (host_sim/synthetic_3d.h) writes.
#include <doctest/doctest.h>

#include "read_file.h"

#include <cstdint>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

#include "host_sim/model_dataset.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/model_stream_header.h"
#include "host_sim/synthetic_3d.h"

using lslam::sim::ModelDataset;
using lslam::sim::modelStreamHeader;

namespace {

const std::string kDataDir = LSLAM_DATA_DIR;

using lslam::test::firstDifferingLine;
using lslam::test::readFile;

}  // namespace

TEST_CASE("the committed landmarks_3d_300 dataset is what the generator writes") {
  std::ostringstream generated;
  lslam::sim::writeModelG2o(generated, lslam::sim::generateLandmarkWorld3D());
  const std::string committed = readFile(kDataDir + "/landmarks_3d_300.g2o");
  CHECK_MESSAGE(firstDifferingLine(committed, generated.str()) == 0,
                "data/landmarks_3d_300.g2o is stale; regenerate it with\n"
                "  build/ci/host_sim/lslam-stream-header --landmarks-3d data/landmarks_3d_300.g2o");
}

TEST_CASE("the committed landmarks_3d_300 stream header is what the host generates now") {
  const ModelDataset d = lslam::sim::readModelDataset(kDataDir + "/landmarks_3d_300.g2o");
  const std::string generated = modelStreamHeader(d, "landmarks_3d_300.g2o", "landmarks_3d_300");
  const std::string committed = readFile(kDataDir + "/landmarks_3d_300_stream.h");
  CHECK_MESSAGE(firstDifferingLine(committed, generated) == 0,
                "data/landmarks_3d_300_stream.h is stale; regenerate it with\n"
                "  build/ci/host_sim/lslam-stream-header data/landmarks_3d_300.g2o "
                "data/landmarks_3d_300_stream.h");
}

TEST_CASE("modelStreamHeader is deterministic and holds every step, variable and measurement") {
  const ModelDataset d = lslam::sim::readModelDataset(kDataDir + "/landmarks_3d_300.g2o");
  const std::string a = modelStreamHeader(d, "m.g2o", "m");
  CHECK(a == modelStreamHeader(d, "m.g2o", "m"));
  CHECK(a.find("kNumSteps = 300;") != std::string::npos);
  CHECK(a.find("kNumVariables = " + std::to_string(d.vertices.size()) + ";") != std::string::npos);
  CHECK(a.find("kNumFactors = " + std::to_string(d.factors.size()) + ";") != std::string::npos);
  CHECK(a.find("namespace lslam::stream::m {") != std::string::npos);
}

TEST_CASE("the generator is deterministic and gives each landmark several observations") {
  const ModelDataset a = lslam::sim::generateLandmarkWorld3D();
  std::ostringstream ta, tb;
  lslam::sim::writeModelG2o(ta, a);
  lslam::sim::writeModelG2o(tb, lslam::sim::generateLandmarkWorld3D());
  CHECK(ta.str() == tb.str());
  std::map<std::int64_t, int> observations;
  int loops = 0;
  for (const lslam::sim::ModelFactor& f : a.factors) {
    if (f.kind == lslam::sim::FactorKind::PointXYZ3) ++observations[f.second.id];
    if (f.kind == lslam::sim::FactorKind::BetweenSE3 && f.second.id != f.first.id + 1) ++loops;
  }
  CHECK(loops > 10);
  CHECK(observations.size() > 10);
  for (const auto& [landmark, count] : observations) CHECK(count >= 2);
}

TEST_CASE("modelStreamHeader rejects datasets outside its model and bad namespaces") {
  const ModelDataset d = lslam::sim::readModelDataset(kDataDir + "/landmarks_3d_300.g2o");
  CHECK_THROWS_AS(modelStreamHeader(d, "x.g2o", "2bad"), std::invalid_argument);
  CHECK_THROWS_AS(modelStreamHeader(d, "x.g2o", "a-b"), std::invalid_argument);
  ModelDataset poses_only = d;
  poses_only.factors.clear();
  for (const lslam::sim::ModelFactor& f : d.factors) {
    if (f.kind == lslam::sim::FactorKind::BetweenSE3) poses_only.factors.push_back(f);
  }
  CHECK_THROWS_AS(modelStreamHeader(poses_only, "x.g2o", "x"), std::invalid_argument);
}
