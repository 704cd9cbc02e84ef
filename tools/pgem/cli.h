/* Shared pieces of the pgem command-line tool. */
#ifndef PGEM_CLI_H
#define PGEM_CLI_H

#include <stdint.h>

#include "pgem/io.h"
#include "pgem/pgem.h"

/* Exit codes (documented in the README). */
#define PGEM_EXIT_OK 0
#define PGEM_EXIT_FAILURE 1  /* the solve failed or the input was rejected */
#define PGEM_EXIT_USAGE 2    /* bad command line */
#define PGEM_EXIT_IO 3       /* a file could not be read or written */

/* Monotonic seconds. */
double pgem_cli_now(void);

/* Parses a non-negative integer option value; prints an error and returns 0 on failure. */
int pgem_cli_parse_u32(const char *option, const char *text, uint32_t *value);

/* Deterministic random numbers for a seed on every platform (splitmix64): uniform in [0, 1)
 * and standard normal (Box-Muller). */
double pgem_cli_uniform(uint64_t *state);
double pgem_cli_gaussian(uint64_t *state);

/* Parses a robust kernel name (em, cauchy, huber, dcs, none); prints an error on failure. */
int pgem_cli_parse_kernel(const char *text, pgem_kernel_t *kernel);

/* Parses a positive finite number; prints an error and returns 0 on failure. */
int pgem_cli_parse_positive(const char *option, const char *text, double *value);

/* Writes one line per loop closure, "from to weight state"; prints errors; 0 on success. */
int pgem_cli_write_weights(const pgem_t *instance, const char *path);

/* Creates an instance sized for a file graph and loads it, with the fill budget set to
 * exactly what the symbolic analysis asks for.
 * Prints errors to stderr. Returns PGEM_OK or an error code. */
int pgem_cli_load(const pgem_io_graph_t *file, const char *path, pgem_t **instance);

/* Writes an instance to a g2o file; prints errors. */
int pgem_cli_write(const pgem_t *instance, const char *path);

/* Writes text to stdout as a JSON string: quoted, with '"', '\\' and control bytes escaped. */
void pgem_cli_json_string(const char *text);

int pgem_cmd_optimize(int argc, char **argv);
int pgem_cmd_simulate(int argc, char **argv);
int pgem_cmd_corrupt(int argc, char **argv);
int pgem_cmd_eval(int argc, char **argv);
int pgem_cmd_plot(int argc, char **argv);
int pgem_cmd_stats(int argc, char **argv);

#endif /* PGEM_CLI_H */
