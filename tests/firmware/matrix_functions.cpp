#include "matrix_functions.h"

#include <unsupported/Eigen/MatrixFunctions>

namespace lslam::test {

Eigen::Matrix3d matrixExp(const Eigen::Matrix3d& m) {
  return m.exp();
}

Eigen::Matrix4d matrixExp(const Eigen::Matrix4d& m) {
  return m.exp();
}

Eigen::Matrix3d matrixLog(const Eigen::Matrix3d& m) {
  return m.log();
}

Eigen::Matrix4d matrixLog(const Eigen::Matrix4d& m) {
  return m.log();
}

}  // namespace lslam::test
