# Shared by the benchmark smoke tests: bench_report(<report variable> <options>...) runs
# ${PYTHON} ${BENCH} <options> --out ${OUT}, fails unless it exits with 0 and writes ${OUT} and
# its .json beside it with the report also on stdout, and sets <report variable> to the report.
function(bench_report variable)
  execute_process(COMMAND "${PYTHON}" "${BENCH}" ${ARGN} --out "${OUT}"
                  RESULT_VARIABLE code OUTPUT_VARIABLE stdout ERROR_VARIABLE stderr)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "${BENCH} ${ARGN} exited with ${code}\nstderr:\n${stderr}")
  endif()
  get_filename_component(out_dir "${OUT}" DIRECTORY)
  get_filename_component(out_name "${OUT}" NAME_WE)
  if(NOT EXISTS "${OUT}" OR NOT EXISTS "${out_dir}/${out_name}.json")
    message(FATAL_ERROR "${BENCH} did not write ${OUT} and its .json\nstderr:\n${stderr}")
  endif()
  file(READ "${OUT}" report)
  if(NOT "${report}\n" STREQUAL "${stdout}")  # print() adds a newline
    message(SEND_ERROR "the report on stdout differs from ${OUT}")
  endif()
  set(${variable} "${report}" PARENT_SCOPE)
endfunction()

# bench_expect(<report> <fragment>...): an error for every fragment not in the report.
function(bench_expect report)
  foreach(fragment ${ARGN})
    string(FIND "${report}" "${fragment}" at)
    if(at EQUAL -1)
      message(SEND_ERROR "'${fragment}' not found in the report:\n${report}")
    endif()
  endforeach()
endfunction()
