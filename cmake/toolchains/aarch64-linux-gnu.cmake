# Cross build for 64-bit Arm Linux (onboard robot computers) with Debian's gcc-aarch64-linux-gnu.
# Tests run under qemu-aarch64 (qemu-user) through CMAKE_CROSSCOMPILING_EMULATOR; their arm64
# libraries (cmocka) come from Debian multiarch: dpkg --add-architecture arm64 and
# libcmocka-dev:arm64 (tools/setup-debian --cross does both).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
# No fused multiply-add contraction, so results match the x86-64 build bit for bit where the
# math library agrees (GCC contracts by default on aarch64).
set(CMAKE_C_FLAGS_INIT "-ffp-contract=off")
set(CMAKE_CXX_FLAGS_INIT "-ffp-contract=off")

# Libraries and headers for the target: the cross toolchain's own, then Debian's arm64
# multiarch folders; programs and header-only packages (Eigen) from the host.
set(CMAKE_FIND_ROOT_PATH /usr/aarch64-linux-gnu /)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE BOTH)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE BOTH)
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_SYSROOT_DIR} "")

find_program(PGEM_QEMU_AARCH64 qemu-aarch64)
if(PGEM_QEMU_AARCH64)
  # The arm64 loader and libc come from the cross toolchain's folder.
  set(CMAKE_CROSSCOMPILING_EMULATOR "${PGEM_QEMU_AARCH64};-L;/usr/aarch64-linux-gnu")
endif()
