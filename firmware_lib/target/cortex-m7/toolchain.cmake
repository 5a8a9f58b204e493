# Cortex-M7 with the double-precision FPU (QEMU's mps2-an500), bare metal, GNU Arm Embedded
# toolchain from Debian (gcc-arm-none-eabi + newlib + libstdc++). Used by the `cortex-m7` preset.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR cortex-m7)

find_program(LSLAM_ARM_GCC arm-none-eabi-gcc)
find_program(LSLAM_ARM_GXX arm-none-eabi-g++)
if(NOT LSLAM_ARM_GCC OR NOT LSLAM_ARM_GXX)
  message(FATAL_ERROR "lslam: arm-none-eabi-gcc/g++ not found. Install the Debian packages "
                      "gcc-arm-none-eabi libnewlib-arm-none-eabi libstdc++-arm-none-eabi-newlib "
                      "(.ci/deps target, as root).")
endif()
find_program(LSLAM_ARM_SIZE arm-none-eabi-size)
set(CMAKE_C_COMPILER ${LSLAM_ARM_GCC})
set(CMAKE_CXX_COMPILER ${LSLAM_ARM_GXX})
# No executable can run during configuration (no startup code yet): probe with static libraries.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

set(LSLAM_TARGET_CPU_FLAGS "-mthumb -mcpu=cortex-m7 -mfpu=fpv5-d16 -mfloat-abi=hard")
# -ffp-contract=off: no fused multiply-add, so every product is rounded as on the host (x86-64
# without -march has no FMA), and the target's chi2 matches the host's to rounding.
set(CMAKE_C_FLAGS_INIT "${LSLAM_TARGET_CPU_FLAGS} -ffunction-sections -fdata-sections -ffp-contract=off")
# --param=inline-unit-growth=200 (GCC's default 40): with the default, how much of Eigen's
# fixed-size block arithmetic GCC inlines into the factorization's column functions hangs on the
# size of the rest of incremental_cholesky.cpp, so unrelated edits there move the steps' instruction
# counts. With room to spare the decisions no longer depend on the unit's size, no step costs more
# than with the default, and the code grows by under 1 KB.
set(CMAKE_CXX_FLAGS_INIT
    "${CMAKE_C_FLAGS_INIT} -fno-exceptions -fno-rtti -fno-threadsafe-statics --param=inline-unit-growth=200")
# The project's startup and linker script replace crt0; nano newlib for memcpy/memset and libm.
set(CMAKE_EXE_LINKER_FLAGS_INIT "-nostartfiles --specs=nano.specs --specs=nosys.specs -Wl,--gc-sections")

# Eigen is header-only: the host's headers are used as they are. Libraries and headers of the host
# must never be picked up for the target.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE NEVER)

# ctest runs every target program under QEMU through this wrapper (exit status = the program's).
set(CMAKE_CROSSCOMPILING_EMULATOR ${CMAKE_CURRENT_LIST_DIR}/run-qemu)
# The top-level CMakeLists adds this folder (runtime, link options) when it is set.
set(LSLAM_TARGET_DIR ${CMAKE_CURRENT_LIST_DIR})
