// Tests of the stream header the target programs embed (host_sim/stream_header.h): the committed
// data/manhattan_world_500_stream.h must be exactly what the host generates now, so the target is
// always checked against the current host results.
#include <doctest/doctest.h>

#include "read_file.h"

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "host_sim/model_dataset.h"
#include "host_sim/model_dataset_io.h"
#include "host_sim/stream_header.h"

using lslam::sim::ModelDataset;
using lslam::sim::ModelFactor;
using lslam::sim::streamHeader;
using lslam::sim::VariableRole;

namespace {

const std::string kDataDir = LSLAM_DATA_DIR;

using lslam::test::firstDifferingLine;
using lslam::test::readFile;

}  // namespace

TEST_CASE("the committed manhattan_world_500 stream header is what the host generates now") {
  const ModelDataset d = lslam::sim::readModelDataset(kDataDir + "/manhattan_world_500.g2o");
  const std::string generated = streamHeader(d, "manhattan_world_500.g2o", "manhattan_world_500");
  const std::string committed = readFile(kDataDir + "/manhattan_world_500_stream.h");
  CHECK_MESSAGE(firstDifferingLine(committed, generated) == 0,
                "data/manhattan_world_500_stream.h is stale; regenerate it with\n"
                "  build/ci/host_sim/lslam-stream-header data/manhattan_world_500.g2o "
                "data/manhattan_world_500_stream.h");
}

TEST_CASE("streamHeader is deterministic and holds every step and measurement") {
  const ModelDataset d = lslam::sim::readModelDataset(kDataDir + "/manhattan_world_500.g2o");
  const std::string a = streamHeader(d, "m.g2o", "m");
  CHECK(a == streamHeader(d, "m.g2o", "m"));
  CHECK(a.find("kNumSteps = 500;") != std::string::npos);
  CHECK(a.find("kNumFactors = " + std::to_string(d.factors.size()) + ";") != std::string::npos);
  CHECK(a.find("namespace lslam::stream::m {") != std::string::npos);
}

TEST_CASE("streamHeader rejects a namespace that is not an identifier and ids beyond 32 bits") {
  ModelDataset d;
  ModelFactor f;
  f.kind = lslam::sim::FactorKind::BetweenSE2;
  f.first = {VariableRole::Pose, 0};
  f.second = {VariableRole::Pose, 1};
  f.measurement = Eigen::Vector3d(1.0, 0.0, 0.0);
  f.information = Eigen::Matrix3d::Identity();
  d.factors.push_back(f);
  CHECK_THROWS_AS(streamHeader(d, "x.g2o", "2bad"), std::invalid_argument);
  CHECK_THROWS_AS(streamHeader(d, "x.g2o", "a-b"), std::invalid_argument);
  CHECK_NOTHROW(streamHeader(d, "x.g2o", "tiny"));
  d.factors[0].second.id = std::int64_t{1} << 32;
  CHECK_THROWS_AS(streamHeader(d, "x.g2o", "tiny"), std::invalid_argument);
  // Only between factors: a prior is not in the format; nor is a landmark.
  f.kind = lslam::sim::FactorKind::PriorSE2;
  d.factors = {f};
  CHECK_THROWS_AS(streamHeader(d, "x.g2o", "tiny"), std::invalid_argument);
}
