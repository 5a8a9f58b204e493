// Smoke test of the target runtime under QEMU: startup (.data copied, .bss zeroed, constructors
// run), the double-precision FPU, fixed-size Eigen, COLAMD built from source, the semihosting exit
// status and the instruction counter's calibration.
#include <Eigen/Cholesky>
#include <cmath>
#include <cstdint>

#include "lslam/eigen.h"
#include "lslam/geometry/sin_cos.h"
#include "lslam/linear/colamd_ordering.h"
#include "lslam_target/instruction_counter.h"
#include "target_checks.h"

namespace {

struct Constructed {
  Constructed() : value(7) {}
  int value;
};

volatile int g_data = 42;   // .data
std::uint32_t g_bss[64];    // .bss
Constructed g_constructed;  // .init_array
lslam::StaticColamdStorage<16, 8, 8> g_colamd_storage;

// Exactly 2 * n instructions: `subs` and `bne` per iteration.
void spin(std::uint32_t n) {
  asm volatile(
      "1: subs %0, %0, #1\n"
      "   bne 1b\n"
      : "+r"(n)
      :
      : "cc");
}

bool bssIsZero() {
  for (std::uint32_t v : g_bss) {
    if (v != 0) return false;
  }
  return true;
}

bool choleskyWorks() {
  lslam::Mat3 a;
  a << 4, 2, 0.4, 2, 5, 1, 0.4, 1, 3;
  const Eigen::LLT<lslam::Mat3> llt(a);
  const lslam::Mat3 l = llt.matrixL();
  return llt.info() == Eigen::Success && (l * l.transpose() - a).norm() < 1e-14;
}

// A chain x0 - x1 - x2 - x3 as rows (factors) over columns (variables): any valid ordering is a
// permutation of 0..3.
bool colamdWorks() {
  lslam::ColamdOrdering ordering(g_colamd_storage.arrays());
  ordering.begin();
  const lslam::Index rows_of_column[4][2] = {{0, 0}, {0, 1}, {1, 2}, {2, 2}};
  for (const auto& rows : rows_of_column) {
    ordering.startColumn();
    if (!ordering.addEntry(rows[0])) return false;
    if (rows[1] != rows[0] && !ordering.addEntry(rows[1])) return false;
  }
  lslam::Index order[4] = {};
  if (ordering.order(3, order) != lslam::Status::Ok) return false;
  int seen = 0;
  for (lslam::Index v : order) seen |= 1 << v;
  return seen == 0xF;
}

bool counterIsCalibrated() {
  constexpr std::uint32_t kIterations = 100000;
  lslam::target::startInstructionCounter();
  const std::uint64_t t0 = lslam::target::ticks();
  spin(kIterations);
  const std::uint64_t t1 = lslam::target::ticks();
  const std::uint64_t expected = 2 * kIterations / lslam::target::kInstructionsPerTick;
  lslam::target::Line()
      .text("spin of ")
      .integer(2 * kIterations)
      .text(" instructions: ")
      .integer(static_cast<long long>(t1 - t0))
      .text(" ticks")
      .print();
  // The reads around the loop add a few instructions: at most one tick more.
  return t1 - t0 >= expected && t1 - t0 <= expected + 1;
}

// The project's fixed-cost sine and cosine against newlib's on this FPU, over a sweep of
// headings both ways round (two ulps of 1, as on the host against glibc).
bool sinCosMatchesLibm() {
  constexpr int kSamples = 2001;
  constexpr double kStep = 20.0 / (kSamples - 1);
  for (int i = 0; i < kSamples; ++i) {
    const double angle = -10.0 + i * kStep + 1e-3;
    const lslam::SinCos sc = lslam::sinCos(angle);
    if (std::fabs(sc.sin - std::sin(angle)) > 4.5e-16) return false;
    if (std::fabs(sc.cos - std::cos(angle)) > 4.5e-16) return false;
  }
  return true;
}

}  // namespace

int main() {
  lslam::target::Checks checks;
  checks.expect(g_data == 42, ".data is copied from flash");
  checks.expect(bssIsZero(), ".bss is zeroed");
  checks.expect(g_constructed.value == 7, "static constructors run");
  const double two = std::sqrt(2.0) * std::sqrt(2.0);
  checks.expect(
      std::fabs(two - 2.0) < 1e-15 && std::fabs(std::sin(1.0) - 0.8414709848078965) < 1e-16,
      "double-precision FPU and libm");
  checks.expect(sinCosMatchesLibm(), "lslam::sinCos agrees with newlib's sin and cos");
  checks.expect(choleskyWorks(), "fixed-size Eigen LLT");
  checks.expect(colamdWorks(), "COLAMD from source");
  checks.expect(counterIsCalibrated(), "SysTick counts one tick per 40 instructions");
  return checks.exitStatus();
}
