#include "lslam_target/semihosting.h"

#include <cmath>
#include <cstdint>

namespace lslam::target {
namespace {

constexpr std::uint32_t kSysWrite0 = 0x04;
constexpr std::uint32_t kSysExitExtended = 0x20;
constexpr std::uint32_t kAdpStoppedApplicationExit = 0x20026;

// r0 = operation, r1 = argument, `bkpt 0xAB` traps to the debugger, r0 = result. Explicit moves
// instead of register variables (the `register` keyword is gone from C++17).
std::uint32_t semihostingCall(std::uint32_t operation, const void* argument) noexcept {
  std::uint32_t result;
  asm volatile(
      "mov r0, %1\n"
      "mov r1, %2\n"
      "bkpt 0xAB\n"
      "mov %0, r0\n"
      : "=r"(result)
      : "r"(operation), "r"(argument)
      : "r0", "r1", "memory");
  return result;
}

}  // namespace

void write(const char* text) noexcept {
  semihostingCall(kSysWrite0, text);
}

void exit(int status) noexcept {
  const std::uint32_t block[2] = {kAdpStoppedApplicationExit, static_cast<std::uint32_t>(status)};
  semihostingCall(kSysExitExtended, block);
  for (;;) {
  }  // not reached under a debugger that implements SYS_EXIT_EXTENDED
}

void Line::put(char c) noexcept {
  if (size_ < kCapacity) buffer_[size_++] = c;
}

void Line::putDigits(unsigned long long value, int min_digits) noexcept {
  char digits[24];
  int n = 0;
  do {
    digits[n++] = static_cast<char>('0' + value % 10);
    value /= 10;
  } while (value != 0 || n < min_digits);
  while (n > 0) put(digits[--n]);
}

Line& Line::text(const char* s) noexcept {
  while (*s != '\0') put(*s++);
  return *this;
}

Line& Line::integer(long long value) noexcept {
  if (value < 0) put('-');
  // Negate in unsigned arithmetic: -LLONG_MIN overflows a long long.
  const unsigned long long magnitude = value < 0 ? 0ULL - static_cast<unsigned long long>(value)
                                                 : static_cast<unsigned long long>(value);
  putDigits(magnitude, 1);
  return *this;
}

Line& Line::real(double value, int significant) noexcept {
  if (std::isnan(value)) return text("nan");
  if (value < 0) put('-');
  const double a = std::fabs(value);
  if (std::isinf(a)) return text("inf");
  significant = significant < 1 ? 1 : (significant > 17 ? 17 : significant);
  int exponent = a == 0.0 ? 0 : static_cast<int>(std::floor(std::log10(a)));
  const double scale = std::pow(10.0, significant - 1);
  unsigned long long digits =
      static_cast<unsigned long long>(std::llround(a / std::pow(10.0, exponent) * scale));
  // log10 and the rounding can land one decade off: renormalise to exactly `significant` digits.
  const unsigned long long top = static_cast<unsigned long long>(scale);
  if (digits >= 10 * top) {
    digits = (digits + 5) / 10;
    ++exponent;
  } else if (digits < top && digits != 0) {
    digits *= 10;
    --exponent;
  }
  const unsigned long long lead = digits / top;
  putDigits(lead, 1);
  if (significant > 1) {
    put('.');
    putDigits(digits - lead * top, significant - 1);
  }
  put('e');
  put(exponent < 0 ? '-' : '+');
  putDigits(static_cast<unsigned long long>(exponent < 0 ? -exponent : exponent), 2);
  return *this;
}

Line& Line::fixed(double value, int decimals) noexcept {
  if (!std::isfinite(value)) return real(value);
  decimals = decimals < 0 ? 0 : (decimals > 9 ? 9 : decimals);
  const unsigned long long scale = static_cast<unsigned long long>(std::pow(10.0, decimals));
  const unsigned long long scaled =
      static_cast<unsigned long long>(std::llround(std::fabs(value) * static_cast<double>(scale)));
  if (value < 0 && scaled != 0) put('-');
  putDigits(scaled / scale, 1);
  if (decimals > 0) {
    put('.');
    putDigits(scaled % scale, decimals);
  }
  return *this;
}

void Line::print() noexcept {
  buffer_[size_] = '\n';
  buffer_[size_ + 1] = '\0';
  write(buffer_);
  size_ = 0;
}

}  // namespace lslam::target
