/* Shared pieces of the pgem command-line tool. */
#ifndef PGEM_CLI_H
#define PGEM_CLI_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "pgem/io.h"
#include "pgem/pgem.h"
#include "pgem/threads.h"

#include "json.h" /* lib/support: the JSON writer every --json output goes through */

/* Exit codes (documented in docs/CLI.md). */
#define PGEM_EXIT_OK 0
#define PGEM_EXIT_FAILURE 1  /* the solve failed or the input was rejected */
#define PGEM_EXIT_USAGE 2    /* bad command line */
#define PGEM_EXIT_IO 3       /* a file could not be read or written */

/* Monotonic seconds. */
double pgem_cli_now(void);

/* The tools apply the core's rule for 3D quaternions. */
#define PGEM_CLI_QUAT_TOLERANCE PGEM_QUAT_NORM_TOLERANCE

/* Normalises the quaternion q (qx qy qz qw) in place and returns its norm before; *refused is 1
 * when that norm is off 1 by more than PGEM_CLI_QUAT_TOLERANCE or not finite (what the core
 * refuses when loading). */
double pgem_cli_quat_check(double *q, int *refused);

/* A tool's command line, for pgem_cli_parse_args. */
typedef struct pgem_cli_parser {
    const char *tool;          /* name in messages: "pgem optimize", "pgem-lcm-send" */
    const char *const *valued; /* names of the options that take a value */
    size_t valued_count;
    /* One of them with its value (NULL when the command line ends there): 1, or 0 after
     * printing why the value is wrong. */
    int (*value)(void *args, const char *name, const char *value);
    /* A name that may be one of the tool's flags: 1 when it is (and is applied), else 0. */
    int (*flag)(void *args, const char *name);
    /* An argument that does not start with '-' (or is "-"): 1, or 0 after printing why it is
     * refused. NULL: the tool takes none. */
    int (*positional)(void *args, const char *argument);
    /* -h or --help: the help, to out. */
    void (*help)(FILE *out, const void *context);
    /* Options every tool of a family takes (the LCM tools' --url ...), tried first; NULL: none.
     * 1 when argv[*k] was one (with its value: *k left on it), 0 when not, -1 after printing a
     * usage error. */
    int (*common)(void *context, int argc, char **argv, int *k);
    void *context; /* for common and help */
} pgem_cli_parser_t;

/* The argument loop of every tool: the common options, -h/--help (help to stdout), then the
 * tool's flags, valued options and positional arguments; anything else is "TOOL: unknown
 * option 'X' (see TOOL --help)" (or "unknown argument"). Returns 0, -1 after --help, or
 * PGEM_EXIT_USAGE after a usage error was printed. */
int pgem_cli_parse_args(const pgem_cli_parser_t *parser, void *args, int argc, char **argv);

/* A command's one file argument into *field; a second one is "TOOL: more than one WHAT file
 * ('X')" and 0. */
int pgem_cli_one_file(const char *tool, const char *what, const char **field,
                      const char *argument);

/* An option's text value into *field; without one, "TOOL: NAME needs NOUN" ("a file name",
 * "a value") and 0. */
int pgem_cli_text_value(const char *tool, const char *name, const char *value, const char *noun,
                        const char **field);

/* Parses a non-negative integer option value; prints "PREFIX: OPTION needs a non-negative
 * integer, got 'TEXT'" and returns 0 on failure. */
int pgem_cli_parse_u32(const char *prefix, const char *option, const char *text,
                       uint32_t *value);

/* As pgem_cli_parse_u32, and at least `least`: below it prints "PREFIX: OPTION needs at least
 * LEAST WHAT, got N" and returns 0. */
int pgem_cli_parse_at_least(const char *prefix, const char *option, const char *text,
                            uint32_t least, const char *what, uint32_t *value);

/* Parses a finite number, positive when strict, else non-negative; prints "PREFIX: OPTION
 * needs a positive (non-negative) number, got 'TEXT'" and returns 0 on failure. */
