#pragma once
// The range of a position coordinate from outside (a translation, a point, a range; metres): every
// input is checked against it before it can reach the graph, so that a finite but absurd value is
// bad input (a Status) and not an estimate that overflows a later step.
#include <cmath>

#include "lslam/eigen.h"
#include "lslam/status.h"

namespace lslam {

// |coordinate| <= kMaxCoordinate (1e9 m, a million kilometres). It is far beyond any map a robot
// builds (UTM northings and Earth-centred coordinates stay below 1e7 m), and a difference of two
// such coordinates, squared, keeps thirty orders of magnitude of double's range for the information
// that weights it. Unbounded, a translation of 1e200 m was accepted and its squares in the
// relinearized system overflowed: NaN estimates, and every later update refused.
inline constexpr double kMaxCoordinate = 1e9;

// One coordinate: |value| <= kMaxCoordinate (false for NaN).
[[nodiscard]] inline bool withinCoordinateRange(double value) noexcept {
  return std::abs(value) <= kMaxCoordinate;
}

// NonFiniteInput for a NaN or Inf coordinate, InvalidArgument for one beyond kMaxCoordinate, Ok
// otherwise.
template <class Derived>
[[nodiscard]] Status checkCoordinates(const Eigen::MatrixBase<Derived>& coordinates) noexcept {
  if (!coordinates.allFinite()) return Status::NonFiniteInput;
  return coordinates.cwiseAbs().maxCoeff() <= kMaxCoordinate ? Status::Ok : Status::InvalidArgument;
}

}  // namespace lslam
