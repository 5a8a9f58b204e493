#pragma once
#include <cstdint>

namespace lslam {

// Indices of variables, columns, factors and blocks. 32 bits: a robot's map never holds 2^31 of
// anything, and the arrays stay half the size of std::size_t ones.
using Index = std::int32_t;
inline constexpr Index kNoIndex = -1;

}  // namespace lslam
