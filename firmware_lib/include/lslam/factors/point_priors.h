#pragma once
// Prior factors on point landmarks: z is the measured position of the landmark, in the frame
// the landmark is estimated in. e = x - z; its Jacobian w.r.t. x (+) tau = x + tau is I.
#include "lslam/eigen.h"
#include "lslam/geometry/point.h"
#include "lslam/status.h"
#include "lslam/type_list.h"

namespace lslam {

// e = x - z
Vec2 priorErrorPoint2(const Point2& x, const Point2& z, Mat2* J_e_x = nullptr) noexcept;
Vec3 priorErrorPoint3(const Point3& x, const Point3& z, Mat3* J_e_x = nullptr) noexcept;

// Input check of a prior before it is added: validateValue(z) (NonFiniteInput, or InvalidArgument
// beyond kMaxCoordinate), else checkInformation(information) (NonFiniteInput,
// InformationNotPositiveDefinite or Ok).
[[nodiscard]] Status validatePriorPoint2(const Point2& z, const Mat2& information) noexcept;
[[nodiscard]] Status validatePriorPoint3(const Point3& z, const Mat3& information) noexcept;

// ---- Factor kinds (the entries of a model's factor list; see lslam/models/) ----------------
// Each names its variables, its measurement and error dimension, the error with its Jacobians and
// the check of an input (measurement and information).

template <int N>
struct PriorPointFactor {
  using Variables = TypeList<Point<N>>;
  using Measurement = Point<N>;
  static constexpr int kErrorDim = N;
  using Vector = Eigen::Matrix<double, N, 1>;
  using Matrix = Eigen::Matrix<double, N, N>;
  static Vector error(const Point<N>& x, const Point<N>& z, Matrix* J_e_x) noexcept {
    if constexpr (N == 2) {
      return priorErrorPoint2(x, z, J_e_x);
    } else {
      return priorErrorPoint3(x, z, J_e_x);
    }
  }
  [[nodiscard]] static Status validate(const Point<N>& z, const Matrix& information) noexcept {
    if constexpr (N == 2) {
      return validatePriorPoint2(z, information);
    } else {
      return validatePriorPoint3(z, information);
    }
  }
};
using PriorPoint2Factor = PriorPointFactor<2>;
using PriorPoint3Factor = PriorPointFactor<3>;

}  // namespace lslam
