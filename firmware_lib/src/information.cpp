#include "lslam/factors/information.h"

// After lslam/eigen.h, so that the Cholesky module's assertions use lslam's handler too.
#include <Eigen/Cholesky>

namespace lslam {
namespace {

// Relative, so that the test means the same for information matrices of any scale
// (1e-4 for a noisy GPS prior, 1e8 for a near-rigid constraint).
constexpr double kSymmetryTolerance = 1e-9;

template <int N>
Status check(const Eigen::Matrix<double, N, N>& information) noexcept {
  if (!information.allFinite()) return Status::NonFiniteInput;
  const double scale = information.cwiseAbs().maxCoeff();
  const double asymmetry = (information - information.transpose()).cwiseAbs().maxCoeff();
  if (asymmetry > kSymmetryTolerance * scale) return Status::InformationNotPositiveDefinite;
  // Fixed-size LLT: no allocation. It reads only the lower triangle, which the symmetry test
  // above makes representative of the whole matrix.
  const Eigen::LLT<Eigen::Matrix<double, N, N>> llt(information);
  return llt.info() == Eigen::Success ? Status::Ok : Status::InformationNotPositiveDefinite;
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
