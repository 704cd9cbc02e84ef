/* pgem I/O tokens: splits a line into fields and parses ids and numbers with full validation. */
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "io_internal.h"

static int io_is_separator(char c)
{
    return c == ' ' || c == '\t' || c == '\r';
}

size_t io_split(char *text, char **fields, size_t capacity)
{
    size_t count = 0;
    char *cursor = text;
    while (*cursor != '\0') {
        while (io_is_separator(*cursor)) {
            *cursor++ = '\0';
        }
        if (*cursor == '\0') {
            break;
        }
        if (count < capacity) {
            fields[count] = cursor;
        }
        count++;
        while (*cursor != '\0' && !io_is_separator(*cursor)) {
            cursor++;
        }
    }
    return count;
}

int io_parse_id(const char *token, pgem_id_t *id)
{
    char *end = NULL;
    unsigned long long value;
    if (token[0] < '0' || token[0] > '9') {
        return -1; /* strtoull would accept a sign, spaces or nothing */
    }
    errno = 0;
    value = strtoull(token, &end, 10);
    if (errno == ERANGE || end == token || *end != '\0') {
        return -1;
    }
#if ULLONG_MAX > UINT64_MAX
    if (value > UINT64_MAX) {
        return -1;
    }
#endif
    *id = (pgem_id_t)value;
    return 0;
}

int io_parse_number(const char *token, double *value)
{
    char *end = NULL;
    double parsed;
    errno = 0;
    parsed = io_strtod(token, &end);
    if (end == token || *end != '\0') {
        return IO_NUMBER_INVALID;
    }
    if (!isfinite(parsed)) {
        return IO_NUMBER_NOT_FINITE; /* "nan", "inf" or a value beyond the double range */
    }
    *value = parsed; /* ERANGE on underflow keeps the tiny (or zero) value strtod returns */
    return IO_NUMBER_OK;
}
