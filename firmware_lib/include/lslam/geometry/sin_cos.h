#pragma once
// Sine and cosine at a fixed cost.
//
// Why not std::sin/std::cos: newlib's routines branch on the size of the argument, so on the
// Cortex-M7 one call costs from ~80 to ~220 instructions depending on the angle, and an odometry
// step (which does the same block work every time) would cost more or less depending on which way
// the robot faces. Per-step timing on the target must show the solver's work, not the heading.
//
// The host uses the same code, so host and target start from the same doubles and their
// estimates agree to rounding of the remaining arithmetic.

namespace lslam {

// Sine first, then cosine: `const auto [s, c] = sinCos(angle);` binds both.
struct SinCos {
  double sin = 0.0;
  double cos = 1.0;
};

// Both values of one angle, within ~1 ulp of the correctly rounded result. Every finite
// |angle| <= kSinCosFixedCostLimit takes the same instruction path (one reduction by pi/2, two
// polynomials, a four-way select); larger finite angles are first wrapped to (-pi, pi] (extra
// cost, never on the solver's path: stored angles are wrapped). NaN and +-Inf give NaN.
constexpr double kSinCosFixedCostLimit = 65536.0;
SinCos sinCos(double angle) noexcept;

}  // namespace lslam
