# tools/bench/bench.py end to end, pgem alone (no GTSAM, no numpy): one Gauss-Newton run on
# intel and input_M3500_g2o, one EM run on input_M3500_g2o with 100 random false loops. The
# report must be written and hold the Gauss-Newton, robust and memory tables and the targets.
# Run by CTest as:
#   cmake -DPYTHON=<python3> -DBENCH=<bench.py> -DPGEM=<pgem> -DOUT=<report.md>
#         [-DDATASETS=<dir>] -P test_bench_smoke.cmake
# Prints "bench_smoke: skipped: ..." (which CTest reports as skipped) without the datasets.
foreach(variable PYTHON BENCH PGEM OUT)
  if(NOT ${variable})
    message(FATAL_ERROR "usage: cmake -DPYTHON=<python3> -DBENCH=<bench.py> -DPGEM=<pgem> -DOUT=<report.md> [-DDATASETS=<dir>] -P test_bench_smoke.cmake")
  endif()
endforeach()
if(NOT DATASETS OR NOT EXISTS "${DATASETS}/2d/intel.g2o" OR NOT EXISTS "${DATASETS}/2d/input_M3500_g2o.g2o")
  message("bench_smoke: skipped: 2d/intel.g2o and 2d/input_M3500_g2o.g2o not found in '${DATASETS}' (PGEM_DATASETS_DIR)")
  return()
endif()

get_filename_component(out_dir "${OUT}" DIRECTORY)
get_filename_component(out_name "${OUT}" NAME_WE)
set(raw "${out_dir}/${out_name}.json")
file(REMOVE "${OUT}" "${raw}")
execute_process(COMMAND "${PYTHON}" "${BENCH}" --quick --peer none --runs 1 --pgem "${PGEM}"
                        --datasets "${DATASETS}" --out "${OUT}" --work "${out_dir}/${out_name}_work"
                RESULT_VARIABLE code OUTPUT_VARIABLE stdout ERROR_VARIABLE stderr)
if(NOT code EQUAL 0)
  message(FATAL_ERROR "bench.py exited with ${code}\nstderr:\n${stderr}")
endif()
if(NOT EXISTS "${OUT}" OR NOT EXISTS "${raw}")
  message(FATAL_ERROR "bench.py did not write ${OUT} and ${raw}\nstderr:\n${stderr}")
endif()
file(READ "${OUT}" report)
if(NOT "${report}\n" STREQUAL "${stdout}")  # print() adds a newline
  message(SEND_ERROR "the report on stdout differs from ${OUT}")
endif()
foreach(fragment
    "## Gauss-Newton on the clean graphs"
    "| dataset | dim | poses | edges | pgem time |"
    "| intel | 2D | 943 | 1837 |"
    "| input_M3500_g2o | 2D | 3500 | 5453 |"
    "## Robust solves on corrupted graphs"
    "| input_M3500_g2o | random | 100 | 1 | pgem-em |"
    "1.000 / 1.000"
    "## Memory"
    "## Timing spread"
    "## Targets")
  string(FIND "${report}" "${fragment}" at)
  if(at EQUAL -1)
    message(SEND_ERROR "'${fragment}' not found in the report:\n${report}")
  endif()
endforeach()
string(FIND "${report}" "## Failures and timeouts\n\nNone." at)
if(at EQUAL -1)
  message(SEND_ERROR "a run failed:\n${report}")
endif()
