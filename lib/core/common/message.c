/* Text built without stdio, so the core stays firmware-safe: the pieces of error messages
 * (the instance's message is built with them, instance/message.c), and the option checks'
 * finite test. */
#include <math.h>

#include "common/common.h"

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

void pgem_text_i64(char *text, size_t size, int64_t value)
{
    if (value < 0) {
        pgem_text_append(text, size, "-");
        pgem_text_u64(text, size, (uint64_t)(-(value + 1)) + 1u);
    } else {
        pgem_text_u64(text, size, (uint64_t)value);
    }
}

int pgem_text_fail(char *message, int code, const char *text)
{
    message[0] = '\0';
    pgem_text_append(message, PGEM_MESSAGE_SIZE, text);
    return code;
}

int pgem_text_option(char *message, double value, const char *name)
{
    if (isfinite(value)) {
        return PGEM_OK;
    }
    message[0] = '\0';
    pgem_text_append(message, PGEM_MESSAGE_SIZE, "option ");
    pgem_text_append(message, PGEM_MESSAGE_SIZE, name);
    pgem_text_append(message, PGEM_MESSAGE_SIZE, " is not a finite number");
    return PGEM_ERR_INVALID_ARGUMENT;
}
