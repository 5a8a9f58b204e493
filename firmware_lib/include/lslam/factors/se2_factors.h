#pragma once
// Error functions of the 2D pose factors, in the g2o convention so that chi2 values and
// information matrices read from g2o/TORO datasets mean the same thing here: the error is the
// (x, y, wrapped theta) vector of a residual pose, not the Lie logarithm of it.
//
// Jacobians are w.r.t. right perturbations of the poses (x (+) tau = x * Exp(tau)); each output
// pointer may be nullptr. These run once per factor per linearization, so they are written out
// by hand rather than chained from SE2's group operations.
#include "lslam/eigen.h"
#include "lslam/factors/information.h"
#include "lslam/geometry/se2.h"
#include "lslam/type_list.h"

namespace lslam {

// Between factor: z is the measured pose of xj seen from xi.
// e = (x, y, wrapAngle(theta)) of z^-1 * (xi^-1 * xj).
Vec3 betweenErrorSE2(const SE2& xi, const SE2& xj, const SE2& z, Mat3* J_e_xi = nullptr,
                     Mat3* J_e_xj = nullptr) noexcept;

// The between factor's share of Lambda and eta: with J_i, J_j the Jacobians above and Omega the
// information, ii = J_i^T Omega J_i, jj = J_j^T Omega J_j, ji = J_j^T Omega J_i, eta_i = -J_i^T
// Omega e, eta_j = -J_j^T Omega e. Written out over the Jacobians' known zeros and ones
// (J_j = [R 0; 0 1], J_i = [M p; 0 -1] with 2 x 2 blocks R, M): 91 multiplications where the
// general products take 162, for a factor linearized at every column assembly; the dropped terms
// are exact zeros and the unit factors exact. Returns e.
Vec3 linearizeBetweenSE2(const SE2& xi, const SE2& xj, const SE2& z, const Mat3& information,
                         Mat3* ii, Mat3* jj, Mat3* ji, Vec3* eta_i, Vec3* eta_j) noexcept;

// Prior factor: z is the measured pose of x.
// e = (x, y, theta) of z^-1 * x.
Vec3 priorErrorSE2(const SE2& x, const SE2& z, Mat3* J_e_x = nullptr) noexcept;

// ---- Factor kinds (the entries of a model's factor list; see lslam/models/) ----------------
// Each names its variables, its measurement and error dimension, the error with its Jacobians and
// the check of an input (measurement and information).

struct PriorSE2Factor {
  using Variables = TypeList<SE2>;
  using Measurement = SE2;
  static constexpr int kErrorDim = 3;
  static Vec3 error(const SE2& x, const SE2& z, Mat3* J_e_x) noexcept {
    return priorErrorSE2(x, z, J_e_x);
  }
  [[nodiscard]] static Status validate(const SE2& z, const Mat3& information) noexcept {
    const Status s = validateValue(z);
    return s != Status::Ok ? s : checkInformation(information);
  }
};

struct BetweenSE2Factor {
  using Variables = TypeList<SE2, SE2>;
  using Measurement = SE2;
  static constexpr int kErrorDim = 3;
  static Vec3 error(const SE2& xi, const SE2& xj, const SE2& z, Mat3* J_e_xi,
                    Mat3* J_e_xj) noexcept {
    return betweenErrorSE2(xi, xj, z, J_e_xi, J_e_xj);
  }
  // The factor graph linearizes this kind through linearizeBetweenSE2 (a kind without
  // `linearize` takes the general products).
  static void linearize(const SE2& xi, const SE2& xj, const SE2& z, const Mat3& information,
                        Mat3* ii, Mat3* jj, Mat3* ji, Vec3* eta_i, Vec3* eta_j) noexcept {
    static_cast<void>(linearizeBetweenSE2(xi, xj, z, information, ii, jj, ji, eta_i, eta_j));
  }
  [[nodiscard]] static Status validate(const SE2& z, const Mat3& information) noexcept {
    return PriorSE2Factor::validate(z, information);
  }
};

}  // namespace lslam
