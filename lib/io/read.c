/* pgem I/O read: reads a g2o or TORO file line by line into a file graph. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io_internal.h"

/* Turns what io_read_line reported (other than a line or the end) into an error. */
static int io_line_error(const io_reader_t *reader, int status, int saved_errno)
{
    switch (status) {
    case IO_LINE_TOO_LONG:
        return io_fail(reader, reader->line, PGEM_ERR_PARSE, "line is longer than %u bytes",
                       IO_LINE_MAX);
    case IO_LINE_HAS_NUL:
        return io_fail(reader, reader->line, PGEM_ERR_PARSE,
                       "line contains a NUL byte (binary data?)");
    case PGEM_ERR_OUT_OF_MEMORY:
        return io_fail(reader, reader->line, PGEM_ERR_OUT_OF_MEMORY, "out of memory");
    default:
        return io_fail(reader, reader->line, PGEM_ERR_IO, "read error: %s",
                       saved_errno != 0 ? strerror(saved_errno) : "unknown");
    }
}

static int io_read_lines(io_reader_t *reader, FILE *stream)
{
    io_line_t line = {NULL, 0, 0};
    int status = PGEM_OK;
    for (;;) {
        int got;
        errno = 0;
        got = io_read_line(stream, &line);
        if (got == IO_LINE_END) {
            break;
        }
        reader->line++;
        if (got != IO_LINE_READ) {
            status = io_line_error(reader, got, errno);
            break;
        }
        status = io_parse_line(reader, line.text);
        if (status != PGEM_OK) {
            break;
        }
    }
    io_line_free(&line);
    return status;
}

static int io_check_read_arguments(FILE *stream, pgem_format_t format, pgem_io_graph_t *graph,
                                   char *message, size_t message_size)
{
    if (stream == NULL || graph == NULL) {
        io_message(message, message_size, "pgem_io_read: NULL stream or graph");
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (format != PGEM_FORMAT_AUTO && format != PGEM_FORMAT_G2O && format != PGEM_FORMAT_TORO) {
        io_message(message, message_size, "pgem_io_read: unknown format %d", (int)format);
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    return PGEM_OK;
}

int pgem_io_read_stream(FILE *stream, const char *name, pgem_format_t format,
                        pgem_io_graph_t *graph, char *message, size_t message_size)
{
    io_reader_t reader;
    int status;
    io_message(message, message_size, "%s", "");
    if (graph != NULL) {
        memset(graph, 0, sizeof *graph);
    }
    status = io_check_read_arguments(stream, format, graph, message, message_size);
    if (status != PGEM_OK) {
        return status;
    }
    memset(&reader, 0, sizeof reader);
    reader.name = name != NULL ? name : "(stream)";
    reader.format = format;
    reader.graph = graph;
    reader.message = message;
    reader.message_size = message_size;
    status = io_read_lines(&reader, stream);
    if (status == PGEM_OK) {
        status = io_check_ids(&reader);
    }
    free(reader.fixed_lines);
    if (status != PGEM_OK) {
        pgem_io_graph_free(graph);
        return status;
    }
    snprintf(graph->source, sizeof graph->source, "%s", reader.name);
    return PGEM_OK;
}

int pgem_io_read(const char *path, pgem_format_t format, pgem_io_graph_t *graph, char *message,
                 size_t message_size)
{
    FILE *stream;
    int status;
    if (graph != NULL) {
        memset(graph, 0, sizeof *graph);
    }
    if (path == NULL) {
        io_message(message, message_size, "pgem_io_read: NULL path");
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    stream = fopen(path, "rb");
    if (stream == NULL) {
        io_message(message, message_size, "%s: cannot open: %s", path, strerror(errno));
        return PGEM_ERR_IO;
    }
    status = pgem_io_read_stream(stream, path, format, graph, message, message_size);
    fclose(stream);
    return status;
}
