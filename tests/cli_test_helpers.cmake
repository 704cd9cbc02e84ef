# Helpers shared by the command-line tests, CMake scripts run as
#   cmake -DPGEM=<pgem> -DWORK=<folder> [-DDATASETS=<dir>] -P <script>
# Including this file checks that PGEM and WORK are given and empties WORK, the folder every
# pgem command runs in.
if(NOT PGEM OR NOT WORK)
  get_filename_component(cli_test_script "${CMAKE_SCRIPT_MODE_FILE}" NAME)
  message(FATAL_ERROR "usage: cmake -DPGEM=<pgem> -DWORK=<folder> [-DDATASETS=<dir>] -P ${cli_test_script}")
endif()
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")

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

# expect(<json> key value key value ...): every key has exactly that value (as equals()).
function(expect json)
  set(pairs ${ARGN})
  while(pairs)
    list(POP_FRONT pairs key value)
    equals("${json}" "${key}" "${value}")
  endwhile()
endfunction()

# nested(<json> <expected> path...): the value at a path of keys and indices.
function(nested json expected)
  string(JSON value ERROR_VARIABLE error GET "${json}" ${ARGN})
  if(error OR NOT value STREQUAL "${expected}")
    fail("${ARGN} = '${value}' ${error}, expected ${expected}\nin ${json}")
  endif()
endfunction()

# length(<json> <expected> path...): the number of elements of the array at a path.
function(length json expected)
  string(JSON value ERROR_VARIABLE error LENGTH "${json}" ${ARGN})
  if(error OR NOT value EQUAL expected)
    fail("length of ${ARGN} = '${value}' ${error}, expected ${expected}\nin ${json}")
  endif()
endfunction()

# json_object(<name> <text>): the text (a command's stdout) is one JSON object.
function(json_object name text)
  string(JSON type ERROR_VARIABLE error TYPE "${text}")
  if(NOT type STREQUAL "OBJECT")
    fail("${name}: stdout is not one JSON object: ${text}")
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

# pgem_ok(<name> args...): pgem_expect with exit code 0.
function(pgem_ok name)
  pgem_expect(0 ${name} ${ARGN})
  set(${name}_out "${${name}_out}" PARENT_SCOPE)
  set(${name}_err "${${name}_err}" PARENT_SCOPE)
endfunction()

# pgem_fails(<expected exit code> <name> <fragment> args...): pgem_expect, and stderr holds
# the fragment.
function(pgem_fails expected name fragment)
  pgem_expect(${expected} ${name} ${ARGN})
  contains(${name} "${${name}_err}" "${fragment}")
  set(${name}_out "${${name}_out}" PARENT_SCOPE)
  set(${name}_err "${${name}_err}" PARENT_SCOPE)
endfunction()

# block_adds_up(<name> <json>): an `optimize --json` summary's block is its poses and edges at
# block_bytes_per_pose and block_bytes_per_edge, plus block_bytes_factor, plus a rest (the
# instance, the id map of at most 16 bytes per pose, alignment, and the factorisation's dense
# workspaces where a small instance gets their floor of 32 KiB per worker rather than their
# per-pose share) that is neither negative nor larger than 16 bytes per pose, 16 KiB and
# 32 KiB per thread.
function(block_adds_up name json)
  foreach(key poses edges block_bytes block_bytes_per_pose block_bytes_per_edge block_bytes_factor)
    json_value("${json}" ${key} ${key})
  endforeach()
  json_value("${json}" threads threads)
  if(NOT threads)
    set(threads 1)
  endif()
  math(EXPR rest "${block_bytes} - ${poses} * ${block_bytes_per_pose} - ${edges} * ${block_bytes_per_edge} - ${block_bytes_factor}")
  math(EXPR most "16 * ${poses} + 16384 + 32768 * ${threads}")
  if(block_bytes_per_pose LESS 100 OR block_bytes_per_edge LESS 100 OR block_bytes_factor LESS 8
     OR rest LESS 0 OR rest GREATER most)
    fail("${name}: block ${block_bytes} = ${poses} poses x ${block_bytes_per_pose} + ${edges} edges x ${block_bytes_per_edge} + factor ${block_bytes_factor} + rest ${rest} (expected 0 .. ${most})")
  endif()
endfunction()

# count_lines(<name> <file> <regex> <expected>): the file has exactly that many lines matching
# the regex.
function(count_lines name file regex expected)
  file(STRINGS "${file}" matched REGEX "${regex}")
  list(LENGTH matched count)
  if(NOT count EQUAL expected)
    fail("${name}: ${count} lines of ${file} match '${regex}', expected ${expected}: ${matched}")
  endif()
endfunction()
