// Startup of every target program on mps2-an500 (Cortex-M7): the vector table and the reset
// handler that prepares memory, the FPU and the C++ constructors, then runs main() and passes its
// result to the debugger as the exit status. No C library startup (crt0) is linked.
#include <cstdint>

#include "lslam_target/semihosting.h"

extern "C" {
// Linker script symbols (mps2_an500.ld). The stack top is declared as a function only so that it
// fits the vector table's element type without a cast.
void __stack_top();
extern std::uint32_t __data_start[];
extern std::uint32_t __data_end[];
extern const std::uint32_t __data_load[];
extern std::uint32_t __bss_start[];
extern std::uint32_t __bss_end[];
using InitFunction = void (*)();
extern InitFunction __init_array_start[];
extern InitFunction __init_array_end[];

// The program's main(), under another name: ISO C++ forbids calling main itself.
int programMain() __asm__("main");
[[noreturn]] void Reset_Handler();
void SysTick_Handler();  // instruction_counter.cpp
}

namespace {

// A fault means a bug: report which one and stop with a status no test passes with.
[[noreturn]] void fault(const char* name) {
  lslam::target::write("lslam target: ");
  lslam::target::write(name);
  lslam::target::write("\n");
  lslam::target::exit(99);
}

[[noreturn]] void nmiHandler() {
  fault("NMI");
}
[[noreturn]] void hardFaultHandler() {
  fault("HardFault");
}
[[noreturn]] void memManageHandler() {
  fault("MemManage fault");
}
[[noreturn]] void busFaultHandler() {
  fault("BusFault");
}
[[noreturn]] void usageFaultHandler() {
  fault("UsageFault");
}
[[noreturn]] void unexpectedHandler() {
  fault("unexpected exception");
}

volatile std::uint32_t& cpacr() {
  return *reinterpret_cast<volatile std::uint32_t*>(0xE000ED88);
}

void enableFpu() {
  cpacr() = cpacr() | (0xFu << 20);  // full access to coprocessors 10 and 11 (the FPU)
  asm volatile("dsb\n isb" ::: "memory");
}

}  // namespace

using Handler = void (*)();

// Cortex-M7 system exceptions 0..15; no peripheral interrupt is used.
__attribute__((section(".vectors"), used)) const Handler g_vectors[16] = {
    __stack_top,       Reset_Handler,    nmiHandler,
    hardFaultHandler,  memManageHandler, busFaultHandler,
    usageFaultHandler, nullptr,          nullptr,
    nullptr,           nullptr,          unexpectedHandler /* SVC */,
    unexpectedHandler, nullptr,          unexpectedHandler /* PendSV */,
    SysTick_Handler,
};

void Reset_Handler() {
  // First, before any compiler-generated code may touch a floating-point register.
  enableFpu();
  const std::uint32_t* source = __data_load;
  for (std::uint32_t* p = __data_start; p < __data_end; ++p) *p = *source++;
  for (std::uint32_t* p = __bss_start; p < __bss_end; ++p) *p = 0;
  for (InitFunction* f = __init_array_start; f < __init_array_end; ++f) (*f)();
  lslam::target::exit(programMain());
}
