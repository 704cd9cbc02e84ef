# pgem-bench-factor (tools/bench/bench_factor.c) end to end, the one user of the factor's test
# hook (lib/core/hooks/factor_hook.h): on a simulated 200-pose graph its pgem mode reports the
# factor the hook describes and writes H, which its cholmod mode reads back.
# Run by CTest as:
#   cmake -DPGEM=<pgem> -DBENCH_FACTOR=<pgem-bench-factor> -DWORK=<folder> -P test_bench_factor.cmake
include("${CMAKE_CURRENT_LIST_DIR}/cli_test_helpers.cmake")
if(NOT BENCH_FACTOR)
  message(FATAL_ERROR "pass -DBENCH_FACTOR=<pgem-bench-factor>")
endif()

execute_process(COMMAND ${PGEM} simulate -o graph.g2o --poses 200 --seed 1
                WORKING_DIRECTORY ${WORK} RESULT_VARIABLE rc OUTPUT_QUIET)
if(NOT rc EQUAL 0)
  fail("pgem simulate: exit ${rc}")
endif()

execute_process(COMMAND ${BENCH_FACTOR} pgem graph.g2o --repeat 2 --matrix H.bin
                WORKING_DIRECTORY ${WORK} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  fail("pgem-bench-factor pgem: exit ${rc}: ${err}")
endif()
json_object("pgem mode" "${out}")
# 199 free poses of 3 unknowns (the first pose holds the gauge)
expect("${out}" mode pgem poses 200 unknowns 597 threads 1)
json_value("${out}" factor_nonzeros stored)
json_value("${out}" exact_nonzeros exact)
if(exact LESS 597 OR exact GREATER stored)
  fail("exact_nonzeros ${exact}: expected at least the 597 diagonal entries, at most the ${stored} stored")
endif()
within("${out}" supernodes 0 200)
within("${out}" flops 0 1e9)
within("${out}" executed_multiply_adds 0 1e9)
json_value("${out}" ordering ordering)
json_value("${out}" kernels kernels)
if(NOT ordering MATCHES "^(amd|nested|metis)$" OR NOT kernels MATCHES "^(portable|avx2|avx512)$")
  fail("ordering '${ordering}', kernels '${kernels}'")
endif()
foreach(stage analysis factor iteration)
  json_value("${out}" ${stage}_seconds seconds)
endforeach()

execute_process(COMMAND ${BENCH_FACTOR} cholmod H.bin --repeat 1
                WORKING_DIRECTORY ${WORK} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  fail("pgem-bench-factor cholmod: exit ${rc}: ${err}")
endif()
json_object("cholmod mode" "${out}")
expect("${out}" mode cholmod unknowns 597)
