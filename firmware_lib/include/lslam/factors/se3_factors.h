#pragma once
// Error functions of the 3D pose factors, in the g2o SE3:QUAT convention so that chi2 values and
// information matrices read from g2o datasets (EDGE_SE3:QUAT) mean the same thing here: the error
// of a residual pose D = (q, t) is e = (t, v) with v the vector part of the quaternion of D taken
// with w >= 0 (sin(angle/2) times the axis, not the rotation vector). The information's rotation
// block is therefore w.r.t. that vector part (about 4x the information w.r.t. angles).
//
// The error is discontinuous where the residual rotation crosses a half turn (w = 0): v jumps to
// -v there. Away from it, Jacobians are w.r.t. right perturbations of the poses,
// X (+) tau = X * Exp(tau) with tau = (rho, phi) as in se3.h; each output pointer may be nullptr.
#include "lslam/eigen.h"
#include "lslam/factors/information.h"
#include "lslam/geometry/se3.h"
#include "lslam/type_list.h"

namespace lslam {

// Between factor: z is the measured pose of xj seen from xi.
// e = (t, v with w >= 0) of z^-1 * (xi^-1 * xj).
Vec6 betweenErrorSE3(const SE3& xi, const SE3& xj, const SE3& z, Mat6* J_e_xi = nullptr,
                     Mat6* J_e_xj = nullptr) noexcept;

// The between factor's share of Lambda and eta: with J_i, J_j the Jacobians above and Omega the
// information, ii = J_i^T Omega J_i, jj = J_j^T Omega J_j, ji = J_j^T Omega J_i,
// eta_i = -J_i^T Omega e and eta_j = -J_j^T Omega e, computed over the Jacobians' block structure
// (a factor is linearized at every full assembly). Returns e.
Vec6 linearizeBetweenSE3(const SE3& xi, const SE3& xj, const SE3& z, const Mat6& information,
                         Mat6* ii, Mat6* jj, Mat6* ji, Vec6* eta_i, Vec6* eta_j) noexcept;

// Prior factor: z is the measured pose of x.
// e = (t, v with w >= 0) of z^-1 * x.
Vec6 priorErrorSE3(const SE3& x, const SE3& z, Mat6* J_e_x = nullptr) noexcept;

// ---- Factor kinds (the entries of a model's factor list; see lslam/models/) ----------------
// Each names its variables, its measurement and error dimension, the error with its Jacobians and
// the check of an input (measurement and information).

struct PriorSE3Factor {
  using Variables = TypeList<SE3>;
  using Measurement = SE3;
  static constexpr int kErrorDim = 6;
  static Vec6 error(const SE3& x, const SE3& z, Mat6* J_e_x) noexcept {
    return priorErrorSE3(x, z, J_e_x);
  }
  [[nodiscard]] static Status validate(const SE3& z, const Mat6& information) noexcept {
    const Status s = validateValue(z);
    return s != Status::Ok ? s : checkInformation(information);
  }
};

struct BetweenSE3Factor {
  using Variables = TypeList<SE3, SE3>;
  using Measurement = SE3;
  static constexpr int kErrorDim = 6;
  static Vec6 error(const SE3& xi, const SE3& xj, const SE3& z, Mat6* J_e_xi,
                    Mat6* J_e_xj) noexcept {
    return betweenErrorSE3(xi, xj, z, J_e_xi, J_e_xj);
  }
  // The factor graph linearizes this kind through linearizeBetweenSE3.
  static void linearize(const SE3& xi, const SE3& xj, const SE3& z, const Mat6& information,
                        Mat6* ii, Mat6* jj, Mat6* ji, Vec6* eta_i, Vec6* eta_j) noexcept {
    static_cast<void>(linearizeBetweenSE3(xi, xj, z, information, ii, jj, ji, eta_i, eta_j));
  }
  [[nodiscard]] static Status validate(const SE3& z, const Mat6& information) noexcept {
    return PriorSE3Factor::validate(z, information);
  }
};

}  // namespace lslam
