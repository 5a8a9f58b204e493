#pragma once
// Test-only references for SO(3) and SE(3) code: rotations and poses as 3x3 and 4x4 matrices,
// Exp/Log by Eigen's general matrix exponential and logarithm, central differences over right
// perturbations, and random axes, vectors and rotations. None of it calls SO3's or SE3's
// operations (only the constructors and the stored quaternion and translation), so a test that
// compares SO3 or SE3 against these can actually fail.
#include <doctest/doctest.h>

#include "lslam/geometry/se3.h"
#include "lslam/geometry/so3.h"
#include "numerical_diff.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>
#include <type_traits>
#include <utility>

namespace lslam::test {

// ---- Matrix references ---------------------------------------------------------------------

inline Mat3 hat3(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v(2), v(1), v(2), 0.0, -v(0), -v(1), v(0), 0.0;
  return m;
}

inline Vec3 vee3(const Mat3& m) {
  return Vec3(m(2, 1), m(0, 2), m(1, 0));
}

// se(3) element of tau = (rho, phi): translation part first.
inline Mat4 hat6(const Vec6& tau) {
  Mat4 m = Mat4::Zero();
  m.topLeftCorner<3, 3>() = hat3(tau.tail<3>());
  m.topRightCorner<3, 1>() = tau.head<3>();
  return m;
}

inline Vec6 vee6(const Mat4& m) {
  Vec6 tau;
  tau << m(0, 3), m(1, 3), m(2, 3), m(2, 1), m(0, 2), m(1, 0);
  return tau;
}

// R = (w^2 - |v|^2) I + 2 v v^T + 2 w [v]x, from the stored quaternion alone.
inline Mat3 rotationMatrix(const SO3& x) {
  const Eigen::Quaterniond& q = x.quaternion();
  const Vec3 v = q.vec();
  return (q.w() * q.w() - v.squaredNorm()) * Mat3::Identity() + 2.0 * v * v.transpose() +
         2.0 * q.w() * hat3(v);
}

inline SO3 rotationFromMatrix(const Mat3& r) {
  return SO3(Eigen::Quaterniond(r).normalized());
}

// From the stored rotation and translation alone.
inline Mat4 poseMatrix(const SE3& x) {
  Mat4 m = Mat4::Identity();
  m.topLeftCorner<3, 3>() = rotationMatrix(x.rotation());
  m.topRightCorner<3, 1>() = x.translation();
  return m;
}

inline SE3 poseFromMatrix(const Mat4& m) {
  return SE3(rotationFromMatrix(m.topLeftCorner<3, 3>()), m.topRightCorner<3, 1>());
}

inline Mat4 inverseMatrix(const Mat4& m) {
  Mat4 inv = Mat4::Identity();
  const Mat3 rt = m.topLeftCorner<3, 3>().transpose();
  inv.topLeftCorner<3, 3>() = rt;
  inv.topRightCorner<3, 1>() = -rt * m.topRightCorner<3, 1>();
  return inv;
}

inline Mat3 expMatrix3(const Vec3& phi) {
  return matrixExp(hat3(phi));
}

// Principal matrix logarithm: valid for angles strictly below pi.
inline Vec3 logMatrix3(const Mat3& r) {
  return vee3(matrixLog(r));
}

inline Mat4 expMatrix6(const Vec6& tau) {
  return matrixExp(hat6(tau));
}

// Principal matrix logarithm: valid for rotation angles strictly below pi.
inline Vec6 logMatrix6(const Mat4& m) {
  return vee6(matrixLog(m));
}

inline double rotationDistance(const SO3& a, const SO3& b) {
  return maxAbsDiff(rotationMatrix(a), rotationMatrix(b));
}

inline double poseDistance3(const SE3& a, const SE3& b) {
  return maxAbsDiff(poseMatrix(a), poseMatrix(b));
}

// The rotation angle in [0, pi], from the matrix (trace), not from SO3.
inline double referenceAngle(const SO3& x) {
  const double c = 0.5 * (rotationMatrix(x).trace() - 1.0);
  return std::acos(std::max(-1.0, std::min(1.0, c)));
}

inline double referenceAngle(const SE3& x) {
  return referenceAngle(x.rotation());
}

inline bool nearHalfTurn(double angle) {
  return angle > kPi - 1e-3;
}

// ---- Central differences over right perturbations ------------------------------------------

inline SO3 perturb(const SO3& x, const Vec3& d) {
  return rotationFromMatrix(rotationMatrix(x) * expMatrix3(d));
}
inline SE3 perturb(const SE3& x, const Vec6& d) {
  return poseFromMatrix(poseMatrix(x) * expMatrix6(d));
}
template <int N>
Eigen::Matrix<double, N, 1> perturb(const Eigen::Matrix<double, N, 1>& x,
                                    const Eigen::Matrix<double, N, 1>& d) {
  return x + d;
}

// Log(b^-1 a): the change from b to a in b's tangent space.
inline Vec3 minus(const SO3& a, const SO3& b) {
  return logMatrix3(rotationMatrix(b).transpose() * rotationMatrix(a));
}
inline Vec6 minus(const SE3& a, const SE3& b) {
  return logMatrix6(inverseMatrix(poseMatrix(b)) * poseMatrix(a));
}
template <int N>
Eigen::Matrix<double, N, 1> minus(const Eigen::Matrix<double, N, 1>& a,
                                  const Eigen::Matrix<double, N, 1>& b) {
  return a - b;
}

template <class X>
struct Dim {
  static constexpr int value = X::RowsAtCompileTime;
};
template <>
struct Dim<SO3> {
  static constexpr int value = 3;
};
template <>
struct Dim<SE3> {
  static constexpr int value = 6;
};

// d f(x (+) d) / d d at d = 0, with (+) the retraction for SO3 and SE3 and + for vectors, and the
// change of f measured in its own tangent space.
template <class F, class X>
auto centralJacobian(F f, const X& x, double h = kStep) {
  constexpr int N = Dim<X>::value;
  using Y = std::decay_t<decltype(f(x))>;
  constexpr int M = decltype(minus(std::declval<Y>(), std::declval<Y>()))::RowsAtCompileTime;
  using Step = Eigen::Matrix<double, N, 1>;
  Eigen::Matrix<double, M, N> jacobian;
  const Y y0 = f(x);
  for (int k = 0; k < N; ++k) {
    Step d = Step::Zero();
    d(k) = h;
    const Step minus_d = -d;
    jacobian.col(k) = (minus(f(perturb(x, d)), y0) - minus(f(perturb(x, minus_d)), y0)) / (2.0 * h);
  }
  return jacobian;
}

// ---- Random cases --------------------------------------------------------------------------

inline Vec3 randomAxis(std::mt19937& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Vec3 v;
  do {
    const double a = normal(rng);
    const double b = normal(rng);
    const double c = normal(rng);
    v = Vec3(a, b, c);
  } while (v.norm() < 1e-3);
  return v.normalized();
}

// Each coordinate uniform in [-half_width, half_width], drawn x, y, z in that order.
inline Vec3 randomVector(std::mt19937& rng, double half_width) {
  std::uniform_real_distribution<double> coordinate(-half_width, half_width);
  const double x = coordinate(rng);
  const double y = coordinate(rng);
  const double z = coordinate(rng);
  return Vec3(x, y, z);
}

// Built by Eigen's angle-axis conversion, not by SO3::exp.
inline SO3 angleAxisRotation(double angle, const Vec3& axis) {
  return SO3(Eigen::Quaterniond(Eigen::AngleAxisd(angle, axis)).normalized());
}

}  // namespace lslam::test
