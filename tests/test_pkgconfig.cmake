# The build tree's pgem.pc works: compiles tests/install/consumer.c with the compiler and
# flags of the build and `pkg-config --cflags --libs pgem` (no --static) from PKG_CONFIG_PATH
# set to the build tree, then runs it. Arguments: -DPC_DIR= -DCOMPILER= -DFLAGS= -DSOURCE=
# -DWORK=
set(ENV{PKG_CONFIG_PATH} "${PC_DIR}")
execute_process(COMMAND pkg-config --cflags --libs pgem
                OUTPUT_VARIABLE pc_flags RESULT_VARIABLE pc_status ERROR_VARIABLE pc_error
                OUTPUT_STRIP_TRAILING_WHITESPACE)
if(NOT pc_status EQUAL 0)
  message(FATAL_ERROR "pkg-config --cflags --libs pgem failed: ${pc_error}")
endif()
message(STATUS "pkg-config --cflags --libs pgem: ${pc_flags}")
separate_arguments(pc_flags UNIX_COMMAND "${pc_flags}")
separate_arguments(flags UNIX_COMMAND "${FLAGS}")
foreach(flag IN LISTS pc_flags)
  if(flag MATCHES "^-I(.*)")
    set(folder "${CMAKE_MATCH_1}")
    if(NOT EXISTS "${folder}/pgem/pgem.h")
      message(FATAL_ERROR "pgem.pc names the include folder ${folder}, which has no pgem/pgem.h")
    endif()
  endif()
endforeach()
execute_process(COMMAND ${COMPILER} ${flags} -std=c99 ${SOURCE} -o ${WORK}/consumer-pc ${pc_flags}
                RESULT_VARIABLE cc_status)
if(NOT cc_status EQUAL 0)
  message(FATAL_ERROR "compiling ${SOURCE} with pkg-config's flags failed")
endif()
execute_process(COMMAND ${WORK}/consumer-pc RESULT_VARIABLE run_status)
if(NOT run_status EQUAL 0)
  message(FATAL_ERROR "the consumer built with pkg-config's flags failed (exit ${run_status})")
endif()
