#pragma once
// Point landmarks: positions in the plane (Point2) and in space (Point3), the variable kinds of
// landmark factors. Their tangent space is the vector space itself: retract is addition and
// localCoordinates subtraction.
//
// Thin wrappers around Vec2 / Vec3 rather than aliases, so that a model can treat every variable
// kind alike: X::kDof, x.retract(tau), x.localCoordinates(b), with the same optional Jacobian
// out-params (J_<result>_<input>, nullptr allowed) as SE2 and SE3.
#include "lslam/eigen.h"
#include "lslam/geometry/coordinate_range.h"
#include "lslam/status.h"

namespace lslam {

// A point of N coordinates (2 or 3).
template <int N>
class Point {
 public:
  static_assert(N == 2 || N == 3, "points in the plane or in space");
  static constexpr int kDof = N;
  using Vector = Eigen::Matrix<double, N, 1>;
  using Jacobian = Eigen::Matrix<double, N, N>;

  Point() = default;  // the origin
  Point(double x, double y) noexcept : p_(x, y) { static_assert(N == 2, "a 2D point"); }
  Point(double x, double y, double z) noexcept : p_(x, y, z) {
    static_assert(N == 3, "a 3D point");
  }
  explicit Point(const Vector& p) noexcept : p_(p) {}

  double x() const noexcept { return p_.x(); }
  double y() const noexcept { return p_.y(); }
  double z() const noexcept { return p_.z(); }  // 3D only (Eigen asserts the size)
  const Vector& vector() const noexcept { return p_; }

  // this + tau
  Point retract(const Vector& tau, Jacobian* J_x_a = nullptr,
                Jacobian* J_x_tau = nullptr) const noexcept {
    if (J_x_a != nullptr) J_x_a->setIdentity();
    if (J_x_tau != nullptr) J_x_tau->setIdentity();
    return Point(p_ + tau);
  }
  // b - this; the inverse of retract: retract(localCoordinates(b)) == b.
  Vector localCoordinates(const Point& b, Jacobian* J_t_a = nullptr,
                          Jacobian* J_t_b = nullptr) const noexcept {
    if (J_t_a != nullptr) *J_t_a = -Jacobian::Identity();
    if (J_t_b != nullptr) J_t_b->setIdentity();
    return b.p_ - p_;
  }

 private:
  Vector p_ = Vector::Zero();
};

// Input check for a point from outside: checkCoordinates (coordinate_range.h) of its coordinates.
template <int N>
[[nodiscard]] Status validateValue(const Point<N>& x) noexcept {
  return checkCoordinates(x.vector());
}

using Point2 = Point<2>;
using Point3 = Point<3>;

}  // namespace lslam
