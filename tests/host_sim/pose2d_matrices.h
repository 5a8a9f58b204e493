#pragma once
// A 2D pose as its homogeneous 3 x 3 matrix and back: the tests' reference for composing poses,
// independent of the code under test.
#include <Eigen/Dense>
#include <cmath>

#include "host_sim/dataset.h"

namespace lslam::test {

inline Eigen::Matrix3d homogeneous(const sim::Pose2D& p) {
  Eigen::Matrix3d t;
  t << std::cos(p.theta), -std::sin(p.theta), p.x,  //
      std::sin(p.theta), std::cos(p.theta), p.y,    //
      0.0, 0.0, 1.0;
  return t;
}

inline sim::Pose2D fromHomogeneous(const Eigen::Matrix3d& t) {
  return sim::Pose2D{t(0, 2), t(1, 2), std::atan2(t(1, 0), t(0, 0))};
}

}  // namespace lslam::test
