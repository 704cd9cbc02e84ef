/* pgem I/O internals: the reader's state and the helpers shared between the lib/io files. */
#ifndef PGEM_IO_INTERNAL_H
#define PGEM_IO_INTERNAL_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "pgem/io.h"

/* Longest line accepted, in bytes without the line end. */
#define IO_LINE_MAX 65536u

/* Most fields a line can hold that the reader keeps (EDGE_SE3:QUAT has 31 with its tag). */
#define IO_FIELDS_MAX 32u

/* What io_read_line found besides a line (returned as negative values). */
#define IO_LINE_END 0           /* end of stream, no line */
#define IO_LINE_READ 1          /* a line was read */
#define IO_LINE_TOO_LONG (-100) /* more than IO_LINE_MAX bytes */
#define IO_LINE_HAS_NUL (-101)  /* a NUL byte (binary data) */

/* Bytes read from the stream at a time. */
#define IO_CHUNK_BYTES 65536u

/* A growing buffer holding one line, NUL-terminated, without its line end, and the chunk of
 * the stream the next lines are cut from. */
typedef struct io_line {
    char *text;
    size_t length;
    size_t capacity;
    size_t consumed;  /* bytes the last io_read_line took from the stream, line end included */
    char *chunk;      /* IO_CHUNK_BYTES read ahead from the stream */
    size_t chunk_start;  /* next unread byte of chunk */
    size_t chunk_end;    /* bytes held in chunk */
} io_line_t;

/* Everything one read needs besides the line itself. */
typedef struct io_reader {
    const char *name;              /* file name used in messages */
    pgem_format_t format;          /* which tags are accepted */
    int foreign_ids;               /* edges may name ids without a VERTEX line (counted) */
    pgem_io_graph_t *graph;        /* the graph being filled */
    unsigned long line;            /* current line number (1-based) */
    unsigned long dimension_line;  /* the line that decided graph->dimension */
    unsigned long *fixed_lines;    /* line of each graph->fixed entry */
    size_t fixed_line_count;       /* entries in fixed_lines (graph->fixed_count) */
    size_t fixed_lines_capacity;
    char *message;                 /* caller's message buffer (may be NULL) */
    size_t message_size;
    pgem_io_progress_fn progress;  /* may be NULL */
    void *progress_user;
    uint64_t bytes;                /* bytes read so far */
    uint64_t next_progress;        /* call progress when bytes reaches this */
} io_reader_t;

/* message.c: formats "NAME:LINE: text" (or "NAME: text" when line is 0) into a caller's
 * buffer (NULL / size 0 tolerated); text is cut to 511 bytes. */
void io_vmessage_at(char *message, size_t size, const char *name, unsigned long line,
                    const char *format, va_list args);
/* message.c: io_vmessage_at into the reader's message, with the reader's name; returns code. */
int io_fail(const io_reader_t *reader, unsigned long line, int code, const char *format, ...);
/* message.c: vsnprintf into a caller's buffer, tolerating NULL / size 0. */
void io_message(char *message, size_t size, const char *format, ...);
/* message.c: copies at most size-1 bytes of text, replacing unprintable bytes by '?'. */
void io_copy_printable(char *out, size_t size, const char *text);

/* lines.c: reads the next line (any of LF, CRLF; a final line may lack its end). */
int io_read_line(FILE *stream, io_line_t *line);
void io_line_free(io_line_t *line);

/* tokens.c: splits text in place on spaces, tabs and CRs; stores at most capacity fields and
 * returns how many there are in all. */
size_t io_split(char *text, char **fields, size_t capacity);
/* tokens.c: a whole unsigned decimal token (no sign, no overflow). 0 on success, -1 if not. */
int io_parse_id(const char *token, pgem_id_t *id);
/* tokens.c: a whole number token. */
/* numbers.c: strtod's contract (value, end pointer, errno) for every input, plain decimals
 * parsed exactly and fast. */
double io_strtod(const char *text, char **end);
/* numbers.c: the shortest text that strtod reads back to value's bits (up to 24 bytes and a
 * NUL into out, which holds IO_NUMBER_TEXT); returns its length. */
#define IO_NUMBER_TEXT 32
size_t io_format_double(double value, char *out);
#define IO_NUMBER_OK 0
#define IO_NUMBER_INVALID 1
#define IO_NUMBER_NOT_FINITE 2
int io_parse_number(const char *token, double *value);

/* layout.c: where the k-th information value of a line of this format and dimension goes in
 * the full row-major matrix (row <= col). */
void io_info_cell(pgem_format_t format, int dimension, size_t k, size_t *row, size_t *col);
/* layout.c: number of information values on an edge line of this dimension (6 or 21). */
size_t io_info_values(int dimension);
/* kinds.c: odometry when the ids differ by exactly one (either direction), else loop: a line's
 * kind before io_assign_edge_kinds has seen the whole file. */
pgem_edge_kind_t io_edge_kind(pgem_id_t from, pgem_id_t to);
/* kinds.c: of the edges between consecutive ids i and i+1 (either direction), the first in file
 * order is odometry, the later ones loop closures. PGEM_OK or PGEM_ERR_OUT_OF_MEMORY. */
int io_assign_edge_kinds(pgem_io_graph_t *graph);
/* kinds.c: the order to write the edges in so that io_assign_edge_kinds reads their kinds back:
 * *order NULL when graph order does (no loop closure between consecutive ids before an
 * odometry edge of its pair), else edge_count indices (free them). PGEM_OK or
 * PGEM_ERR_OUT_OF_MEMORY. */
int io_write_order(const pgem_io_graph_t *graph, size_t **order);
/* layout.c: the identity pose of a dimension. */
void io_identity_pose(int dimension, double *pose);

/* file_graph.c: appends one zeroed element of element_size bytes to *array (*count used of
 * *capacity, grown by doubling from 64) and returns it with *count bumped; NULL (nothing
 * changed) when out of memory. */
void *io_append(void **array, size_t *count, size_t *capacity, size_t element_size);
/* file_graph.c: io_append on a graph's arrays (NULL, PGEM_ERR_OUT_OF_MEMORY: out of memory). */
pgem_io_pose_t *io_graph_new_pose(pgem_io_graph_t *graph);
pgem_io_edge_t *io_graph_new_edge(pgem_io_graph_t *graph);
pgem_io_edge_t *io_graph_new_self_loop(pgem_io_graph_t *graph);
int io_graph_add_fixed(pgem_io_graph_t *graph, pgem_id_t id);

/* parse.c: handles one line of text (modified in place). */
int io_parse_line(io_reader_t *reader, char *text);

/* ids.c: after the last line: duplicate vertex ids, edges and FIX naming unknown ids, and
 * the chain guess for edge-only files. */
int io_check_ids(io_reader_t *reader);

/* chain.c: creates the poses of an edge-only graph, ordered by id, with a spanning-tree guess
 * (odometry first). FIX ids are checked afterwards by the caller. */
int io_chain_poses(io_reader_t *reader);

/* sorted_ids.c: sorts ids ascending; finds id in sorted ids (1 and *index if found, else 0). */
void io_sort_ids(pgem_id_t *ids, size_t count);
int io_find_id(const pgem_id_t *sorted, size_t count, pgem_id_t id, size_t *index);
/* sorted_ids.c: ids with where they came from (an index, or a file line in `index`), sorted by
 * both. */
void io_sort_keyed_ids(pgem_io_pose_index_t *items, size_t count);

#endif /* PGEM_IO_INTERNAL_H */
