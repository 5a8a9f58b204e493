#pragma once
// Draws built on std::mt19937 only, whose output sequence the standard fixes (std::
// distributions differ between standard libraries), so the synthetic worlds are the same files
// on every host. Private to host_sim/src.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>

namespace lslam::sim::detail {

class PortableRandom {
 public:
  explicit PortableRandom(std::uint32_t seed) : engine_(seed) {}

  // Uniform in [0, 1) with 53 random bits (exact arithmetic).
  double uniform() {
    const std::uint64_t a = engine_() >> 5;                                  // 27 bits
    const std::uint64_t b = engine_() >> 6;                                  // 26 bits
    return static_cast<double>((a << 26) | b) * (1.0 / 9007199254740992.0);  // / 2^53
  }

  // Uniform integer in [0, n), n >= 1.
  std::size_t index(std::size_t n) {
    const auto k = static_cast<std::size_t>(uniform() * static_cast<double>(n));
    return k < n ? k : n - 1;
  }

  // Standard normal (Marsaglia's polar method; the second value of each pair is kept).
  double normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u = 0.0;
    double v = 0.0;
    double s = 0.0;
    do {
      u = 2.0 * uniform() - 1.0;
      v = 2.0 * uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }

 private:
  std::mt19937 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace lslam::sim::detail
