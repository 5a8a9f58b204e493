#pragma once
// Test-only references for SE(2) code: central finite differences, poses as 3x3 homogeneous
// matrices, and Exp/Log by Eigen's general matrix exponential and logarithm. None of it calls
// SE2's group operations, so a test that compares SE2 against these can actually fail.
#include <doctest/doctest.h>

#include "lslam/geometry/se2.h"
#include "matrix_functions.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <random>
#include <type_traits>

namespace lslam::test {

constexpr double kPi = 3.14159265358979323846;
constexpr double kStep = 1e-6;  // central differences: truncation ~h^2, rounding ~1e-16/h

// ---- Homogeneous-matrix references ---------------------------------------------------------

// Built from the stored (x, y, theta) alone.
inline Mat3 toMatrix(const SE2& pose) {
  const double c = std::cos(pose.theta());
  const double s = std::sin(pose.theta());
  Mat3 m;
  m << c, -s, pose.x(), s, c, pose.y(), 0.0, 0.0, 1.0;
  return m;
}

inline SE2 fromMatrix(const Mat3& m) {
  return SE2(m(0, 2), m(1, 2), std::atan2(m(1, 0), m(0, 0)));
}

// se(2) element of tau = (vx, vy, w).
inline Mat3 hat(const Vec3& tau) {
  Mat3 m;
  m << 0.0, -tau(2), tau(0), tau(2), 0.0, tau(1), 0.0, 0.0, 0.0;
  return m;
}

inline Vec3 vee(const Mat3& m) {
  return Vec3(m(0, 2), m(1, 2), m(1, 0));
}

inline Mat3 expMatrix(const Vec3& tau) {
  return matrixExp(hat(tau));
}

// Principal matrix logarithm: valid for rotation angles strictly inside (-pi, pi).
inline Vec3 logMatrix(const Mat3& m) {
  return vee(matrixLog(m));
}

// x * Exp(tau), by matrix exponential.
inline SE2 referenceRetract(const SE2& x, const Vec3& tau) {
  return fromMatrix(toMatrix(x) * expMatrix(tau));
}

// Log(a^-1 b) by matrix logarithm, for nearby a and b.
inline Vec3 referenceMinus(const SE2& b, const SE2& a) {
  return logMatrix(toMatrix(a).inverse() * toMatrix(b));
}

template <class A, class B>
double maxAbsDiff(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

// Poses compared as matrices, so that theta = pi and theta = -pi + 1e-17 count as close.
inline double poseDistance(const SE2& a, const SE2& b) {
  return maxAbsDiff(toMatrix(a), toMatrix(b));
}

// ---- Central finite differences ------------------------------------------------------------

// The difference of two function values in the tangent space at the second.
template <int R>
Eigen::Matrix<double, R, 1> difference(const Eigen::Matrix<double, R, 1>& a,
                                       const Eigen::Matrix<double, R, 1>& b) {
  return a - b;
}
inline Vec3 difference(const SE2& a, const SE2& b) {
  return referenceMinus(a, b);
}

template <class T>
struct TangentOf {
  using Type = T;
};
template <>
struct TangentOf<SE2> {
  using Type = Vec3;
};

template <class F, class In>
using JacobianOf =
    Eigen::Matrix<double,
                  TangentOf<std::decay_t<std::invoke_result_t<F, In>>>::Type::RowsAtCompileTime,
                  TangentOf<In>::Type::RowsAtCompileTime>;

// d f(x Exp(tau)) / d tau at tau = 0, for f returning a fixed-size vector or an SE2 (whose
// change is then measured in its own tangent space, Log(f(x)^-1 f(x Exp(tau)))).
template <class F>
JacobianOf<F, SE2> numericalJacobianSE2(F f, const SE2& x, double h = kStep) {
  JacobianOf<F, SE2> jacobian;
  const auto y0 = f(x);
  for (int k = 0; k < 3; ++k) {
    Vec3 tau = Vec3::Zero();
    tau(k) = h;
    jacobian.col(k) = (difference(f(referenceRetract(x, tau)), y0) -
                       difference(f(referenceRetract(x, -tau)), y0)) /
                      (2.0 * h);
  }
  return jacobian;
}

// d f(v + dv) / d dv at dv = 0, for a fixed-size vector v.
template <class F, int N>
JacobianOf<F, Eigen::Matrix<double, N, 1>> numericalJacobian(F f,
                                                             const Eigen::Matrix<double, N, 1>& v,
                                                             double h = kStep) {
  JacobianOf<F, Eigen::Matrix<double, N, 1>> jacobian;
  const auto y0 = f(v);
  for (int k = 0; k < N; ++k) {
    Eigen::Matrix<double, N, 1> dv = Eigen::Matrix<double, N, 1>::Zero();
    dv(k) = h;
    jacobian.col(k) = (difference(f(v + dv), y0) - difference(f(v - dv), y0)) / (2.0 * h);
  }
  return jacobian;
}

// True when every entry agrees to tol, absolutely for small entries and relatively for large.
template <class A, class B>
bool jacobianNear(const Eigen::MatrixBase<A>& analytic, const Eigen::MatrixBase<B>& numeric,
                  double tol = 1e-6) {
  for (Eigen::Index r = 0; r < analytic.rows(); ++r) {
    for (Eigen::Index c = 0; c < analytic.cols(); ++c) {
      const double scale = std::max(1.0, std::abs(numeric(r, c)));
      if (!(std::abs(analytic(r, c) - numeric(r, c)) <= tol * scale)) return false;
    }
  }
  return true;
}

// ---- Random cases from a fixed seed --------------------------------------------------------

// Angles cycle through the regimes where SE(2) code goes wrong: generic, near +pi and -pi
// (the wrap cut), tiny and exactly zero (the 0/0 of Exp/Log), and both sides of the switches
// between Taylor series and closed forms.
inline double randomAngle(std::mt19937& rng, int case_index) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double u = unit(rng);
  const double sign = unit(rng) < 0.5 ? -1.0 : 1.0;
  switch (case_index % 9) {
    case 0:
      return kPi * (2.0 * u - 1.0);
    case 1:
      return kPi - 1e-6 * u;
    case 2:
      return -kPi + 1e-6 * u;
    case 3:
      return sign * 1e-12 * u;
    case 4:
      return 0.0;
    case 5:
      return sign * (0.3 + 1e-6 * (2.0 * u - 1.0));
    case 6:
      return sign * (1e-4 + 1e-9 * (2.0 * u - 1.0));
    case 7:
      return sign * 1e-3 * u;
    default:
      return 3.0 * (2.0 * u - 1.0);
  }
}

inline SE2 randomPose(std::mt19937& rng, int case_index) {
  std::uniform_real_distribution<double> coordinate(-10.0, 10.0);
  const double x = coordinate(rng);
  const double y = coordinate(rng);
  return SE2(x, y, randomAngle(rng, case_index));
}

inline Vec3 randomTangent(std::mt19937& rng, int case_index) {
  std::uniform_real_distribution<double> coordinate(-5.0, 5.0);
  const double vx = coordinate(rng);
  const double vy = coordinate(rng);
  return Vec3(vx, vy, randomAngle(rng, case_index));
}

}  // namespace lslam::test

// A Jacobian check that prints both matrices when they differ.
#define CHECK_JACOBIAN(analytic, numeric)                             \
  do {                                                                \
    INFO("analytic:\n" << (analytic) << "\nnumeric:\n" << (numeric)); \
    CHECK(jacobianNear((analytic), (numeric)));                       \
  } while (false)
