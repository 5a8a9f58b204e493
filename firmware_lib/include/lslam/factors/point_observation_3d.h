#pragma once
// The position of a 3D point landmark l measured in the frame of a 3D pose x = (R, t)
// (g2o EDGE_SE3_TRACKXYZ with an identity sensor offset, iSAM POINT3).
//
// Jacobians are w.r.t. the right perturbation of the pose, x (+) tau = x * Exp(tau) with
// tau = (rho, phi) as in se3.h, and w.r.t. l (+) dl = l + dl; each output pointer may be nullptr.
#include "lslam/eigen.h"
#include "lslam/geometry/point.h"
#include "lslam/geometry/se3.h"
#include "lslam/status.h"
#include "lslam/type_list.h"

namespace lslam {

// z is the measured position of l in the frame of x. e = R^T (l - t) - z.
Vec3 pointObservationErrorSE3(const SE3& x, const Point3& l, const Vec3& z, Mat36* J_e_x = nullptr,
                              Mat3* J_e_l = nullptr) noexcept;

// l = t + R z: the landmark at which the error is zero.
Point3 landmarkFromPointObservationSE3(const SE3& x, const Vec3& z) noexcept;

// checkCoordinates(z) (coordinate_range.h), then checkInformation(information).
[[nodiscard]] Status validatePointObservationSE3(const Vec3& z, const Mat3& information) noexcept;

// ---- Factor kinds (the entries of a model's factor list; see lslam/models/) ----------------
// Each names its variables, its measurement and error dimension, the error with its Jacobians and
// the check of an input (measurement and information).
// initialize(x, z): the landmark at which the error is zero, for a landmark's first observation.

struct PointObservationSE3Factor {
  using Variables = TypeList<SE3, Point3>;
  using Measurement = Vec3;
  static constexpr int kErrorDim = 3;
  static Vec3 error(const SE3& x, const Point3& l, const Vec3& z, Mat36* J_e_x,
                    Mat3* J_e_l) noexcept {
    return pointObservationErrorSE3(x, l, z, J_e_x, J_e_l);
  }
  static Point3 initialize(const SE3& x, const Vec3& z) noexcept {
    return landmarkFromPointObservationSE3(x, z);
  }
  [[nodiscard]] static Status validate(const Vec3& z, const Mat3& information) noexcept {
    return validatePointObservationSE3(z, information);
  }
};

}  // namespace lslam
