/* pgem I/O lines: reads one line of any length up to IO_LINE_MAX into a growing buffer. The
 * stream is read in chunks and each line found with memchr: a byte-by-byte getc took 5 ns a
 * byte, 5 s for a 1 GiB file. A line that is already too long or holds a NUL byte ends the
 * read where that is known, so an endless stream without a line end (/dev/zero, a pipe) fails
 * after a chunk or two instead of being read to its end. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

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

/* Reads the next chunk when the current one is used up. Returns 1 with bytes to read, 0 at the
 * end of the stream or on a read error (ferror tells which). */
static int io_chunk_fill(FILE *stream, io_line_t *line)
{
    if (line->chunk_start < line->chunk_end) {
        return 1;
    }
    if (line->chunk == NULL) {
        line->chunk = (char *)malloc(IO_CHUNK_BYTES);
        if (line->chunk == NULL) {
            return 0;
        }
    }
    line->chunk_start = 0;
    line->chunk_end = fread(line->chunk, 1, IO_CHUNK_BYTES, stream);
    return line->chunk_end > 0;
}

/* Appends a piece of the line; past IO_LINE_MAX + 1 bytes (room for the CR of a CRLF end)
 * only the count grows, so an overlong line costs no memory. */
static int io_line_append(io_line_t *line, const char *piece, size_t size, size_t *total)
{
    const size_t limit = IO_LINE_MAX + 1u;
    size_t kept = *total < limit ? limit - *total : 0;
    kept = kept < size ? kept : size;
    if (kept > 0) {
        if (io_line_reserve(line, line->length + kept + 1) != PGEM_OK) {
            return PGEM_ERR_OUT_OF_MEMORY;
        }
        memcpy(line->text + line->length, piece, kept);
        line->length += kept;
    }
    *total += size;
    return PGEM_OK;
}

int io_read_line(FILE *stream, io_line_t *line)
{
    int got_any = 0;
    int has_nul = 0;
    size_t total = 0; /* bytes of the line without its LF, kept or not */
    line->length = 0;
    line->consumed = 0;
    if (io_line_reserve(line, 1) != PGEM_OK) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    while (io_chunk_fill(stream, line)) {
        const char *start = line->chunk + line->chunk_start;
        const size_t available = line->chunk_end - line->chunk_start;
        const char *newline = (const char *)memchr(start, '\n', available);
        const size_t size = newline != NULL ? (size_t)(newline - start) : available;
        got_any = 1;
        has_nul |= memchr(start, '\0', size) != NULL;
        if (io_line_append(line, start, size, &total) != PGEM_OK) {
            return PGEM_ERR_OUT_OF_MEMORY;
        }
        line->chunk_start += size + (newline != NULL);
        line->consumed += size + (newline != NULL);
        if (newline != NULL || has_nul || total > IO_LINE_MAX + 1u) {
            break; /* the line is whole, or its verdict is known: read no further */
        }
    }
    if (line->chunk == NULL) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    if (ferror(stream)) {
        return PGEM_ERR_IO;
    }
    if (!got_any) {
        return IO_LINE_END;
    }
    if (total > 0 && line->text[line->length - 1] == '\r' && total == line->length) {
        line->length--;
        total--;
    }
    line->text[line->length] = '\0';
    if (total > IO_LINE_MAX) {
        return IO_LINE_TOO_LONG;
    }
    return has_nul ? IO_LINE_HAS_NUL : IO_LINE_READ;
}

void io_line_free(io_line_t *line)
{
    free(line->text);
    free(line->chunk);
    memset(line, 0, sizeof *line);
}
