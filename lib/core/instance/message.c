/* The instance's last error message, built from common's text pieces; the calls of the layers
 * that still take pgem_t (instance/message.h). */
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

void pgem_message_i64(pgem_t *graph, int64_t value)
{
    pgem_text_i64(graph->message, PGEM_MESSAGE_SIZE, value);
}

void pgem_message_edge(pgem_t *graph, uint32_t k)
{
    pgem_store_edge_name(&graph->store, k, graph->message);
}

int pgem_fail(pgem_t *graph, int code, const char *text)
{
    return pgem_text_fail(graph->message, code, text);
}

int pgem_check_option(pgem_t *graph, double value, const char *name)
{
    return pgem_text_option(graph->message, value, name);
}
