#pragma once
// Factors between a 2D pose x = (t, theta) and a point landmark l, with R = R(theta) and
// d = R^T (l - t) the landmark seen from the robot (in the robot frame).
//
// Jacobians are w.r.t. the right perturbation of the pose, x (+) (v, w) = x * Exp(v, w), and
// w.r.t. l (+) dl = l + dl; each output pointer may be nullptr. Every factor comes with the
// landmark position that makes its error zero (to initialize a landmark on first sight) and with
// the input check of its measurement and information, which reports bad input as a Status.
#include "lslam/eigen.h"
#include "lslam/geometry/point.h"
#include "lslam/geometry/se2.h"
#include "lslam/status.h"
#include "lslam/type_list.h"

namespace lslam {

// ---- Position in the robot frame (g2o EDGE_SE2_XY, iSAM LANDMARK) ----------------------------

// z is the measured position of l in the frame of x. e = R^T (l - t) - z.
Vec2 pointObservationErrorSE2(const SE2& x, const Point2& l, const Vec2& z, Mat23* J_e_x = nullptr,
                              Mat2* J_e_l = nullptr) noexcept;

// l = t + R z: the landmark at which the error is zero.
Point2 landmarkFromPointObservationSE2(const SE2& x, const Vec2& z) noexcept;

// checkCoordinates(z) (coordinate_range.h), then checkInformation(information).
[[nodiscard]] Status validatePointObservationSE2(const Vec2& z, const Mat2& information) noexcept;

// ---- Range and bearing ---------------------------------------------------------------------

// z = (range, bearing): the distance to l and the angle of l in the frame of x, counterclockwise
// from the robot's x axis. The information matrix is in the same order (range, bearing).
// e = (|d| - range, wrapAngle(atan2(d.y, d.x) - bearing)).
//
// At d = 0 (the landmark on the robot) neither |d| nor the bearing is differentiable: the error
// is then (-range, wrapAngle(-bearing)) and both Jacobians are zero, so that the factor adds
// nothing (rather than NaN) to a linearization at that point.
Vec2 rangeBearingErrorSE2(const SE2& x, const Point2& l, const Vec2& z, Mat23* J_e_x = nullptr,
                          Mat2* J_e_l = nullptr) noexcept;

// l = t + R (range cos(bearing), range sin(bearing)): the landmark at which the error is zero.
Point2 landmarkFromRangeBearingSE2(const SE2& x, const Vec2& z) noexcept;

// NonFiniteInput for a NaN or Inf range or bearing; InvalidArgument for range <= 0 or beyond
// kMaxCoordinate (coordinate_range.h); else checkInformation(information). A zero range is
// rejected, not only a negative one: it says the landmark is exactly at the robot, where the
// bearing is undefined (it carries no information) and the Jacobian of the bearing, which scales as
// 1/|d|, is singular; the landmark initialized from it would sit exactly at that point.
[[nodiscard]] Status validateRangeBearingSE2(const Vec2& z, const Mat2& information) noexcept;

// ---- Factor kinds (the entries of a model's factor list; see lslam/models/) ----------------
// Each names its variables, its measurement and error dimension, the error with its Jacobians and
// the check of an input (measurement and information).
// initialize(x, z): the landmark at which the error is zero, for a landmark's first observation.

struct PointObservationSE2Factor {
  using Variables = TypeList<SE2, Point2>;
  using Measurement = Vec2;
  static constexpr int kErrorDim = 2;
  static Vec2 error(const SE2& x, const Point2& l, const Vec2& z, Mat23* J_e_x,
                    Mat2* J_e_l) noexcept {
    return pointObservationErrorSE2(x, l, z, J_e_x, J_e_l);
  }
  static Point2 initialize(const SE2& x, const Vec2& z) noexcept {
    return landmarkFromPointObservationSE2(x, z);
  }
  [[nodiscard]] static Status validate(const Vec2& z, const Mat2& information) noexcept {
    return validatePointObservationSE2(z, information);
  }
};

struct RangeBearingSE2Factor {
  using Variables = TypeList<SE2, Point2>;
  using Measurement = Vec2;
  static constexpr int kErrorDim = 2;
  static Vec2 error(const SE2& x, const Point2& l, const Vec2& z, Mat23* J_e_x,
                    Mat2* J_e_l) noexcept {
    return rangeBearingErrorSE2(x, l, z, J_e_x, J_e_l);
  }
  static Point2 initialize(const SE2& x, const Vec2& z) noexcept {
    return landmarkFromRangeBearingSE2(x, z);
  }
  [[nodiscard]] static Status validate(const Vec2& z, const Mat2& information) noexcept {
    return validateRangeBearingSE2(z, information);
  }
};

}  // namespace lslam
