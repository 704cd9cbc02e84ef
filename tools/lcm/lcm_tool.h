/* Shared pieces of the LCM tools. */
#ifndef PGEM_LCM_TOOL_H
#define PGEM_LCM_TOOL_H

#endif /* PGEM_LCM_TOOL_H */
