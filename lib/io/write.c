/* pgem I/O write: a file graph as g2o (2D/3D) or TORO (2D) text, every number the shortest text
 * that reads back to its bits (numbers.c). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io_internal.h"

/* The tags a format and dimension are written with. */
typedef struct io_writer_tags {
    const char *vertex;
    const char *edge;
} io_writer_tags_t;

static io_writer_tags_t io_tags_for(pgem_format_t format, int dimension)
{
    io_writer_tags_t tags;
    if (format == PGEM_FORMAT_TORO) {
        tags.vertex = "VERTEX2";
        tags.edge = "EDGE2";
    } else if (dimension == 3) {
        tags.vertex = "VERTEX_SE3:QUAT";
        tags.edge = "EDGE_SE3:QUAT";
    } else {
        tags.vertex = "VERTEX_SE2";
        tags.edge = "EDGE_SE2";
    }
    return tags;
}

/* One line at a time: the tag, ids and numbers are laid out in a buffer and written with one
 * fwrite (the longest line, EDGE_SE3:QUAT, holds 28 numbers of at most 24 bytes). */
typedef struct io_line_out {
    char text[1024];
    size_t length;
} io_line_out_t;

static void io_out_text(io_line_out_t *line, const char *text)
{
    const size_t length = strlen(text);
    memcpy(line->text + line->length, text, length);
    line->length += length;
}

static void io_out_id(io_line_out_t *line, pgem_id_t id)
{
    char digits[24];
    size_t count = 0;
    do {
        digits[count++] = (char)('0' + (int)(id % 10u));
        id /= 10u;
    } while (id != 0);
    line->text[line->length++] = ' ';
    while (count > 0) {
        line->text[line->length++] = digits[--count];
    }
}

static void io_out_number(io_line_out_t *line, double value)
{
    line->text[line->length++] = ' ';
    line->length += io_format_double(value, line->text + line->length);
}

static void io_out_end(FILE *stream, io_line_out_t *line)
{
    line->text[line->length++] = '\n';
    (void)fwrite(line->text, 1, line->length, stream);
    line->length = 0;
}

static void io_write_numbers(io_line_out_t *line, const double *values, size_t count)
{
    size_t i;
    for (i = 0; i < count; ++i) {
        io_out_number(line, values[i]);
    }
}

static void io_write_poses(FILE *stream, const pgem_io_graph_t *graph, const char *tag)
{
    size_t i;
    io_line_out_t line = {{0}, 0};
    for (i = 0; i < graph->pose_count; ++i) {
        io_out_text(&line, tag);
        io_out_id(&line, graph->poses[i].id);
        io_write_numbers(&line, graph->poses[i].pose, (size_t)PGEM_POSE_SIZE(graph->dimension));
        io_out_end(stream, &line);
    }
}

static void io_write_fixed(FILE *stream, const pgem_io_graph_t *graph)
{
    size_t i;
    for (i = 0; i < graph->fixed_count; ++i) {
        fprintf(stream, "FIX %llu\n", (unsigned long long)graph->fixed[i]);
    }
}

/* The information values of an edge in the order the format writes them. */
static void io_write_information(io_line_out_t *line, pgem_format_t format, int dimension,
                                 const double *information)
{
    size_t n = (size_t)PGEM_TANGENT_SIZE(dimension);
    size_t k;
    for (k = 0; k < io_info_values(dimension); ++k) {
        size_t row;
        size_t col;
        io_info_cell(format, dimension, k, &row, &col);
        io_out_number(line, information[row * n + col]);
    }
}

/* The edges in graph order, or in `order` when it is not NULL (io_write_order). */
static void io_write_edges(FILE *stream, pgem_format_t format, const pgem_io_graph_t *graph,
                           const char *tag, const size_t *order)
{
    size_t i;
    io_line_out_t line = {{0}, 0};
    for (i = 0; i < graph->edge_count; ++i) {
        const pgem_io_edge_t *edge = &graph->edges[order != NULL ? order[i] : i];
        io_out_text(&line, tag);
        io_out_id(&line, edge->from);
        io_out_id(&line, edge->to);
        io_write_numbers(&line, edge->measurement, (size_t)PGEM_POSE_SIZE(graph->dimension));
        io_write_information(&line, format, graph->dimension, edge->information);
        io_out_end(stream, &line);
    }
}

