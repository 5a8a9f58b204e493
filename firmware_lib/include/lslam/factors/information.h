#pragma once
// Validation of a factor's information matrix at the API boundary, before it can reach the
// factorization: a bad matrix is bad input (a Status), never an assertion.
#include "lslam/eigen.h"
#include "lslam/status.h"

namespace lslam {

// NonFiniteInput if any entry is NaN or Inf; InformationNotPositiveDefinite if the matrix is not
// symmetric (an entry of A - A^T above 1e-9 times the largest |entry|) or the Cholesky
// factorization of its symmetric part (symmetricPart) fails; otherwise Ok.
[[nodiscard]] Status checkInformation(const Mat2& information) noexcept;
[[nodiscard]] Status checkInformation(const Mat3& information) noexcept;
[[nodiscard]] Status checkInformation(const Eigen::Matrix<double, 6, 6>& information) noexcept;

// Makes `information` its symmetric part (A + A^T) / 2, the matrix a pose graph stores for an
// accepted information A: each off-diagonal pair that differs is replaced by its mean; every
// other entry (all of them, if A is exactly symmetric) is kept bit for bit.
inline void symmetrizePair(double& lower, double& upper) noexcept {
  // Halves first: the mean of two finite values never overflows.
  if (lower != upper) lower = upper = 0.5 * lower + 0.5 * upper;
}

template <int N>
void symmetrize(Eigen::Matrix<double, N, N>& information) noexcept {
  for (int c = 0; c < N; ++c) {
    for (int r = c + 1; r < N; ++r) symmetrizePair(information(r, c), information(c, r));
  }
}

// The 3 x 3 case written out, so that it inlines: three comparisons on a factor's insertion.
inline void symmetrize(Mat3& information) noexcept {
  symmetrizePair(information(1, 0), information(0, 1));
  symmetrizePair(information(2, 0), information(0, 2));
  symmetrizePair(information(2, 1), information(1, 2));
}

inline Mat3 symmetricPart(const Mat3& information) noexcept {
  Mat3 s = information;
  symmetrize(s);
  return s;
}

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
