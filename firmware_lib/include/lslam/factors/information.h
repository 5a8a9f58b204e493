#pragma once
// Validation of a factor's information matrix at the API boundary, before it can reach the
// factorization: a bad matrix is bad input (a Status), never an assertion.
#include "lslam/eigen.h"
#include "lslam/status.h"

namespace lslam {

// NonFiniteInput if any entry is NaN or Inf; InformationNotPositiveDefinite if the matrix is not
// symmetric (an entry of A - A^T above 1e-9 times the largest |entry|) or its Cholesky
// factorization fails; otherwise Ok.
[[nodiscard]] Status checkInformation(const Mat2& information) noexcept;
[[nodiscard]] Status checkInformation(const Mat3& information) noexcept;
[[nodiscard]] Status checkInformation(const Eigen::Matrix<double, 6, 6>& information) noexcept;

// Any other fixed-size expression (Mat3::Identity(), a * a.transpose(), a block): evaluated into
// its matrix type, then checked by the overload above. Without this, such an expression would
// convert equally well to every overload and the call would be ambiguous.
template <class Derived>
[[nodiscard]] Status checkInformation(const Eigen::MatrixBase<Derived>& information) noexcept {
  using Matrix = Eigen::Matrix<double, Derived::RowsAtCompileTime, Derived::ColsAtCompileTime>;
  static_assert(Derived::RowsAtCompileTime == 2 || Derived::RowsAtCompileTime == 3 ||
                    Derived::RowsAtCompileTime == 6,
                "information matrices are 2x2, 3x3 or 6x6");
  static_assert(Derived::RowsAtCompileTime == Derived::ColsAtCompileTime,
                "an information matrix is square");
  return checkInformation(Matrix(information));
}

}  // namespace lslam
