/** @file
 * pgem I/O (hosted only): g2o and TORO graph files to and from a core instance. */
#ifndef PGEM_IO_H
#define PGEM_IO_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "pgem/core.h"
#include "pgem/graph.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pgem_format {
    PGEM_FORMAT_AUTO = 0,  /**< read: decided per line by its tag; write: g2o */
    PGEM_FORMAT_G2O = 1,   /**< VERTEX_SE2, EDGE_SE2, VERTEX_SE3:QUAT, EDGE_SE3:QUAT, FIX */
    PGEM_FORMAT_TORO = 2   /**< VERTEX2, EDGE2 (information xx xy yy tt xt yt), EQUIV skipped */
} pgem_format_t;

/** One pose as read from a file. */
typedef struct pgem_io_pose {
    pgem_id_t id;                        /**< pose id as written */
    double pose[PGEM_POSE_SIZE_MAX];     /**< 2D [x y theta]; 3D [x y z qx qy qz qw] */
    unsigned long line;                  /**< line it came from (0 = made by the reader) */
} pgem_io_pose_t;

/** One edge as read from a file, information expanded to a full row-major matrix. */
typedef struct pgem_io_edge {
    pgem_id_t from;                      /**< first pose id */
    pgem_id_t to;                        /**< second pose id */
    double measurement[PGEM_POSE_SIZE_MAX];
    double information[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    pgem_edge_kind_t kind;               /**< the first edge between ids i and i+1 in file
                                              order is odometry, the others loop closures */
    unsigned long line;                  /**< line it came from (0 = not from a file) */
} pgem_io_edge_t;

/** lib/io's own error codes, beside the core's pgem_error_t (which the reader and the loader
 * also return): the values the core leaves free, the ones these codes had when they were part
 * of pgem_error_t. */
typedef enum pgem_io_error {
    PGEM_ERR_IO = -17,   /**< a file could not be opened, read or written */
    PGEM_ERR_PARSE = -18 /**< a line of a graph file is malformed */
} pgem_io_error_t;

/** pgem_error_name and pgem_error_description for a status of lib/io: its own codes, and the
 * core's through those (header only, so a program that names codes links nothing more). */
static inline const char *pgem_io_error_name(int code)
{
    return code == PGEM_ERR_IO      ? "PGEM_ERR_IO"
           : code == PGEM_ERR_PARSE ? "PGEM_ERR_PARSE"
                                    : pgem_error_name(code);
}
static inline const char *pgem_io_error_description(int code)
{
    return code == PGEM_ERR_IO      ? "a file could not be opened, read or written"
           : code == PGEM_ERR_PARSE ? "a line of a graph file is malformed"
                                    : pgem_error_description(code);
}

/** A whole graph file in memory (heap-allocated; release with pgem_io_graph_free). */
typedef struct pgem_io_graph {
    int dimension;                       /**< 2 or 3 (0 while empty) */
    pgem_io_pose_t *poses;               /**< pose_count entries, file order */
    size_t pose_count;
    size_t pose_capacity;
    pgem_io_edge_t *edges;               /**< edge_count entries, file order */
    size_t edge_count;
    size_t edge_capacity;
    pgem_id_t *fixed;                    /**< ids named by FIX lines */
    size_t fixed_count;
    size_t fixed_capacity;
    size_t chained_poses;                /**< poses with no VERTEX line, guessed by composing
                                            edges along a spanning tree (odometry first) */
    size_t unknown_lines;                /**< lines with a tag the reader does not know */
    char first_unknown_tag[32];          /**< the first such tag */
    unsigned long first_unknown_line;    /**< and its line */
    size_t equiv_lines;                  /**< TORO EQUIV lines skipped */
    size_t toro_edges;                   /**< edges read from TORO EDGE2 lines (counted in
                                            edge_count too; 0 for g2o edges) */
    char source[256];                    /**< path or stream name read ("" if not from a file);
                                            pgem_io_load prefixes its messages with it */
    size_t foreign_edges;                /**< edges naming an id with no VERTEX line, read
                                            with pgem_io_read_options_t.foreign_ids (0
                                            otherwise: such a file is refused) */
    unsigned long first_foreign_line;    /**< the first such edge's line */
    pgem_io_edge_t *self_loops;          /**< edges joining a pose to itself (FROM == TO),
                                            self_loop_count entries in file order: they
                                            constrain nothing, so they are left out of edges
                                            (a caller warns with their lines) */
    size_t self_loop_count;
    size_t self_loop_capacity;
} pgem_io_graph_t;

/** Reads a graph file. Blank lines and lines starting with '#' are ignored. Poses without a
 * VERTEX line get an initial guess composed from the edges (odometry chain first). On error
 * returns PGEM_ERR_IO / PGEM_ERR_PARSE / PGEM_ERR_DIMENSION / PGEM_ERR_UNKNOWN_ID /
 * PGEM_ERR_DUPLICATE_ID / PGEM_ERR_OUT_OF_RANGE (or PGEM_ERR_OUT_OF_MEMORY), writes
 * "FILE:LINE: what is wrong" into
 * message, and leaves *file empty.
 * - *file is overwritten, not freed: release a graph read earlier with pgem_io_graph_free.
 * - An empty file (or one with only blank, comment or unknown lines) is a valid empty graph
 *   with dimension 0.
 * - With PGEM_FORMAT_AUTO every tag below is accepted; with PGEM_FORMAT_G2O only the g2o tags
 *   (incl. FIX), with PGEM_FORMAT_TORO only VERTEX2 / EDGE2 / EQUIV. Any other tag is counted
 *   in unknown_lines, not an error. FIX takes one or more ids (as g2o writes it).
 * - An edge joining a pose to itself (EDGE_SE2 1 1 ...) is kept in self_loops, not edges: it
 *   constrains nothing, and peers read such files (the core refuses one through its API).
 * - A file with edge lines but no VERTEX line gets one pose per referenced id, ordered by id;
 *   if some ids have VERTEX lines, an edge naming an id without one is PGEM_ERR_UNKNOWN_ID.
 * - Lines are limited to 65536 bytes; a NUL byte in a line is PGEM_ERR_PARSE. Either stops
 *   the read where it is found (a stream that never ends a line is not read to its end).
 * - LF and CRLF line ends are accepted, and a UTF-8 byte order mark at the start of the file
 *   is skipped. The memory a read takes depends on the graph, not on the file's size: blank,
 *   comment and unknown lines cost nothing.
 * - A translation beyond PGEM_TRANSLATION_LIMIT or an information value beyond
 *   PGEM_INFORMATION_LIMIT (pgem/graph.h) is PGEM_ERR_OUT_OF_RANGE, naming the field: a graph
 *   that reads loads (capacity and the core's other checks aside) with a finite chi2.
 * FORMATS.md at the repository root lists every accepted line. */
int pgem_io_read(const char *path, pgem_format_t format, pgem_io_graph_t *file,
                 char *message, size_t message_size);

/** Progress of a long read, for a tool that shows it: bytes and lines read so far. */
typedef void (*pgem_io_progress_fn)(uint64_t bytes, unsigned long lines, void *user);

/** Bytes between two calls of a pgem_io_progress_fn (16 MiB). */
#define PGEM_IO_PROGRESS_BYTES (UINT64_C(16) << 20)

/** As pgem_io_read, calling progress (if not NULL) each time another PGEM_IO_PROGRESS_BYTES
 * have been read. */
int pgem_io_read_progress(const char *path, pgem_format_t format, pgem_io_graph_t *file,
                          char *message, size_t message_size, pgem_io_progress_fn progress,
                          void *user);

/** How pgem_io_read_with reads; zero-initialise for pgem_io_read's behaviour. */
typedef struct pgem_io_read_options {
    pgem_format_t format;        /**< which tags are accepted (PGEM_FORMAT_AUTO: all) */
    int foreign_ids;             /**< 1: in a file with VERTEX lines, an edge may name an id
                                      that has none, another source's pose (one robot's file of
                                      a team, whose loop closures name other robots' poses): it
                                      is kept and counted in foreign_edges. pgem_io_load refuses
                                      such a graph (the core has no pose for it); pgem-lcm-send
                                      streams it, and the bridge holds the edge until the pose
                                      arrives from its own sender */
    pgem_io_progress_fn progress; /**< NULL, or called as for pgem_io_read_progress */
    void *progress_user;
} pgem_io_read_options_t;

/** pgem_io_read with options (NULL: the defaults, exactly pgem_io_read). */
int pgem_io_read_with(const char *path, const pgem_io_read_options_t *options,
                      pgem_io_graph_t *file, char *message, size_t message_size);

/** As pgem_io_read, from an open stream; name is used in messages. */
int pgem_io_read_stream(FILE *stream, const char *name, pgem_format_t format,
                        pgem_io_graph_t *file, char *message, size_t message_size);

void pgem_io_graph_free(pgem_io_graph_t *file);

/** A pose id and where its pose is in a file graph's poses (or, inside the reader, the line it
 * came from): what pgem_io_index_poses sorts, by id and then index. */
typedef struct pgem_io_pose_index {
    pgem_id_t id;
    size_t index;
} pgem_io_pose_index_t;

/** pgem_io_find_pose: no pose with that id. */
#define PGEM_IO_NO_POSE ((size_t)-1)

/** The poses of a file graph sorted by id, in a new array of pose_count entries (free it); NULL
 * when out of memory. */
pgem_io_pose_index_t *pgem_io_index_poses(const pgem_io_graph_t *file);

/** The index in the file graph of the pose with this id, from its sorted index (count
 * entries), or PGEM_IO_NO_POSE. */
size_t pgem_io_find_pose(const pgem_io_pose_index_t *sorted, size_t count, pgem_id_t id);

/** A config whose capacities fit the graph exactly (dimension, max_poses, max_edges). */
void pgem_io_config(const pgem_io_graph_t *file, pgem_config_t *config);

/** Adds every pose, edge and FIX of the file graph to an empty instance. On error the message
 * names the file line of the offending pose or edge and the instance's message is appended.
 * A graph read with foreign ids that has foreign edges is PGEM_ERR_UNKNOWN_ID with nothing added.
 * A graph larger than the instance's free capacity is PGEM_ERR_CAPACITY with nothing added;
 * after any other error the instance holds the poses and edges added before the offending
 * one: discard it (the core cannot take them back). */
int pgem_io_load(const pgem_io_graph_t *file, pgem_t *graph, char *message,
                 size_t message_size);

/** Copies an instance (poses, edges, fixed poses) into a file graph (*file is overwritten, as
 * for pgem_io_read). Edge kinds are copied as the instance has them. */
int pgem_io_from_instance(const pgem_t *graph, pgem_io_graph_t *file);

/** Writes a file graph (g2o or TORO 2D) with round-trip precision (%.17g): vertices, then the
 * FIX lines (g2o only; TORO has no way to say a pose is fixed, so they are not written), then
 * edges in graph order, except that between ids i and i+1 the odometry edge is written before
 * the loop closures, so reading the file back gives every edge its kind (the formats have no
 * kind field; FORMATS.md). TORO for a 3D graph is PGEM_ERR_DIMENSION; a failed write is
 * PGEM_ERR_IO, no memory for that order PGEM_ERR_OUT_OF_MEMORY. */
int pgem_io_write(const char *path, pgem_format_t format, const pgem_io_graph_t *file,
                  char *message, size_t message_size);
int pgem_io_write_stream(FILE *stream, pgem_format_t format, const pgem_io_graph_t *file);

/** Writes the loop closures of an instance, one line each in edge order: "from to weight
 * state" (state "accepted" or "pruned"), after a "#" header line. The format `pgem optimize
 * --weights` writes and `pgem eval --weights` reads. PGEM_ERR_IO if a write failed. */
int pgem_io_write_weights(FILE *stream, const pgem_t *graph);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_IO_H */
