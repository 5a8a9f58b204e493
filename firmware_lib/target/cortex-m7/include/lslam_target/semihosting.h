#pragma once
// Console output and exit status of a target program, through Arm semihosting (`bkpt 0xAB`): the
// debugger (here QEMU with -semihosting) prints the text and ends with the given status. No
// printf: newlib's pulls in malloc, which the link guard forbids.
#include <cstddef>

namespace lslam::target {

// Writes a NUL-terminated string to the host console (SYS_WRITE0).
void write(const char* text) noexcept;

// Ends the program: QEMU exits with `status` (SYS_EXIT_EXTENDED, ADP_Stopped_ApplicationExit).
[[noreturn]] void exit(int status) noexcept;

// One line of text built in a fixed buffer and written with a single semihosting call. Text beyond
// the buffer is dropped (a diagnostic line, never data).
class Line {
 public:
  Line& text(const char* s) noexcept;
  Line& integer(long long value) noexcept;
  // Scientific notation with `significant` digits (1..17), e.g. 1.401126059e+03. Rounded through
  // pow(10, .), so the last digit or two may be off: for reading, not for comparing.
  Line& real(double value, int significant = 10) noexcept;
  // Fixed notation with `decimals` digits after the point (0..9), e.g. 9.68; |value| < 1e9.
  Line& fixed(double value, int decimals) noexcept;
  // Writes the line with a newline and starts the next one.
  void print() noexcept;

 private:
  void put(char c) noexcept;
  void putDigits(unsigned long long value, int min_digits) noexcept;

  static constexpr std::size_t kCapacity = 240;
  char buffer_[kCapacity + 2] = {};  // + '\n' + NUL
  std::size_t size_ = 0;
};

}  // namespace lslam::target
