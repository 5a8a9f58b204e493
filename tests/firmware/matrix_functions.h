#pragma once
// The general matrix exponential and principal logarithm (Eigen's unsupported MatrixFunctions) at
// the sizes the Lie-group references take them: 3 x 3 (se(2) and so(3)) and 4 x 4 (se(3)).
// Compiled once (matrix_functions.cpp) for every test: instantiated in each test that includes
// the references, they took most of those files' compile time.
#include <Eigen/Core>

namespace lslam::test {

Eigen::Matrix3d matrixExp(const Eigen::Matrix3d& m);
Eigen::Matrix4d matrixExp(const Eigen::Matrix4d& m);
// Principal logarithm: valid where no eigenvalue lies on the closed negative real axis (rotation
// angles strictly below pi).
Eigen::Matrix3d matrixLog(const Eigen::Matrix3d& m);
Eigen::Matrix4d matrixLog(const Eigen::Matrix4d& m);

}  // namespace lslam::test
