# Runs two commands (EXPECTED: this machine's build; ACTUAL: another target, under an emulator)
# and checks that their reports agree line for line, lines starting with '#' (sizes, counters:
# machine-specific) excepted; those are printed for the log.
#   cmake -DEXPECTED="cmd;args" -DACTUAL="cmd;args" -DNAME=label -P CompareReports.cmake
cmake_minimum_required(VERSION 3.25)
foreach(side EXPECTED ACTUAL)
  execute_process(COMMAND ${${side}} OUTPUT_VARIABLE out_${side} ERROR_VARIABLE err_${side}
                  RESULT_VARIABLE status_${side} TIMEOUT 540)
  if(NOT status_${side} EQUAL 0)
    message(FATAL_ERROR "${side} (${${side}}) failed with ${status_${side}}:\n"
                        "${out_${side}}${err_${side}}")
  endif()
  string(REGEX REPLACE "\r" "" out_${side} "${out_${side}}")
  string(REGEX MATCHALL "[^\n]*\n" lines "${out_${side}}")
  set(kept_${side} "")
  set(notes_${side} "")
  foreach(line IN LISTS lines)
    if(line MATCHES "^#")
      string(APPEND notes_${side} "${line}")
    else()
      string(APPEND kept_${side} "${line}")
    endif()
  endforeach()
endforeach()
message("host:\n${notes_EXPECTED}${NAME}:\n${notes_ACTUAL}")
if(kept_EXPECTED STREQUAL "")
  message(FATAL_ERROR "the host's report is empty")
endif()
if(NOT kept_EXPECTED STREQUAL kept_ACTUAL)
  message(FATAL_ERROR "${NAME} and host reports differ.\n--- host:\n${kept_EXPECTED}"
                      "--- ${NAME}:\n${kept_ACTUAL}")
endif()
message("${NAME} report equals the host's:\n${kept_ACTUAL}")
