#include "lslam_target/instruction_counter.h"

namespace lslam::target {
namespace {

// SysTick and the interrupt control register of the System Control Block (Armv7-M ARM, B3.3).
volatile std::uint32_t& reg(std::uintptr_t address) {
  return *reinterpret_cast<volatile std::uint32_t*>(address);
}
constexpr std::uintptr_t kSystCsr = 0xE000E010;  // control and status
constexpr std::uintptr_t kSystRvr = 0xE000E014;  // reload value
constexpr std::uintptr_t kSystCvr = 0xE000E018;  // current value (counts down)
constexpr std::uintptr_t kScbIcsr = 0xE000ED04;
constexpr std::uint32_t kCsrEnable = 1u << 0;
constexpr std::uint32_t kCsrTickInt = 1u << 1;
constexpr std::uint32_t kCsrProcessorClock = 1u << 2;
constexpr std::uint32_t kIcsrPendStSet = 1u << 26;
constexpr std::uint32_t kReload = 0x00FFFFFF;  // the 24-bit maximum

volatile std::uint32_t g_wraps = 0;

}  // namespace

void startInstructionCounter() noexcept {
  reg(kSystCsr) = 0;
  reg(kSystRvr) = kReload;
  reg(kSystCvr) = 0;  // any write clears the counter; it loads the reload value on the next tick
  reg(kSystCsr) = kCsrEnable | kCsrTickInt | kCsrProcessorClock;
  // That first load is not a wrap-around (no exception): wait for it, so that ticks() starts at 0
  // and only increases.
  while (reg(kSystCvr) == 0) {
  }
  g_wraps = 0;
}

std::uint64_t ticks() noexcept {
  std::uint32_t wraps;
  std::uint32_t value;
  bool pending;
  do {
    wraps = g_wraps;
    value = reg(kSystCvr);
    pending = (reg(kScbIcsr) & kIcsrPendStSet) != 0;
  } while (wraps != g_wraps);
  // The counter has reloaded but the exception has not been taken yet: count that wrap now.
  if (pending && value > kReload / 2) ++wraps;
  return static_cast<std::uint64_t>(wraps) * (kReload + 1ull) + (kReload - value);
}

}  // namespace lslam::target

// The SysTick exception (vector 15, see startup.cpp): one wrap-around of the 24-bit counter.
extern "C" void SysTick_Handler() {
  lslam::target::g_wraps = lslam::target::g_wraps + 1;
}
