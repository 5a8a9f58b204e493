#pragma once
// A synthetic world before its finishing touches (worlds.cpp): the true values and the noisy
// factors in online order, landmarks still named by their index in `landmarks`. Each world's draft
// lives in its own file (world_<name>.cpp). Private to host_sim/src.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "host_sim/model_dataset.h"
#include "host_sim/synthetic_3d.h"
#include "host_sim/worlds.h"
#include "portable_random.h"

namespace lslam::sim::detail {

struct WorldDraft {
  std::string name;
  int dimension = 2;
  std::vector<Eigen::VectorXd> poses;      // true parameters of pose i (SE2 or SE3)
  std::vector<Eigen::VectorXd> landmarks;  // true positions; factors name {Landmark, index}
  std::vector<ModelFactor> factors;        // online order
};

WorldDraft draftGrid2D(const WorldOptions& o);
WorldDraft draftSphere3D(const WorldOptions& o);
WorldDraft draftGarage3D(const WorldOptions& o);
WorldDraft draftPoints3D(const WorldOptions& o);
// The landmark world of synthetic_3d.h, which draftPoints3D and generateLandmarkWorld3D finish.
WorldDraft draftLandmarkWorld3D(const Synthetic3DOptions& o);

// The newest pose a factor involves (its step in online order).
std::int64_t newestPose(const ModelFactor& f);

}  // namespace lslam::sim::detail
