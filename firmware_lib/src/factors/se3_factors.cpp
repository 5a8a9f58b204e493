#include "lslam/factors/se3_factors.h"

#include <Eigen/Geometry>

#include "lslam/geometry/so3.h"

// Derivation. The residual is D = z^-1 A with A = xi^-1 xj, and e(D) = (t_D, s v_D) with
// s = sign(w_D) (s = 1 at w_D = 0, as in SO3::log).
//
// 1) D w.r.t. the poses, as right perturbations of D:
//    xj -> xj Exp(tau):  D -> D Exp(tau)                                  (identity)
//    xi -> xi Exp(tau):  D -> z^-1 Exp(-tau) xi^-1 xj = D Exp(-Ad(A^-1) tau),
//    since z^-1 Exp(-tau) z D = D (z D)^-1 Exp(-tau) (z D) and z D = A.
//
// 2) e w.r.t. D Exp(rho, phi), to first order:
//    t_D -> t_D + R_D rho;
//    q_D -> q_D (1, phi/2), whose vector part is v + (w phi + v x phi)/2, so with the sign s
//    applied (s w = |w|, s v = the canonical v): d(s v)/d phi = (|w| I + [s v]x)/2 =: Q.
//    J_e_D = [R_D 0; 0 Q].
//
// 3) Chained: J_e_xj = J_e_D, and with Ad(A^-1) = [Ra^T -Ra^T [ta]x; 0 Ra^T] and
//    R_D Ra^T = Rz^T:  J_e_xi = -J_e_D Ad(A^-1) = [-Rz^T  Rz^T [ta]x; 0  -Q Ra^T].
//
// The prior is the same error with xi fixed at the identity (A = x).

namespace lslam {
namespace {

using Mat63 = Eigen::Matrix<double, 6, 3>;

// e(D) of the residual d, and the blocks R_D and Q of J_e_D = [R_D 0; 0 Q] when r_d is not
// nullptr (step 2 above).
Vec6 quaternionError(const SE3& d, Mat3* r_d, Mat3* q_block) noexcept {
  const Eigen::Quaterniond& q = d.rotation().quaternion();
  // q and -q are the same rotation; g2o takes the one with w >= 0.
  const double sign = q.w() < 0.0 ? -1.0 : 1.0;
  const double w = sign * q.w();
  const Vec3 v = sign * q.vec();
  if (r_d != nullptr) {
    *r_d = d.rotation().matrix();
    *q_block = 0.5 * (w * Mat3::Identity() + skew(v));
  }
  Vec6 e;
  e << d.translation(), v;
  return e;
}

// e(D) of the residual d, and J_e_D when jacobian is not nullptr.
Vec6 quaternionError(const SE3& d, Mat6* jacobian) noexcept {
  if (jacobian == nullptr) return quaternionError(d, nullptr, nullptr);
  Mat3 r_d;
  Mat3 q_block;
  const Vec6 e = quaternionError(d, &r_d, &q_block);
  *jacobian << r_d, Mat3::Zero(), Mat3::Zero(), q_block;
  return e;
}

// J_e_xi = -J_e_D Ad(A^-1), written out by blocks (step 3 above); q_block is Q of J_e_D.
Mat6 jacobianOfFirst(const SE3& a, const SE3& z, const Mat3& q_block) noexcept {
  const Mat3 rz_t = z.rotation().matrix().transpose();
  Mat6 m;
  m << -rz_t, rz_t * skew(a.translation()),  //
      Mat3::Zero(), -q_block * a.rotation().matrix().transpose();
  return m;
}

}  // namespace

Vec6 betweenErrorSE3(const SE3& xi, const SE3& xj, const SE3& z, Mat6* J_e_xi,
                     Mat6* J_e_xj) noexcept {
  const SE3 a = xi.between(xj);
  Mat6 J_e_d;
  const bool want_jacobian = J_e_xi != nullptr || J_e_xj != nullptr;
  const Vec6 e = quaternionError(z.between(a), want_jacobian ? &J_e_d : nullptr);
  if (J_e_xi != nullptr) *J_e_xi = jacobianOfFirst(a, z, J_e_d.bottomRightCorner<3, 3>());
  if (J_e_xj != nullptr) *J_e_xj = J_e_d;
  return e;
}

// With N = Ad(A^-1) = [Ra^T  -Ra^T S; 0  Ra^T] (S = [ta]x), J_e_xi = -J_e_xj N (step 3 above), so
// with P = J_e_xj^T Omega J_e_xj: ji = -P N, ii = N^T P N, eta_j = -J_e_xj^T Omega e and
// eta_i = -N^T eta_j. J_e_xj is block-diagonal and N block-triangular: about 600 multiply-adds
// where the general products of two dense Jacobians take 1250.
Vec6 linearizeBetweenSE3(const SE3& xi, const SE3& xj, const SE3& z, const Mat6& information,
                         Mat6* ii, Mat6* jj, Mat6* ji, Vec6* eta_i, Vec6* eta_j) noexcept {
  const SE3 a = xi.between(xj);
  Mat3 r_d;
  Mat3 q_block;
  const Vec6 e = quaternionError(z.between(a), &r_d, &q_block);
  // P = J^T (Omega J) with J = diag(R_D, Q).
  Mat6 omega_j;
  omega_j.leftCols<3>().noalias() = information.leftCols<3>() * r_d;
  omega_j.rightCols<3>().noalias() = information.rightCols<3>() * q_block;
  const Vec6 omega_e = information * e;  // read before any output is written
  Mat6& p = *jj;
  p.topRows<3>().noalias() = r_d.transpose() * omega_j.topRows<3>();
  p.bottomRows<3>().noalias() = q_block.transpose() * omega_j.bottomRows<3>();
  Vec6 g;  // J^T Omega e
  g.head<3>().noalias() = r_d.transpose() * omega_e.head<3>();
  g.tail<3>().noalias() = q_block.transpose() * omega_e.tail<3>();
  *eta_j = -g;
  // P N = [T  U - T S] with T, U the halves of P times Ra^T.
  const Mat3 ra_t = a.rotation().matrix().transpose();
  const Mat3 s = skew(a.translation());
  const Mat63 t = p.leftCols<3>() * ra_t;
  Mat6 pn;
  pn.leftCols<3>() = t;
  pn.rightCols<3>().noalias() = p.rightCols<3>() * ra_t;
  pn.rightCols<3>().noalias() -= t * s;
  *ji = -pn;
  // N^T M = [Ra M_top; S Ra M_top + Ra M_bottom] for M = P N, and likewise N^T g.
  const Mat3 ra = ra_t.transpose();
  const Mat36 ra_top = ra * pn.topRows<3>();
  ii->topRows<3>() = ra_top;
  ii->bottomRows<3>().noalias() = s * ra_top;
  ii->bottomRows<3>().noalias() += ra * pn.bottomRows<3>();
  const Vec3 ra_g = ra * g.head<3>();
  eta_i->head<3>() = ra_g;
  eta_i->tail<3>().noalias() = s * ra_g;
  eta_i->tail<3>().noalias() += ra * g.tail<3>();
  return e;
}

Vec6 priorErrorSE3(const SE3& x, const SE3& z, Mat6* J_e_x) noexcept {
  return quaternionError(z.between(x), J_e_x);
}

}  // namespace lslam
