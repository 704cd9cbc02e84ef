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

# Host programs come from the host; libraries, headers and packages only from under
# CMAKE_FIND_ROOT_PATH, which is left empty: find_library and find_path then find nothing (in
# particular not the host's CSparse or libm), and newlib's libc and libm are linked by name
# (-lm), so the compiler driver picks the multilib. Cross-built dependencies go in a
# directory passed as -DCMAKE_FIND_ROOT_PATH=...
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
set(PGEM_CM7_COMMON_FLAGS
    "${PGEM_CM7_ARCH_FLAGS} -ffunction-sections -fdata-sections -ffp-contract=off")

# C++ for firmware: no exceptions, no RTTI and no guarded local statics, so nothing references
# the C++ runtime (__cxa_*, __gxx_personality_v0, _Unwind_*). One way in remains: a class with a
# virtual destructor has a deleting destructor that calls operator delete, hence free; unless
# the optimiser removes it (at -O0 it does not) the link then fails on _sbrk (see below).
set(CMAKE_C_FLAGS_INIT "${PGEM_CM7_COMMON_FLAGS}")
set(CMAKE_CXX_FLAGS_INIT
    "${PGEM_CM7_COMMON_FLAGS} -fno-exceptions -fno-rtti -fno-threadsafe-statics")
set(CMAKE_ASM_FLAGS_INIT "${PGEM_CM7_ARCH_FLAGS}")

# The C library: newlib in full (libc.a), not newlib-nano (--specs=nano.specs).
# Linked with a program calling sin, cos, atan2, sqrt, fabs, exp, log, memcpy, memset and
# memmove, neither library pulls in malloc, free or _sbrk: libm reports errors through errno,
# which is an int inside newlib's statically allocated reentrancy struct (__errno() returns its
# address), and memcpy, memset and memmove are the same Thumb-2 routines in both. What nano
# saves is code this project does not link (printf, stdio, malloc) and about 1 KiB of RAM (its
# smaller reentrancy struct). But that smaller struct allocates some members on first use:
# with nano, rand() or strtok() calls malloc, while full newlib keeps that state in the static
# struct. Full newlib is the one that stays malloc-free for more of the C library. (nano.specs
# would also have to be given when compiling: it switches newlib.h to /usr/include/newlib/nano.)
#
# No --specs=nosys.specs or rdimon.specs either: the system-call stubs stay undefined, so any
# change that pulls in malloc (which needs _sbrk) or stdio (which needs _write) fails to link
# instead of silently growing the firmware.
set(CMAKE_EXE_LINKER_FLAGS_INIT "${PGEM_CM7_ARCH_FLAGS} -Wl,--gc-sections")
