#include "matrix_functions.h"

#include <unsupported/Eigen/MatrixFunctions>

namespace lslam::test {
namespace {
// At dynamic size: one instantiation of each function for both sizes (each costs tens of seconds
// of compile).
Eigen::MatrixXd dynamicExp(const Eigen::MatrixXd& m) {
  return m.exp();
}
Eigen::MatrixXd dynamicLog(const Eigen::MatrixXd& m) {
  return m.log();
}
}  // namespace

Eigen::Matrix3d matrixExp(const Eigen::Matrix3d& m) {
  return dynamicExp(m);
}
Eigen::Matrix4d matrixExp(const Eigen::Matrix4d& m) {
  return dynamicExp(m);
}
Eigen::Matrix3d matrixLog(const Eigen::Matrix3d& m) {
  return dynamicLog(m);
}
Eigen::Matrix4d matrixLog(const Eigen::Matrix4d& m) {
  return dynamicLog(m);
}

}  // namespace lslam::test
