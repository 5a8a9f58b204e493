#pragma once
// The timing hook of the target programs: SysTick clocked by the processor clock, with its
// wrap-arounds counted in the SysTick exception, read as a 64-bit tick count.
//
// Under QEMU with `-icount shift=0` each instruction takes exactly 1 ns of virtual time and
// SysTick runs at the board's 25 MHz, so one tick is exactly kInstructionsPerTick instructions and
// every run gives the same counts. Resolution: kInstructionsPerTick instructions (a count may be
// off by one tick). On real silicon the same hook counts cycles / (SysTick clock divider).
#include <cstdint>

namespace lslam::target {

inline constexpr std::uint32_t kInstructionsPerTick = 40;

// Starts SysTick at its longest period (2^24 ticks) with the wrap exception enabled.
void startInstructionCounter() noexcept;

// Ticks since startInstructionCounter().
std::uint64_t ticks() noexcept;

// ticks() in instructions (under QEMU -icount shift=0).
inline std::uint64_t instructions() noexcept {
  return ticks() * kInstructionsPerTick;
}

}  // namespace lslam::target