static int io_check_write_arguments(pgem_format_t format, const pgem_io_graph_t *graph)
{
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (format != PGEM_FORMAT_AUTO && format != PGEM_FORMAT_G2O && format != PGEM_FORMAT_TORO) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (graph->dimension != 0 && graph->dimension != 2 && graph->dimension != 3) {
        return PGEM_ERR_DIMENSION;
    }
    if (format == PGEM_FORMAT_TORO && graph->dimension == 3) {
        return PGEM_ERR_DIMENSION;
    }
    return PGEM_OK;
}

int pgem_io_write_stream(FILE *stream, pgem_format_t format, const pgem_io_graph_t *graph)
{
    io_writer_tags_t tags;
    size_t *order;
    int status = io_check_write_arguments(format, graph);
    if (stream == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (status != PGEM_OK) {
        return status;
    }
    if (format == PGEM_FORMAT_AUTO) {
        format = PGEM_FORMAT_G2O;
    }
    if (graph->dimension == 0) {
        return PGEM_OK; /* an empty graph is an empty file */
    }
    status = io_write_order(graph, &order);
    if (status != PGEM_OK) {
        return status;
    }
    tags = io_tags_for(format, graph->dimension);
    io_write_poses(stream, graph, tags.vertex);
    if (format == PGEM_FORMAT_G2O) {
        io_write_fixed(stream, graph);
    }
    io_write_edges(stream, format, graph, tags.edge, order);
    free(order);
    return ferror(stream) ? PGEM_ERR_IO : PGEM_OK;
}

static int io_write_failed(const char *path, int status, char *message, size_t message_size)
{
    if (status == PGEM_ERR_DIMENSION) {
        io_message(message, message_size, "%s: TORO files hold 2D graphs only (graph is 3D)",
                   path);
    } else if (status == PGEM_ERR_IO) {
        io_message(message, message_size, "%s: write error: %s", path,
                   errno != 0 ? strerror(errno) : "unknown");
    } else if (status == PGEM_ERR_OUT_OF_MEMORY) {
        io_message(message, message_size, "%s: out of memory", path);
    } else {
        io_message(message, message_size, "%s: invalid graph or format", path);
    }
    return status;
}

int pgem_io_write(const char *path, pgem_format_t format, const pgem_io_graph_t *graph,
                  char *message, size_t message_size)
{
    FILE *stream;
    int status;
    io_message(message, message_size, "%s", "");
    if (path == NULL) {
        io_message(message, message_size, "pgem_io_write: NULL path");
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    status = io_check_write_arguments(format, graph);
    if (status != PGEM_OK) {
        return io_write_failed(path, status, message, message_size);
    }
    stream = fopen(path, "wb");
    if (stream == NULL) {
        io_message(message, message_size, "%s: cannot open for writing: %s", path,
                   strerror(errno));
        return PGEM_ERR_IO;
    }
    (void)setvbuf(stream, NULL, _IOFBF, (size_t)1 << 18); /* a few large writes */
    errno = 0;
    status = pgem_io_write_stream(stream, format, graph);
    if (fclose(stream) != 0 && status == PGEM_OK) {
        status = PGEM_ERR_IO;
    }
    return status == PGEM_OK ? PGEM_OK : io_write_failed(path, status, message, message_size);
}

int pgem_io_write_weights(FILE *stream, const pgem_t *instance)
{
    if (stream == NULL || instance == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    fprintf(stream, "# from to weight state (one line per loop closure)\n");
    for (uint32_t k = 0; k < pgem_edge_count(instance); k++) {
        pgem_edge_view_t edge;
        pgem_edge_at(instance, k, &edge);
        if (edge.kind == PGEM_EDGE_LOOP) {
            fprintf(stream, "%llu %llu %.9g %s\n", (unsigned long long)edge.from,
                    (unsigned long long)edge.to, edge.weight, edge.active ? "accepted" : "pruned");
        }
    }
    return ferror(stream) ? PGEM_ERR_IO : PGEM_OK;
}
