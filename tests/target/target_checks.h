#pragma once
// The pass/fail bookkeeping of a target test program: each check prints one PASS/FAIL line, and
// main() returns exitStatus(), which QEMU passes on to ctest.
#include "lslam_target/semihosting.h"

namespace lslam::target {

class Checks {
 public:
  // Prints "PASS <what>" or "FAIL <what>" and counts failures; returns ok.
  bool expect(bool ok, const char* what) noexcept {
    Line line;
    line.text(ok ? "PASS " : "FAIL ").text(what).print();
    failures_ += ok ? 0 : 1;
    return ok;
  }
  int failures() const noexcept { return failures_; }
  int exitStatus() const noexcept { return failures_ == 0 ? 0 : 1; }

 private:
  int failures_ = 0;
};

}  // namespace lslam::target
