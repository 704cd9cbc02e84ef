/* pgem I/O lines: reads one line of any length up to IO_LINE_MAX into a growing buffer. */
#include <stdio.h>
#include <stdlib.h>

#include "io_internal.h"

static int io_line_reserve(io_line_t *line, size_t needed)
{
    size_t capacity = line->capacity == 0 ? 256 : line->capacity;
    char *text;
    if (needed <= line->capacity) {
        return PGEM_OK;
    }
    while (capacity < needed) {
        capacity *= 2;
    }
    text = (char *)realloc(line->text, capacity);
    if (text == NULL) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    line->text = text;
    line->capacity = capacity;
    return PGEM_OK;
}

/* Drops the rest of an overlong or broken line so the stream stays usable. */
static void io_skip_to_line_end(FILE *stream)
{
    int c;
    do {
        c = getc(stream);
    } while (c != EOF && c != '\n');
}

static int io_line_finish(FILE *stream, io_line_t *line, int got_any, int has_nul)
{
    if (ferror(stream)) {
        return PGEM_ERR_IO;
    }
    if (!got_any) {
        return IO_LINE_END;
    }
    if (line->length > 0 && line->text[line->length - 1] == '\r') {
        line->length--;
    }
    line->text[line->length] = '\0';
    return has_nul ? IO_LINE_HAS_NUL : IO_LINE_READ;
}

int io_read_line(FILE *stream, io_line_t *line)
{
    int c;
    int got_any = 0;
    int has_nul = 0;
    line->length = 0;
    if (io_line_reserve(line, 1) != PGEM_OK) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    while ((c = getc(stream)) != EOF) {
        got_any = 1;
        if (c == '\n') {
            break;
        }
        /* one more byte allowed for a CR that belongs to a CRLF line end */
        if (line->length > IO_LINE_MAX) {
            io_skip_to_line_end(stream);
            return IO_LINE_TOO_LONG;
        }
        if (io_line_reserve(line, line->length + 2) != PGEM_OK) {
            return PGEM_ERR_OUT_OF_MEMORY;
        }
        has_nul |= (c == '\0');
        line->text[line->length++] = (char)c;
    }
    line->text[line->length] = '\0';
    if (line->length > IO_LINE_MAX &&
        !(line->length == IO_LINE_MAX + 1 && line->text[IO_LINE_MAX] == '\r')) {
        return IO_LINE_TOO_LONG;
    }
    return io_line_finish(stream, line, got_any, has_nul);
}

void io_line_free(io_line_t *line)
{
    free(line->text);
    line->text = NULL;
    line->length = 0;
    line->capacity = 0;
}
