# Toolchain file: bare-metal Cortex-M7 with the double-precision FPU (fpv5-d16), hard-float ABI,
# GNU Arm Embedded (arm-none-eabi-gcc) and newlib.
#
#   cmake -S . -B build/cm7 -DCMAKE_TOOLCHAIN_FILE=cmake/toolchains/arm-none-eabi-cortex-m7.cmake
#
# These flags select newlib's thumb/v7e-m+dp/hard multilib: check with
#   arm-none-eabi-gcc -mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard -print-multi-directory
# which must print "thumb/v7e-m+dp/hard" (with -mfpu=fpv5-sp-d16 it would pick the single-precision
# v7e-m+fp libraries and every double operation would become a libgcc software call).
#
# An executable still needs a start-up file and a linker script, and is linked with
# -nostartfiles (no crt0: the start-up file is the entry point). examples/firmware/ has both for
# QEMU's mps2-an500 board; its README shows the link line.

set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

set(CMAKE_C_COMPILER arm-none-eabi-gcc)
set(CMAKE_CXX_COMPILER arm-none-eabi-g++)
set(CMAKE_ASM_COMPILER arm-none-eabi-gcc)

# Compiler checks build a static library: a test executable could not link without a start-up
# file and a linker script.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

# Host programs come from the host; libraries and headers only from the target's sysroot.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# -ffp-contract=off: no fused multiply-add (the M7's VFMA.F64 rounds once where a separate
#   multiply and add round twice), so each double operation rounds as it does in an x86-64 host
#   build, which keeps the core's arithmetic bit-identical between the two. (GCC already
#   defaults to off under -std=c99, but not under -std=gnu99 or in C++; say it explicitly.)
#   This covers the code we compile; libm's sin, cos, atan2, exp and log are newlib's own
#   implementations, not glibc's, and need not round the same way as the host's.
# -ffunction-sections -fdata-sections with --gc-sections: unused functions and data are dropped.
set(PGEM_CM7_ARCH_FLAGS "-mcpu=cortex-m7 -mthumb -mfpu=fpv5-d16 -mfloat-abi=hard")
set(PGEM_CM7_COMMON_FLAGS "${PGEM_CM7_ARCH_FLAGS} -ffunction-sections -fdata-sections -ffp-contract=off")

# C++ for firmware: no exceptions, no RTTI and no guarded local statics, so nothing references
# the C++ runtime (__cxa_*, __gxx_personality_v0, _Unwind_*).
set(CMAKE_C_FLAGS_INIT "${PGEM_CM7_COMMON_FLAGS}")
set(CMAKE_CXX_FLAGS_INIT
    "${PGEM_CM7_COMMON_FLAGS} -fno-exceptions -fno-rtti -fno-threadsafe-statics")
set(CMAKE_ASM_FLAGS_INIT "${PGEM_CM7_ARCH_FLAGS}")

# The C library: newlib in full (libc.a), not newlib-nano (--specs=nano.specs).
# Both were linked with a program calling sin, cos, atan2, sqrt, fabs, exp, log, memcpy, memset
# and memmove, and neither pulled in malloc, free or _sbrk: libm reports errors through errno,
# which is one int in newlib's static reentrancy struct (__errno() returns its address), never
# allocated. So nano is not needed for the no-malloc guarantee, and what it saves (a smaller
# printf, malloc and stdio) is code this project does not link. memcpy, memset and memmove are
# the same optimised Thumb-2 routines in both libraries. Full newlib costs about 1 KiB more RAM
# for its reentrancy struct; nano would also switch headers (nano.specs adds
# -isystem .../newlib/nano at compile time), so it is all or nothing across a build.
#
# No --specs=nosys.specs or rdimon.specs either: the system-call stubs stay undefined, so a
# change that pulls in malloc (which needs _sbrk) or stdio (which needs _write) fails to link
# instead of silently growing the firmware.
set(CMAKE_EXE_LINKER_FLAGS_INIT "${PGEM_CM7_ARCH_FLAGS} -Wl,--gc-sections")