int pgem_cli_parse_number(const char *prefix, const char *option, const char *text, int strict,
                          double *value);

/* Deterministic random numbers for a seed on every platform (splitmix64): uniform in [0, 1)
 * and standard normal (Box-Muller). */
double pgem_cli_uniform(uint64_t *state);
double pgem_cli_gaussian(uint64_t *state);
/* A false loop closure's measurement (pgem corrupt, pgem simulate --false-loops): translation
 * uniform in +-10 m per axis (z is drawn in 2D too, and not used), any rotation (2D: heading
 * uniform; 3D: uniform on the unit quaternions). */
void pgem_cli_random_pose(uint64_t *rng, int dimension, double *measurement);

/* Parses a robust kernel name (em, cauchy, huber, dcs, none); prints "PREFIX: --robust takes ..."
 * on failure. */
int pgem_cli_parse_kernel(const char *prefix, const char *text, pgem_kernel_t *kernel);

/* pgem_cli_read_graph flags. */
#define PGEM_CLI_NEED_POSES 1u   /* a graph without poses is an error ("PATH has no poses") */
#define PGEM_CLI_WARN_CHAINED 2u /* warn when the poses were guessed along the edges */
#define PGEM_CLI_LIST_SELF_LOOPS 4u /* the caller lists the skipped self-loop edges itself */
#define PGEM_CLI_FOREIGN_IDS 8u /* edges may name ids without a VERTEX line (another sender's
                                   poses): kept and counted (pgem_io_read_options_t) */
#define PGEM_CLI_OFFER_FOREIGN 16u /* a refused edge naming an id with no VERTEX line says that
                                      --foreign-ids takes it (pgem-lcm-send) */

/* pgem_cli_read_graph reports progress on stderr for files at least this large (64 MiB). */
#define PGEM_CLI_PROGRESS_MIN_BYTES (UINT64_C(64) << 20)

/* Reads a graph file (format by tag). Every message starts with prefix ("pgem", "pgem plot").
 * Returns PGEM_EXIT_OK, PGEM_EXIT_IO when the file could not be read, or PGEM_EXIT_FAILURE
 * when it was refused (or has no poses under PGEM_CLI_NEED_POSES). *graph is the caller's to
 * free, also on failure. */
int pgem_cli_read_graph(const char *prefix, const char *path, unsigned flags,
                        pgem_io_graph_t *graph);

/* Writes a file graph as g2o (through pgem_cli_file_t); prints "PREFIX: ..." on failure.
 * Returns a PGEM_EXIT_* code. */
int pgem_cli_write_graph(const char *prefix, const pgem_io_graph_t *graph, const char *path);

/* An output file written whole or not at all (cli_file.c): the stream writes a new temporary
 * file beside PATH (.NAME.XXXXXX in its folder), which replaces PATH when it is complete and
 * synced, so a failure (a full disk) leaves PATH as it was and `-o` onto the input cannot
 * destroy it. A PATH that is a symbolic link keeps it (its target is replaced); one that is a
 * device or a pipe (/dev/stdout) is written directly. */
typedef struct pgem_cli_file {
    FILE *stream;        /* write here between open and commit */
    const char *prefix;  /* for messages: "pgem", "pgem-lcm-dump", ... */
    const char *path;    /* as given */
    char *target;        /* the file the rename replaces (heap; NULL when written directly) */
    char *temporary;     /* the file written (heap; NULL when written directly) */
} pgem_cli_file_t;

/* Returns 0, or -1 after printing "PREFIX: PATH: cannot ...: reason". */
int pgem_cli_file_open(pgem_cli_file_t *file, const char *prefix, const char *path);

/* Flushes, syncs and closes the stream and renames the temporary file over PATH. With
 * `failed` set (an earlier write failed), or when a step fails, prints "PREFIX: PATH: STEP
 * failed: reason (the file is as it was)", removes the temporary file and returns
 * PGEM_EXIT_IO; else PGEM_EXIT_OK. The file is closed either way. */
