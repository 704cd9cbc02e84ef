/* Shared pieces of the LCM tools. */
#include "lcm_tool.h"

typedef int pgem_lcm_tool_unused_t;
