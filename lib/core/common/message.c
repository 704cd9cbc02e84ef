/* Error messages built into the instance without stdio, so the core stays firmware-safe. */
#include "common/common.h"
#include "instance.h"

void pgem_text_append(char *text, size_t size, const char *piece)
{
    size_t length = 0;
    while (text[length] != '\0') {
        length++;
    }
    while (*piece != '\0' && length + 1 < size) {
        text[length++] = *piece++;
    }
    text[length] = '\0';
}

void pgem_text_u64(char *text, size_t size, uint64_t value)
{
    char digits[24];
    int count = 0;
    do {
        digits[count++] = (char)('0' + (int)(value % 10u));
        value /= 10u;
    } while (value != 0u);
    char piece[24];
    for (int k = 0; k < count; k++) {
        piece[k] = digits[count - 1 - k];
    }
    piece[count] = '\0';
    pgem_text_append(text, size, piece);
}

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
    if (value < 0) {
        pgem_message_text(graph, "-");
        pgem_message_u64(graph, (uint64_t)(-(value + 1)) + 1u);
    } else {
        pgem_message_u64(graph, (uint64_t)value);
    }
}

int pgem_fail(pgem_t *graph, int code, const char *text)
{
    pgem_message_clear(graph);
    pgem_message_text(graph, text);
    return code;
}
