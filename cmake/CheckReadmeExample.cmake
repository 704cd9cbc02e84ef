# Fails unless README (README.md or the docs page showing it) holds the example file verbatim,
# in a block fenced with the file's extension (```c for a .c file, ```cpp for a .cpp file).
get_filename_component(fence "${EXAMPLE}" LAST_EXT)
string(SUBSTRING "${fence}" 1 -1 fence)
file(READ "${README}" readme)
file(READ "${EXAMPLE}" example)
string(FIND "${readme}" "```${fence}\n${example}```" position)
if(position EQUAL -1)
  message(FATAL_ERROR "${README} does not contain ${EXAMPLE} verbatim; update its copy there")
endif()
