/* The instance's last error message (instance/message.c), for instance/'s own calls (init,
 * the executor, pgem_copy): clear, then append pieces; pgem_fail sets it to text and returns
 * code (for one-line error returns). The layers write into the message buffer they are lent,
 * with common's pgem_text_* calls (docs/design/core-layers.md). */
#ifndef PGEM_INSTANCE_MESSAGE_H
#define PGEM_INSTANCE_MESSAGE_H

#include "common/common.h"

void pgem_message_clear(pgem_t *graph);
void pgem_message_text(pgem_t *graph, const char *text);
void pgem_message_u64(pgem_t *graph, uint64_t value);
int pgem_fail(pgem_t *graph, int code, const char *text);

#endif /* PGEM_INSTANCE_MESSAGE_H */
