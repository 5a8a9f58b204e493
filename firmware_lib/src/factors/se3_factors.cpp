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

// e(D) of the residual d, and J_e_D when jacobian is not nullptr (step 2 above).
Vec6 quaternionError(const SE3& d, Mat6* jacobian) noexcept {
  const Eigen::Quaterniond& q = d.rotation().quaternion();
  // q and -q are the same rotation; g2o takes the one with w >= 0.
  const double sign = q.w() < 0.0 ? -1.0 : 1.0;
  const double w = sign * q.w();
  const Vec3 v = sign * q.vec();
  if (jacobian != nullptr) {
    *jacobian << d.rotation().matrix(), Mat3::Zero(),  //
        Mat3::Zero(), 0.5 * (w * Mat3::Identity() + skew(v));
  }
  Vec6 e;
  e << d.translation(), v;
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

Vec6 priorErrorSE3(const SE3& x, const SE3& z, Mat6* J_e_x) noexcept {
  return quaternionError(z.between(x), J_e_x);
}

}  // namespace lslam
