# Fails unless DOC contains a tool's help verbatim, in a ``` block: runs TOOL with ARGS (e.g.
# "optimize --help") and looks for "```\n<its stdout>```" in DOC.
separate_arguments(args UNIX_COMMAND "${ARGS}")
set(COMMAND ${TOOL} ${args})
execute_process(COMMAND ${COMMAND} OUTPUT_VARIABLE help RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "${COMMAND} exited ${status}")
endif()
file(READ "${DOC}" doc)
string(FIND "${doc}" "```\n${help}```" position)
if(position EQUAL -1)
  string(REPLACE ";" " " shown "${COMMAND}")
  message(FATAL_ERROR "${DOC} does not contain the output of '${shown}' verbatim; update it "
                      "(paste the output between ``` lines)")
endif()
