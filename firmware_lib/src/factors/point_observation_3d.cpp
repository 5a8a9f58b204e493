#include "lslam/factors/point_observation_3d.h"

#include "lslam/factors/information.h"
#include "lslam/geometry/coordinate_range.h"
#include "lslam/geometry/so3.h"

// Derivation. With d = R^T (l - t), x -> x Exp(rho, phi) moves t -> t + R rho and
// R^T -> (I - [phi]x) R^T to first order, hence
//   d -> (I - [phi]x)(d - rho) = d - rho - phi x d = d - rho + [d]x phi,
//   J_e_x = [-I  [d]x],   and l -> l + dl gives J_e_l = R^T.

namespace lslam {

Vec3 pointObservationErrorSE3(const SE3& x, const Point3& l, const Vec3& z, Mat36* J_e_x,
                              Mat3* J_e_l) noexcept {
  const Mat3 r_t = x.rotation().matrix().transpose();
  const Vec3 d = r_t * (l.vector() - x.translation());
  if (J_e_x != nullptr) *J_e_x << -Mat3::Identity(), skew(d);
  if (J_e_l != nullptr) *J_e_l = r_t;
  return d - z;
}

Point3 landmarkFromPointObservationSE3(const SE3& x, const Vec3& z) noexcept {
  return Point3(x.transformFrom(z));
}

Status validatePointObservationSE3(const Vec3& z, const Mat3& information) noexcept {
  const Status s = checkCoordinates(z);
  return s != Status::Ok ? s : checkInformation(information);
}

}  // namespace lslam
