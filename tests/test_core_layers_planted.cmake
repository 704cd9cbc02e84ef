# The layering check must fail on a violation of each kind: a copy of lib/core gets one planted
# violation at a time, and tests/test_core_layers.cmake must fail naming it; the unplanted copy
# must pass (so a failure is the plant's). Usage:
#   cmake -DCORE=lib/core -DCHECK=tests/test_core_layers.cmake -DSCRATCH=<empty dir> \
#         -P tests/test_core_layers_planted.cmake
cmake_minimum_required(VERSION 3.19)
foreach(var CORE CHECK SCRATCH)
  if(NOT ${var})
    message(FATAL_ERROR "pass -D${var}=...")
  endif()
endforeach()
get_filename_component(CORE "${CORE}" ABSOLUTE)
set(PUBLIC "${CORE}/../../include;${CORE}/../support")

# plant NAME FILE TEXT EXPECTED [FILE2 TEXT2]: TEXT appended to FILE (relative to the copy's
# core; and TEXT2 to FILE2) in a copy of its own; the check must fail with a message matching
# EXPECTED.
set(failures 0)
function(plant name file text expected)
  set(copy "${SCRATCH}/${name}")
  file(REMOVE_RECURSE "${copy}")
  file(COPY "${CORE}/" DESTINATION "${copy}")
  if(name STREQUAL "none")
    set(expected "")
  else()
    if(NOT EXISTS "${copy}/${file}")
      message(SEND_ERROR "${name}: ${file} is not in lib/core (change the plant)")
      return()
    endif()
    file(APPEND "${copy}/${file}" "\n${text}\n")
    if(ARGC GREATER 4)
      file(APPEND "${copy}/${ARGV4}" "\n${ARGV5}\n")
    endif()
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} "-DCORE=${copy}" "-DPUBLIC=${PUBLIC}" -P "${CHECK}"
                  RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  file(REMOVE_RECURSE "${copy}")
  if(name STREQUAL "none")
    if(NOT status EQUAL 0)
      message(SEND_ERROR "the unplanted copy fails the check:\n${out}${err}")
    else()
      message(STATUS "unplanted copy: passes")
    endif()
  elseif(status EQUAL 0)
    message(SEND_ERROR "${name}: the check passed with ${file} planted with: ${text}")
  elseif(NOT out MATCHES "layering violation: ${expected}")
    message(SEND_ERROR "${name}: the check failed, but not with '${expected}':\n${out}${err}")
  else()
    string(REGEX MATCH "layering violation: ${expected}[^\n]*" line "${out}")
    string(STRIP "${line}" line)
    message(STATUS "${name}: fails as it should: ${line}")
  endif()
endfunction()

plant(none "" "" "")
# an upper layer's header, included directly
plant(include_direct graph/pose.c "#include \"solver/solver.h\""
      "graph/pose\\.c: layer graph includes a header of layer solver \\(solver/solver\\.h\\)")
# the same through a header of the layer's own: every file including that header reaches it
plant(include_through graph/graph.h "#include \"robust/robust.h\""
      "graph/[a-z_]+\\.c: layer graph includes a header of layer robust \\(robust/robust\\.h through graph/graph\\.h\\)")
# a private header of a lower layer (linalg's state)
plant(include_private solver/step.c "#include \"linalg/linear.h\""
      "solver/step\\.c: linalg/linear\\.h is private to layer linalg")
# an upper layer's state
plant(state linalg/state.c "static int pgem_planted(pgem_t *g) { return g->solver.planted; }"
      "linalg/state\\.c: layer linalg reads the state of layer solver")
# an upper layer's function
plant(call graph/pose.c "static void pgem_planted(void) { pgem_solver_optimize(0, 0, 0); }"
      "graph/pose\\.c: layer graph calls pgem_solver_optimize of layer solver")
# the hub outside instance/, directly and through a header
plant(hub_direct geometry/se2.c "#include \"instance.h\""
      "geometry/se2\\.c: layer geometry includes the hub instance\\.h \\(instance\\.h\\)")
plant(hub_through common/common.h "#include \"instance.h\""
      "geometry/se3\\.c: layer geometry includes the hub instance\\.h \\(instance\\.h through common/common\\.h\\)"
      geometry/se3.c "#include \"common/common.h\"")
# the hub from the last layer that still saw it (online), and a call of instance/'s
plant(hub_online online/update.c "#include \"instance.h\""
      "online/update\\.c: layer online includes the hub instance\\.h \\(instance\\.h\\)")
plant(call_instance online/adopt.c "static void pgem_planted(void) { pgem_message_clear(0); }"
      "online/adopt\\.c: layer online calls pgem_message_clear of layer instance")
