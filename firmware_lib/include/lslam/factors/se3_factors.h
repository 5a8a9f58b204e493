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
#include "lslam/geometry/se3.h"

namespace lslam {

// Between factor: z is the measured pose of xj seen from xi.
// e = (t, v with w >= 0) of z^-1 * (xi^-1 * xj).
Vec6 betweenErrorSE3(const SE3& xi, const SE3& xj, const SE3& z, Mat6* J_e_xi = nullptr,
                     Mat6* J_e_xj = nullptr) noexcept;

// Prior factor: z is the measured pose of x.
// e = (t, v with w >= 0) of z^-1 * x.
Vec6 priorErrorSE3(const SE3& x, const SE3& z, Mat6* J_e_x = nullptr) noexcept;

}  // namespace lslam
