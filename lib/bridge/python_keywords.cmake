# Makes lcm-gen's Python bindings importable: a field named after a Python keyword (edge2_t's,
# edge3_t's and loop_t's `from`) is generated as `self.from`, a SyntaxError. The attribute is
# renamed with a trailing underscore (`from_`, PEP 8's way) in the generated .py files only: the
# fingerprint lcm-gen computed from the .lcm names is kept, so the wire format, journals and the
# C and Java types are unchanged (docs/design/hostile-input.md).
# Run as: cmake -DPYTHON_DIR=<generated package folder> -P python_keywords.cmake
if(NOT PYTHON_DIR)
  message(FATAL_ERROR "usage: cmake -DPYTHON_DIR=<folder> -P python_keywords.cmake")
endif()
set(keywords False None True and as assert async await break class continue def del elif else
    except finally for from global if import in is lambda nonlocal not or pass raise return try
    while with yield)
file(GLOB generated "${PYTHON_DIR}/*.py")
foreach(file_name ${generated})
  file(READ "${file_name}" text)
  set(patched "${text}")
  foreach(keyword ${keywords})
    string(REGEX REPLACE "self\\.${keyword}([^A-Za-z0-9_])" "self.${keyword}_\\1" patched "${patched}")
    string(REPLACE "\"${keyword}\"" "\"${keyword}_\"" patched "${patched}")
  endforeach()
  if(NOT patched STREQUAL text)
    file(WRITE "${file_name}" "${patched}")
  endif()
endforeach()
