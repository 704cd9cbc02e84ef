/* The instance's last error message, built from common's text pieces; instance/'s own calls
 * (instance/message.h). */
#include "instance.h"

void pgem_message_clear(pgem_t *graph)
{
    graph->message[0] = '\0';
}

void pgem_message_text(pgem_t *graph, const char *text)
{
    pgem_text_append(graph->message, PGEM_MESSAGE_SIZE, text);
}

void pgem_message_u64(pgem_t *graph, uint64_t value)
{
    pgem_text_u64(graph->message, PGEM_MESSAGE_SIZE, value);
}

int pgem_fail(pgem_t *graph, int code, const char *text)
{
    return pgem_text_fail(graph->message, code, text);
}
