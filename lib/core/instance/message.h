/* The instance's last error message (instance/message.c), for the layers that still take
 * pgem_t (docs/design/core-layers.md): clear, then append pieces; pgem_fail sets it to text and
 * returns code (for one-line error returns). A layer that takes its own state instead writes
 * into the message buffer it is handed, with common's pgem_text_* calls. */
#ifndef PGEM_INSTANCE_MESSAGE_H
#define PGEM_INSTANCE_MESSAGE_H

#include "common/common.h"

void pgem_message_clear(pgem_t *graph);
void pgem_message_text(pgem_t *graph, const char *text);
void pgem_message_u64(pgem_t *graph, uint64_t value);
void pgem_message_i64(pgem_t *graph, int64_t value);
/* Appends edge k's pose ids, "FROM-TO" (pgem_store_edge_name). */
void pgem_message_edge(pgem_t *graph, uint32_t k);
int pgem_fail(pgem_t *graph, int code, const char *text);
/* PGEM_ERR_INVALID_ARGUMENT with "option NAME is not a finite number" unless value is finite
 * (pgem_text_option into the instance's message: online's option checks). */
int pgem_check_option(pgem_t *graph, double value, const char *name);

#endif /* PGEM_INSTANCE_MESSAGE_H */
