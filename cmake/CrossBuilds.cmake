# PGEM_CROSS: the project built again for Cortex-M7 (bare metal) and aarch64 Linux, as two
# ExternalProject builds inside this one, and CTest tests that check them against this build:
#   firmware_qemu_matches_host   the Cortex-M7 image under qemu-system-arm prints the same report
#                                as example_firmware_host (lines starting with '#' excepted)
#   firmware_no_heap_symbols     the linked image references no malloc family, no C++ runtime
#   aarch64_unit_tests           the aarch64 build's own CTest run, under qemu-aarch64
#   aarch64_matches_host         example_firmware_host built for aarch64 prints the same report
# and a `size-report` target (flash and RAM on Cortex-M7, block sizes).
include(ExternalProject)
if(NOT PGEM_CSPARSE_SOURCE_DIR)
  message(FATAL_ERROR "PGEM_CROSS needs PGEM_CSPARSE_SOURCE_DIR (tools/fetch-csparse)")
endif()
foreach(tool arm-none-eabi-gcc arm-none-eabi-nm arm-none-eabi-size qemu-system-arm
             aarch64-linux-gnu-gcc aarch64-linux-gnu-g++ qemu-aarch64)
  string(MAKE_C_IDENTIFIER "PGEM_TOOL_${tool}" var)
  find_program(${var} ${tool})
  if(NOT ${var})
    message(FATAL_ERROR "PGEM_CROSS: ${tool} not found; tools/setup-debian --cross installs it")
  endif()
endforeach()

set(PGEM_M7_DIR ${CMAKE_BINARY_DIR}/cortex-m7)
set(PGEM_M7_ELF ${PGEM_M7_DIR}/examples/firmware/pgem_firmware.elf)
ExternalProject_Add(pgem_cortex_m7
  SOURCE_DIR ${PROJECT_SOURCE_DIR}
  BINARY_DIR ${PGEM_M7_DIR}
  CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${PROJECT_SOURCE_DIR}/cmake/toolchains/arm-none-eabi-cortex-m7.cmake
             -DCMAKE_BUILD_TYPE=MinSizeRel -DPGEM_WERROR=ON
             -DPGEM_CSPARSE_SOURCE_DIR=${PGEM_CSPARSE_SOURCE_DIR}
  BUILD_ALWAYS ON
  INSTALL_COMMAND ""
  BUILD_BYPRODUCTS ${PGEM_M7_ELF} ${PGEM_M7_DIR}/lib/libpgem_core.a
  USES_TERMINAL_BUILD ON)

set(PGEM_A64_DIR ${CMAKE_BINARY_DIR}/aarch64)
ExternalProject_Add(pgem_aarch64
  SOURCE_DIR ${PROJECT_SOURCE_DIR}
  BINARY_DIR ${PGEM_A64_DIR}
  CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${PROJECT_SOURCE_DIR}/cmake/toolchains/aarch64-linux-gnu.cmake
             -DCMAKE_BUILD_TYPE=Release -DPGEM_WERROR=ON
             -DPGEM_CSPARSE_SOURCE_DIR=${PGEM_CSPARSE_SOURCE_DIR}
             -DPGEM_DATASETS_DIR=${PGEM_DATASETS_DIR}
             -DPGEM_BUILD_BRIDGE=OFF -DPGEM_BUILD_TOOLS=OFF
  BUILD_ALWAYS ON
  INSTALL_COMMAND ""
  BUILD_BYPRODUCTS ${PGEM_A64_DIR}/examples/firmware/example_firmware_host
  USES_TERMINAL_BUILD ON)

if(PGEM_BUILD_TESTS AND TARGET example_firmware_host)
  set(compare ${PROJECT_SOURCE_DIR}/cmake/CompareReports.cmake)
  add_test(NAME firmware_qemu_matches_host
    COMMAND ${CMAKE_COMMAND} -DEXPECTED=$<TARGET_FILE:example_firmware_host>
            "-DACTUAL=${PGEM_TOOL_qemu_system_arm};-machine;mps2-an500;-cpu;cortex-m7;-nographic;-monitor;none;-serial;none;-semihosting-config;enable=on,target=native;-icount;shift=0;-kernel;${PGEM_M7_ELF}"
            -DNAME=Cortex-M7 -P ${compare})
  set_tests_properties(firmware_qemu_matches_host PROPERTIES TIMEOUT 600)
  # The stream longer than the block, on the Cortex-M7: nothing refused, no false loop kept.
  add_test(NAME firmware_qemu_stream
    COMMAND ${PGEM_TOOL_qemu_system_arm} -machine mps2-an500 -cpu cortex-m7 -nographic -monitor
            none -serial none -semihosting-config enable=on,target=native -icount shift=0
            -kernel ${PGEM_M7_ELF})
  set_tests_properties(firmware_qemu_stream PROPERTIES TIMEOUT 600 PASS_REGULAR_EXPRESSION
    "held, 0 refused for capacity\n.*[0-9]+ true and 0 false accepted")
  add_test(NAME firmware_no_heap_symbols
    COMMAND ${CMAKE_COMMAND} -DNM=${PGEM_TOOL_arm_none_eabi_nm} -DELF=${PGEM_M7_ELF}
            -P ${PROJECT_SOURCE_DIR}/cmake/CheckFirmwareSymbols.cmake)
  add_test(NAME aarch64_unit_tests
    COMMAND ${CMAKE_CTEST_COMMAND} --test-dir ${PGEM_A64_DIR} --output-on-failure -j2
            --no-tests=error)
  set_tests_properties(aarch64_unit_tests PROPERTIES TIMEOUT 1800)
  add_test(NAME aarch64_matches_host
    COMMAND ${CMAKE_COMMAND} -DEXPECTED=$<TARGET_FILE:example_firmware_host>
            "-DACTUAL=${PGEM_TOOL_qemu_aarch64};-L;/usr/aarch64-linux-gnu;${PGEM_A64_DIR}/examples/firmware/example_firmware_host"
            -DNAME=aarch64 -P ${compare})
  set_tests_properties(aarch64_matches_host PROPERTIES TIMEOUT 600)
endif()

add_custom_target(size-report
  COMMAND ${CMAKE_COMMAND} -DSIZE=${PGEM_TOOL_arm_none_eabi_size} -DM7_DIR=${PGEM_M7_DIR}
          -DELF=${PGEM_M7_ELF} -DBLOCK_SIZES=$<TARGET_FILE:block_sizes>
          -P ${PROJECT_SOURCE_DIR}/cmake/SizeReport.cmake
  DEPENDS pgem_cortex_m7 block_sizes
  COMMENT "Cortex-M7 flash and RAM of pgem_core (-Os), block sizes" VERBATIM USES_TERMINAL)
