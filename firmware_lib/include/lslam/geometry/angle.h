#pragma once
// Angles as the solver stores them: wrapped to (-pi, pi].

namespace lslam {

// Maps any finite angle to (-pi, pi]. Exact: no rounding error is added for |angle| <= pi, and
// the result for larger angles is the exact IEEE remainder w.r.t. the double nearest 2*pi.
double wrapAngle(double angle) noexcept;

}  // namespace lslam
