# Helpers shared by the command-line tests (CMake scripts run with cmake -P).

function(fail text)
  message(SEND_ERROR "FAIL: ${text}")
endfunction()

# contains(<name> <text> <fragment>): the text holds the fragment.
function(contains name text fragment)
  string(FIND "${text}" "${fragment}" at)
  if(at EQUAL -1)
    fail("${name}: '${fragment}' not found in:\n${text}")
  endif()
endfunction()

# json_value(<json> <key> <out variable>): the value of a top-level key (fails if missing).
function(json_value json key variable)
  string(JSON value ERROR_VARIABLE error GET "${json}" "${key}")
  if(error)
    fail("key '${key}': ${error}\nin ${json}")
  endif()
  set(${variable} "${value}" PARENT_SCOPE)
endfunction()

# within(<json> <key> <low> <high>): low < value < high (numbers as CMake compares them).
function(within json key low high)
  json_value("${json}" "${key}" value)
  if(NOT (value GREATER low AND value LESS high))
    fail("${key} = ${value}, expected in (${low}, ${high})")
  endif()
endfunction()

# equals(<json> <key> <expected>): exact match of the value as string(JSON) gives it back
# (it reprints numbers with 17 digits: use within() for fractions such as 0.4).
function(equals json key expected)
  json_value("${json}" "${key}" value)
  if(NOT value STREQUAL "${expected}")
    fail("${key} = ${value}, expected ${expected}")
  endif()
endfunction()

# tiny(<json> <key>...): each value is below 1e-9.
function(tiny json)
  foreach(key IN LISTS ARGN)
    within("${json}" "${key}" -1e-300 1e-9)
  endforeach()
endfunction()

# pgem_expect(<expected exit code> <name> args...): runs pgem with args in WORK, fails unless
# it exits with the expected code; sets <name>_out and <name>_err in the caller's scope.
function(pgem_expect expected name)
  execute_process(COMMAND "${PGEM}" ${ARGN} WORKING_DIRECTORY "${WORK}"
                  RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code STREQUAL "${expected}")
    fail("${name}: pgem ${ARGN}: exit code ${code}, expected ${expected}\nstdout: ${out}\nstderr: ${err}")
  endif()
  set(${name}_out "${out}" PARENT_SCOPE)
  set(${name}_err "${err}" PARENT_SCOPE)
endfunction()
