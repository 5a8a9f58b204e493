#include "lslam/factors/information.h"

// After lslam/eigen.h, so that the Cholesky module's assertions use lslam's handler too.
#include <Eigen/Cholesky>

namespace lslam {
namespace {

// Relative, so that the test means the same for information matrices of any scale
// (1e-4 for a noisy GPS prior, 1e8 for a near-rigid constraint).
constexpr double kSymmetryTolerance = 1e-9;

template <int N>
Status check(const Eigen::Matrix<double, N, N>& information) noexcept;

// An input symmetric only to rounding is judged as its symmetric part, the matrix that is stored
// and used; that one is exactly symmetric, so check() factorizes it. Out of line: check()'s
// common path (exactly symmetric input) compiles as if this did not exist.
template <int N>
[[gnu::cold, gnu::noinline]] Status checkSymmetricPart(
    const Eigen::Matrix<double, N, N>& information) noexcept {
  Eigen::Matrix<double, N, N> symmetric = information;
  symmetrize(symmetric);
  return check<N>(symmetric);
}

template <int N>
Status check(const Eigen::Matrix<double, N, N>& information) noexcept {
  if (!information.allFinite()) return Status::NonFiniteInput;
  const double scale = information.cwiseAbs().maxCoeff();
  const double asymmetry = (information - information.transpose()).cwiseAbs().maxCoeff();
  if (asymmetry > kSymmetryTolerance * scale) return Status::InformationNotPositiveDefinite;
  if (asymmetry != 0.0) return checkSymmetricPart<N>(information);
  // Fixed-size LLT: no allocation. It reads only the lower triangle, all of the (exactly
  // symmetric) matrix.
  // LLT fails only on a pivot <= 0; an intermediate overflow (inf - inf) gives a NaN pivot, which
  // passes that test: the finite, indefinite [1e-300 0 1e300; 0 1 0; 1e300 0 1] does. Any
  // non-finite entry of the factor reaches a later pivot (L(i,i)^2 = A(i,i) - sum_j L(i,j)^2), so
  // the diagonal is where to look: N values, not N^2, checked for every factor of every update.
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(information);
  const bool positive_definite =
      llt.info() == Eigen::Success && llt.matrixLLT().diagonal().allFinite();
  return positive_definite ? Status::Ok : Status::InformationNotPositiveDefinite;
}

}  // namespace

Status checkInformation(const Mat2& information) noexcept {
  return check<2>(information);
}
Status checkInformation(const Mat3& information) noexcept {
  return check<3>(information);
}
Status checkInformation(const Eigen::Matrix<double, 6, 6>& information) noexcept {
  return check<6>(information);
}

}  // namespace lslam
