# Shared by the benchmark smoke tests.

# bench_smoke_inputs(<test name> <dataset file>...): what every smoke test starts with. PYTHON,
# BENCH, PGEM and OUT must be given (else a usage error); a dataset file missing under DATASETS
# prints "<test name>: skipped: FILE not found ..." (which CTest reports as skipped) and returns
# from the calling script. Then sets out_dir, out_name and raw (the .json beside OUT) and removes
# OUT and raw.
macro(bench_smoke_inputs name)
  foreach(variable PYTHON BENCH PGEM OUT)
    if(NOT ${variable})
      message(FATAL_ERROR "usage: cmake -DPYTHON=<python3> -DBENCH=<script> -DPGEM=<pgem> -DOUT=<report.md> [-DDATASETS=<dir>] -P test_${name}.cmake")
    endif()
  endforeach()
  foreach(file ${ARGN})
    if(NOT DATASETS OR NOT EXISTS "${DATASETS}/${file}")
      message("${name}: skipped: ${file} not found in '${DATASETS}' (PGEM_DATASETS_DIR)")
      return()
    endif()
  endforeach()
  get_filename_component(out_dir "${OUT}" DIRECTORY)
  get_filename_component(out_name "${OUT}" NAME_WE)
  set(raw "${out_dir}/${out_name}.json")
  file(REMOVE "${OUT}" "${raw}")
endmacro()

# bench_report(<report variable> <options>...) runs
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

# bench_count(<text> <regular expression> <expected>): an error unless the expression matches
# the text exactly <expected> times.
function(bench_count text expression expected)
  string(REGEX MATCHALL "${expression}" found "${text}")
  list(LENGTH found n)
  if(NOT n EQUAL expected)
    message(SEND_ERROR "${n} matches of '${expression}' instead of ${expected} in:\n${text}")
  endif()
endfunction()

# bench_json_length(<file> <key> <expected>): an error unless the JSON file's top-level array
# <key> has <expected> elements.
function(bench_json_length file key expected)
  file(READ "${file}" json)
  string(JSON n ERROR_VARIABLE error LENGTH "${json}" ${key})
  if(error OR NOT n EQUAL expected)
    message(SEND_ERROR "${file} has ${n} ${key} instead of ${expected} ${error}")
  endif()
endfunction()
