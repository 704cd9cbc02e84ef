/* pgem I/O read: reads a g2o or TORO file line by line into a file graph. */
#include <errno.h>
#include <limits.h>
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

/* The text of a line to parse: a UTF-8 byte order mark (some Windows editors start every file
 * with one) is skipped on line 1, or the first tag would not be recognised and its line would
 * be counted as unknown instead of read. */
static char *io_line_text(const io_reader_t *reader, io_line_t *line)
{
    static const char bom[] = "\xEF\xBB\xBF";
    if (reader->line == 1 && line->length >= 3 && memcmp(line->text, bom, 3) == 0) {
        return line->text + 3;
    }
    return line->text;
}

/* Counts the bytes of a line and calls the progress callback when another step is read. */
static void io_count_bytes(io_reader_t *reader, const io_line_t *line)
{
    reader->bytes += line->consumed;
    if (reader->progress != NULL && reader->bytes >= reader->next_progress) {
        reader->progress(reader->bytes, reader->line, reader->progress_user);
        reader->next_progress = reader->bytes - reader->bytes % PGEM_IO_PROGRESS_BYTES +
                                PGEM_IO_PROGRESS_BYTES;
    }
}

static int io_read_lines(io_reader_t *reader, FILE *stream)
{
    io_line_t line = {NULL, 0, 0, 0, NULL, 0, 0};
    int status = PGEM_OK;
    reader->next_progress = PGEM_IO_PROGRESS_BYTES;
    for (;;) {
        int got;
        errno = 0;
        got = io_read_line(stream, &line);
        if (got == IO_LINE_END) {
            break;
        }
        if (reader->line == ULONG_MAX) { /* 32-bit longs: a file of more than 4 Gi lines */
            status = io_fail(reader, 0, PGEM_ERR_PARSE, "more than %lu lines", ULONG_MAX);
            break;
        }
        reader->line++;
        io_count_bytes(reader, &line);
        if (got != IO_LINE_READ) {
            status = io_line_error(reader, got, errno);
            break;
        }
        status = io_parse_line(reader, io_line_text(reader, &line));
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

static int io_read_stream(FILE *stream, const char *name, const pgem_io_read_options_t *options,
                          pgem_io_graph_t *graph, char *message, size_t message_size)
{
    const pgem_format_t format = options->format;
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
    reader.foreign_ids = options->foreign_ids != 0;
    reader.progress = options->progress;
    reader.progress_user = options->progress_user;
    status = io_read_lines(&reader, stream);
    if (status == PGEM_OK) {
        status = io_assign_edge_kinds(graph); /* before the chain guess, which follows odometry */
        if (status != PGEM_OK) {
            io_message(message, message_size, "%s: out of memory", reader.name);
        }
    }
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

int pgem_io_read_stream(FILE *stream, const char *name, pgem_format_t format,
                        pgem_io_graph_t *graph, char *message, size_t message_size)
{
    pgem_io_read_options_t options;
    memset(&options, 0, sizeof options);
    options.format = format;
    return io_read_stream(stream, name, &options, graph, message, message_size);
}

int pgem_io_read(const char *path, pgem_format_t format, pgem_io_graph_t *graph, char *message,
                 size_t message_size)
{
    return pgem_io_read_progress(path, format, graph, message, message_size, NULL, NULL);
}

int pgem_io_read_progress(const char *path, pgem_format_t format, pgem_io_graph_t *graph,
                          char *message, size_t message_size, pgem_io_progress_fn progress,
                          void *user)
{
    pgem_io_read_options_t options;
    memset(&options, 0, sizeof options);
    options.format = format;
    options.progress = progress;
    options.progress_user = user;
    return pgem_io_read_with(path, &options, graph, message, message_size);
}

int pgem_io_read_with(const char *path, const pgem_io_read_options_t *options,
                      pgem_io_graph_t *graph, char *message, size_t message_size)
{
    pgem_io_read_options_t defaults;
    FILE *stream;
    int status;
    if (options == NULL) {
        memset(&defaults, 0, sizeof defaults);
        options = &defaults;
    }
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
    status = io_read_stream(stream, path, options, graph, message, message_size);
    fclose(stream);
    return status;
}
