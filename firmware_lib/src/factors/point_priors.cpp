#include "lslam/factors/point_priors.h"

#include "lslam/factors/information.h"

namespace lslam {

Vec2 priorErrorPoint2(const Point2& x, const Point2& z, Mat2* J_e_x) noexcept {
  if (J_e_x != nullptr) J_e_x->setIdentity();
  return x.vector() - z.vector();
}

Vec3 priorErrorPoint3(const Point3& x, const Point3& z, Mat3* J_e_x) noexcept {
  if (J_e_x != nullptr) J_e_x->setIdentity();
  return x.vector() - z.vector();
}

Status validatePriorPoint2(const Point2& z, const Mat2& information) noexcept {
  const Status s = validateValue(z);
  return s != Status::Ok ? s : checkInformation(information);
}

Status validatePriorPoint3(const Point3& z, const Mat3& information) noexcept {
  const Status s = validateValue(z);
  return s != Status::Ok ? s : checkInformation(information);
}

}  // namespace lslam
