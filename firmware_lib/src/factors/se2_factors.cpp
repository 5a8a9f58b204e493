#include "lslam/factors/se2_factors.h"

#include <cmath>

#include "lslam/geometry/sin_cos.h"

// Derivation. Write a pose as (t, R) and let J = [0 -1; 1 0], so that R(w) = I + w J to first
// order. The residual pose is E = z^-1 xi^-1 xj with
//   t_E = Rz^T (Ri^T (tj - ti) - tz),   theta_E = thj - thi - thz.
//
// xj -> xj Exp(v, w): tj -> tj + Rj v, thj -> thj + w, hence
//   d t_E = Rz^T Ri^T Rj v = R(theta_E) v,   d theta_E = w,
//   J_e_xj = [R(theta_E) 0; 0 1].
//
// xi -> xi Exp(v, w): ti -> ti + Ri v and Ri^T -> (I - w J) Ri^T. With d = Ri^T (tj - ti),
//   d -> (I - w J)(d - v) = d - v - w J d,
//   d t_E = -Rz^T v - w Rz^T J d = -Rz^T v - w J u,   u = Rz^T d   (rotations commute with J),
//   J_e_xi = [-Rz^T  (uy, -ux)^T; 0 0 -1].
//
// The prior is the same error with xi fixed at the identity. The wrap of theta has derivative 1
// everywhere except on its cut, where the error itself jumps.

namespace lslam {
namespace {

// [R(theta) 0; 0 1]
Mat3 rotationBlock(double theta) noexcept {
  const auto [s, c] = sinCos(theta);
  Mat3 m;
  m << c, -s, 0.0,  //
      s, c, 0.0,    //
      0.0, 0.0, 1.0;
  return m;
}

}  // namespace

Vec3 betweenErrorSE2(const SE2& xi, const SE2& xj, const SE2& z, Mat3* J_e_xi,
                     Mat3* J_e_xj) noexcept {
  const auto [si, ci] = sinCos(xi.theta());
  const auto [sz, cz] = sinCos(z.theta());
  const double wx = xj.x() - xi.x();
  const double wy = xj.y() - xi.y();
  // d: translation of xi^-1 xj
  const double dx = ci * wx + si * wy;
  const double dy = -si * wx + ci * wy;
  const double ex = dx - z.x();
  const double ey = dy - z.y();
  const double e_theta = wrapAngle(xj.theta() - xi.theta() - z.theta());
  if (J_e_xi != nullptr) {
    const double ux = cz * dx + sz * dy;
    const double uy = -sz * dx + cz * dy;
    *J_e_xi << -cz, -sz, uy,  //
        sz, -cz, -ux,         //
        0.0, 0.0, -1.0;
  }
  if (J_e_xj != nullptr) *J_e_xj = rotationBlock(e_theta);
  return Vec3(cz * ex + sz * ey, -sz * ex + cz * ey, e_theta);
}

Vec3 linearizeBetweenSE2(const SE2& xi, const SE2& xj, const SE2& z, const Mat3& information,
                         Mat3* ii, Mat3* jj, Mat3* ji, Vec3* eta_i, Vec3* eta_j) noexcept {
  Mat3 j_i;
  Mat3 j_j;
  const Vec3 err = betweenErrorSE2(xi, xj, z, &j_i, &j_j);
  const Vec3 o0 = information.col(0);
  const Vec3 o1 = information.col(1);
  const Vec3 o2 = information.col(2);
  // Omega J: a column k < 2 mixes Omega's first two columns by the block's column k.
  Mat3 o_i;
  o_i.col(0) = o0 * j_i(0, 0) + o1 * j_i(1, 0);
  o_i.col(1) = o0 * j_i(0, 1) + o1 * j_i(1, 1);
  o_i.col(2) = o0 * j_i(0, 2) + o1 * j_i(1, 2) - o2;
  Mat3 o_j;
  o_j.col(0) = o0 * j_j(0, 0) + o1 * j_j(1, 0);
  o_j.col(1) = o0 * j_j(0, 1) + o1 * j_j(1, 1);
  o_j.col(2) = o2;
  const Vec3 o_err = information * err;
  // J^T (Omega J): row r < 2 mixes the first two rows by the block's column r.
  for (int r = 0; r < 2; ++r) {
    ii->row(r) = j_i(0, r) * o_i.row(0) + j_i(1, r) * o_i.row(1);
    jj->row(r) = j_j(0, r) * o_j.row(0) + j_j(1, r) * o_j.row(1);
    ji->row(r) = j_j(0, r) * o_i.row(0) + j_j(1, r) * o_i.row(1);
    (*eta_i)(r) = -(j_i(0, r) * o_err(0) + j_i(1, r) * o_err(1));
    (*eta_j)(r) = -(j_j(0, r) * o_err(0) + j_j(1, r) * o_err(1));
  }
  ii->row(2) = j_i(0, 2) * o_i.row(0) + j_i(1, 2) * o_i.row(1) - o_i.row(2);
  jj->row(2) = o_j.row(2);
  ji->row(2) = o_i.row(2);
  (*eta_i)(2) = -(j_i(0, 2) * o_err(0) + j_i(1, 2) * o_err(1) - o_err(2));
  (*eta_j)(2) = -o_err(2);
  return err;
}

Vec3 priorErrorSE2(const SE2& x, const SE2& z, Mat3* J_e_x) noexcept {
  const auto [sz, cz] = sinCos(z.theta());
  const double ex = x.x() - z.x();
  const double ey = x.y() - z.y();
  const double e_theta = wrapAngle(x.theta() - z.theta());
  if (J_e_x != nullptr) *J_e_x = rotationBlock(e_theta);
  return Vec3(cz * ex + sz * ey, -sz * ex + cz * ey, e_theta);
}

}  // namespace lslam