int pgem_cli_file_commit(pgem_cli_file_t *file, int failed);

/* Closes the stream and removes the temporary file: PATH stays as it was (nothing printed). */
void pgem_cli_file_discard(pgem_cli_file_t *file);

/* Writes one line per loop closure, "from to weight state"; prints errors; 0 on success. */
int pgem_cli_write_weights(const pgem_t *instance, const char *path);

/* Graphs from this many poses on get a line on stderr before their (seconds long) analysis. */
#define PGEM_CLI_ANALYSIS_NOTICE_POSES 20000u

/* Sets the ordering of the instances pgem_cli_load creates from an --ordering value (auto, amd,
 * nested, metis; metis only in a build with METIS); 0 after printing why not. */
int pgem_cli_set_ordering(const char *prefix, const char *text);

/* Creates an instance sized for a file graph with `threads` workers and loads it, with the
 * fill budget set to exactly what the symbolic analysis asks for. *analysis_seconds (may be
 * NULL) receives the time of the analyses (a solve that follows does not repeat them).
 * Prints errors to stderr. Returns PGEM_OK or an error code. */
int pgem_cli_load(const pgem_io_graph_t *file, const char *path, uint32_t threads,
                  pgem_t **instance, double *analysis_seconds);

/* As pgem_cli_load, with what went wrong in message instead of on stderr (a core message
 * without "PATH: " when path is NULL). */
int pgem_cli_load_quietly(const pgem_io_graph_t *file, const char *path, uint32_t threads,
                          pgem_t **instance, double *analysis_seconds, char *message,
                          size_t message_size);

/* The instance's edges, as it holds them, into file, the graph it was loaded from (the same
 * edges in the same order); 0 if file does not match. */
int pgem_cli_refill_edges(const pgem_t *instance, pgem_io_graph_t *file);

/* Writes an instance to a g2o file; prints errors. Returns a PGEM_EXIT_* code. file (may be
 * NULL) is the graph the instance was loaded from, still held: it is overwritten with the
 * instance's graph and written, instead of a fresh copy. edge_text (may be NULL): the
 * instance's edge lines, already formatted (write_ahead.h), written after its poses. */
int pgem_cli_write(const pgem_t *instance, pgem_io_graph_t *file, const char *path,
                   const char *edge_text, size_t edge_bytes);


/* An ordered pair of pose ids and what it belongs to (an edge, a line, a loop). */
typedef struct pgem_cli_pair {
    pgem_id_t from;
    pgem_id_t to;
    size_t index;
} pgem_cli_pair_t;

/* Sorts pairs by (from, to, index); pairs may be NULL when count is 0. */
void pgem_cli_sort_pairs(pgem_cli_pair_t *pairs, size_t count);

/* The end of the run of sorted pairs equal to (from, to) that starts at `first`. */
size_t pgem_cli_pair_run_end(const pgem_cli_pair_t *pairs, size_t count, size_t first,
                             pgem_id_t from, pgem_id_t to);

/* A value for a text line with `decimals` after the point (%.*f), or in exponent form (%.*e)
 * from 1e15 on, where %f would print up to 309 digits (a chi2 of 1e308). Returns out. */
#define PGEM_CLI_NUMBER_MAX 40 /* bytes a pgem_cli_number buffer needs */
const char *pgem_cli_number(char *out, size_t size, double value, int decimals);

/* "s" unless count is 1. */
const char *pgem_cli_plural(size_t count);

int pgem_cmd_optimize(int argc, char **argv);
int pgem_cmd_simulate(int argc, char **argv);
int pgem_cmd_corrupt(int argc, char **argv);
int pgem_cmd_eval(int argc, char **argv);
int pgem_cmd_plot(int argc, char **argv);
int pgem_cmd_stats(int argc, char **argv);

#endif /* PGEM_CLI_H */
