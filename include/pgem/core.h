/** @file
 * pgem core: configuration, memory sizing and initialisation of a fixed-memory instance. */
#ifndef PGEM_CORE_H
#define PGEM_CORE_H

#include <stddef.h>
#include <stdint.h>

#include "pgem/error.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Version of the library (semantic versioning). */
#define PGEM_VERSION_MAJOR 0
#define PGEM_VERSION_MINOR 1
#define PGEM_VERSION_PATCH 0

/** Defaults used when a config field is 0. */
#define PGEM_DEFAULT_DIMENSION 2
#define PGEM_DEFAULT_MAX_POSES 1024u
#define PGEM_DEFAULT_EDGES_PER_POSE 4u  /* max_edges = 4 * max_poses */
#define PGEM_DEFAULT_FILL_PER_POSE 32u  /* fill_budget = 32 * block * block * max_poses */

/** Largest capacities accepted (indices are 32-bit inside the core). */
#define PGEM_MAX_POSES_LIMIT 4000000u
#define PGEM_MAX_EDGES_LIMIT 16000000u
/** Most workers a factorisation can use (config.threads). */
#define PGEM_MAX_THREADS 64u

/** One configuration decides every size; a zeroed config means defaults. */
typedef struct pgem_config {
    int dimension;         /**< 2 = SE(2) poses, 3 = SE(3) poses; 0 means 2 */
    uint32_t max_poses;    /**< pose capacity, 1 .. PGEM_MAX_POSES_LIMIT; 0 means 1024 */
    uint32_t max_edges;    /**< edge capacity, 1 .. PGEM_MAX_EDGES_LIMIT; 0 means 4 * max_poses */
    uint32_t fill_budget;  /**< scalar nonzeros reserved for the Cholesky factor L (each costs
                              8.4 bytes in 2D, 8.1 in 3D); 0 means 32 * b * b * max_poses
                              with b = 3 (2D) or 6 (3D).
                              A graph whose factor needs more fails to optimize with
                              PGEM_ERR_FILL_BUDGET and the message gives the number needed. */
    uint32_t threads;      /**< workers a factorisation can use, 1 .. PGEM_MAX_THREADS; 0 means
                              1. Each has its own workspace in the block; the threads
                              themselves come from an executor (pgem_set_executor), e.g. the
                              hosted thread pool (pgem/threads.h). Results are bit-identical
                              for any number of workers. */
    uint32_t online_fill;  /**< scalar nonzeros reserved for the incremental factor of
                              pgem_update (pgem/update.h); 0 (the default) reserves none and
                              pgem_update is refused. About twice the batch factor's
                              nonzeros leaves it room to grow between re-orderings; the
                              block grows by PGEM_ONLINE_BYTES. */
} pgem_config_t;

/** An instance: lives entirely inside the caller's memory block. Opaque. */
typedef struct pgem pgem_t;

/** Fills every 0 field of *config with its default; returns PGEM_OK or PGEM_ERR_CONFIG.
 * A NULL or invalid config leaves *resolved untouched. */
int pgem_config_resolve(const pgem_config_t *config, pgem_config_t *resolved);

/** Bytes of the memory block a configuration needs (0 if the config is invalid). The block is
 * used at any alignment. */
size_t pgem_memory_size(const pgem_config_t *config);

/** The block of a configuration by part: what each layer carves from it, alignment padding
 * included (pgem_memory_layout). */
typedef struct pgem_memory_parts {
    size_t instance;      /**< the instance struct, and the 16 bytes an unaligned block start
                               may cost */
    size_t graph;         /**< poses (ids, estimate, fixed flags), the id map, edges
                               (measurement, information, kind, state, weight) */
    size_t solver;        /**< the estimate before a solve and LM's last accepted one */
    size_t robust;        /**< the estimate before a robust solve, the saved weights and
                               states, the loops' distances */
    size_t linalg;        /**< the linear system: H's structure and values, the factor L, the
                               workers' and the solves' workspace, CSparse's pool */
    size_t factor;        /**< of linalg: L's values and block row indices, the part that
                               fill_budget scales */
    size_t csparse_pool;  /**< of linalg: CSparse's pool (0 with the system CSparse) */
    size_t total;         /**< instance + graph + solver + robust + linalg:
                               pgem_memory_size(config) */
} pgem_memory_parts_t;

/** The bytes of pgem_memory_size(config) by part, measured by the same carving code. Errors:
 * INVALID_ARGUMENT (a NULL pointer), CONFIG (where pgem_memory_size returns 0); nothing is
 * written then. */
int pgem_memory_layout(const pgem_config_t *config, pgem_memory_parts_t *parts);

/** A compile-time upper bound of pgem_memory_size() for explicit capacities (none 0) and one
 * worker (threads 0 or 1), for static blocks:
 * `static unsigned char block[PGEM_MEMORY_BOUND(2, 500, 600, 16000)];`.
 * Per pose 357 bytes in 2D (677 in 3D), per edge 237 (701), per factor nonzero 8 plus 4 per
 * b x b block (b = 3 or 6), the region the analysis's scratch, the factorisation's dense
 * workspace and the solves' vectors share (PGEM_SHARED_BYTES) and 3000 for the instance
 * itself and alignment. It includes CSparse's pool of the source-built mode (56 bytes per
 * pose, 24 per edge), so it holds for both modes, on 32- and 64-bit machines; the id map's
 * power-of-two size makes it exceed the exact figure by up to 8 bytes per pose. */
#define PGEM_MEMORY_BOUND(dimension, max_poses, max_edges, fill_budget)               \
    ((size_t)(max_poses) * ((dimension) == 3 ? 677u : 357u) +                         \
     (size_t)(max_edges) * ((dimension) == 3 ? 701u : 237u) +                         \
     (size_t)(fill_budget) * 8u + (size_t)(fill_budget) / ((dimension) == 3 ? 36u : 9u) * 4u + \
     PGEM_SHARED_BYTES(dimension, max_poses, max_edges) + 3000u)

/** Bytes of the shared region: the most of the analysis's scratch (12 per edge, 16 per pose),
 * the first worker's dense workspace (PGEM_WORK_BYTES) and one pose block of doubles per pose
 * (72 bytes in 2D, 288 in 3D: the solves after a factorisation). */
#define PGEM_SHARED_BYTES(dimension, max_poses, max_edges)                                  \
    PGEM_WORK_MAX_(PGEM_WORK_MAX_((size_t)(max_edges) * 12u + (size_t)(max_poses) * 16u + 24u, \
                                  PGEM_WORK_BYTES(dimension, max_poses)),                   \
                   (size_t)(max_poses) * ((dimension) == 3 ? 288u : 72u))

/** PGEM_MEMORY_BOUND for `threads` workers: each one past the first adds its own map of the
 * block rows (4 bytes per pose) and a smaller dense workspace. */
#define PGEM_MEMORY_BOUND_THREADS(dimension, max_poses, max_edges, fill_budget, threads)   \
    (PGEM_MEMORY_BOUND(dimension, max_poses, max_edges, fill_budget) +                       \
     ((size_t)(threads) > 1u ? (size_t)(threads) - 1u : 0u) *                                \
         ((size_t)(max_poses) * 4u + PGEM_WORK_BYTES_(dimension, max_poses, 8u) + 64u))

/** Bytes of the first worker's dense workspace: half a pose block of doubles per pose
 * (b x b / 2; an eighth for the other workers), at least 32 doubles per column of a product of
 * min(128, unknowns) columns, at most 49152 doubles (384 KiB). */
#define PGEM_WORK_BYTES(dimension, max_poses) PGEM_WORK_BYTES_(dimension, max_poses, 2u)
#define PGEM_WORK_BYTES_(dimension, max_poses, share)                                        \
    (8u * PGEM_WORK_CLAMP_(PGEM_WORK_SHARE_(dimension, max_poses, share),                    \
                           32u * PGEM_WORK_MIN_(PGEM_WORK_UNKNOWNS_(dimension, max_poses), 128u)))
#define PGEM_WORK_UNKNOWNS_(dimension, max_poses) ((size_t)(max_poses) * ((dimension) == 3 ? 6u : 3u))
#define PGEM_WORK_SHARE_(dimension, max_poses, share) \
    (PGEM_WORK_UNKNOWNS_(dimension, max_poses) * ((dimension) == 3 ? 6u : 3u) / (share))
#define PGEM_WORK_MIN_(a, b) ((a) < (b) ? (a) : (b))
#define PGEM_WORK_MAX_(a, b) ((a) > (b) ? (a) : (b))
#define PGEM_WORK_CLAMP_(share, least) \
    PGEM_WORK_MIN_((share) < (least) ? (least) : (share), (size_t)49152u)

/** Initialises an instance inside buffer (size bytes, at least pgem_memory_size(config)).
 * On success *graph points into buffer; nothing is allocated, now or later (with the
 * system CSparse, its symbolic analysis mallocs and frees workspace: see
 * docs/design/csparse-and-exhaustion.md). There is no teardown: the caller owns the buffer.
 * pgem_init_message() below is the same call, saying why it failed. */
int pgem_init(pgem_t **graph, const pgem_config_t *config, void *buffer, size_t size);

/** pgem_init that says why it failed (there is no instance yet for pgem_last_error): on
 * failure writes one line into message (message_size bytes, always NUL-terminated; NULL for
 * none), e.g. "the memory block is too small: 4095 bytes given, this configuration needs 4096
 * (pgem_memory_size)", and leaves *graph as it was. "" on success.
 * Errors: INVALID_ARGUMENT (a NULL graph, config or buffer), CONFIG (names the field),
 * BUFFER_TOO_SMALL. The block may start at any address: pgem_memory_size() includes the
 * 15 bytes an unaligned start can cost. */
int pgem_init_message(pgem_t **graph, const pgem_config_t *config, void *buffer, size_t size,
                      char *message, size_t message_size);

#ifndef PGEM_NO_MALLOC
/** Hosted convenience: mallocs one block of pgem_memory_size(config) and initialises it.
 * Release with pgem_destroy(). Not declared (nor built) when PGEM_NO_MALLOC is defined. */
int pgem_create(pgem_t **graph, const pgem_config_t *config);
void pgem_destroy(pgem_t *graph);
#endif

/** The resolved configuration of an instance. */
const pgem_config_t *pgem_resolved_config(const pgem_t *graph);

/** The message of the last failed call on this instance ("" if none): names the ids, the
 * field or the number that was wrong. Valid until the next call on the instance. */
const char *pgem_last_error(const pgem_t *graph);

/** Work a factorisation hands to several threads: called once for every worker, numbered
 * from 0 to workers - 1, with that worker's number. */
typedef void (*pgem_task_fn)(void *context, uint32_t worker);

/** Runs tasks on threads the caller owns. run(executor, task, context) must call
 * task(context, w) once for every w in 0 .. workers-1, concurrently, and return when all have
 * returned (it may run worker 0 on the calling thread). The core never creates threads: a
 * hosted program uses the thread pool of pgem/threads.h (threads created once, at its
 * creation), firmware passes none and runs on one. */
typedef struct pgem_executor {
    void (*run)(void *executor, pgem_task_fn task, void *context);
    void *executor;    /**< passed to run */
    uint32_t workers;  /**< workers run serves, 1 .. config.threads */
} pgem_executor_t;

/** Lets the instance's factorisations run on executor (copied; NULL: one thread, the caller's).
 * executor->workers may not exceed config.threads (the workers the block holds workspace
 * for). The results are bit-identical for every number of workers. Errors: INVALID_ARGUMENT
 * (no run function, 0 workers or more than config.threads; the executor is left as it was). */
int pgem_set_executor(pgem_t *graph, const pgem_executor_t *executor);

/** Orders the free poses of a graph's factorisation, for an analysis to weigh against its own
 * orderings: the block graph of `blocks` free poses comes as its upper pattern in compressed
 * columns (colptr[blocks + 1]; rows[colptr[blocks]], each column's rows sorted, below its
 * column, no diagonal, no duplicates), and order(orderer, ...) writes order[k] = the free pose
 * eliminated k-th (a permutation of 0 .. blocks-1), returning 0, or nonzero if it could not
 * (the analysis then keeps its own). It may allocate and take its time: it runs in the
 * analysis, on the caller's thread. A hosted program plugs in METIS this way (pgem/metis.h);
 * the core never links an ordering library. */
typedef struct pgem_orderer {
    int (*order)(void *orderer, int blocks, const int *colptr, const int *rows, int *order);
    void *orderer; /**< passed to order */
} pgem_orderer_t;

/** Which ordering an analysis uses: AUTO measures AMD, and on large graphs (at least 2000 free
 * poses and 1e9 flops under AMD, where the others can pay for themselves) nested dissection
 * and the orderer, keeping the one whose factor needs the fewest flops; AMD, NESTED and
 * ORDERER use that one alone (NESTED and ORDERER fall back to AMD when it cannot order). */
typedef enum pgem_order_choice {
    PGEM_ORDER_AUTO = 0,
    PGEM_ORDER_AMD = 1,
    PGEM_ORDER_NESTED = 2,
    PGEM_ORDER_ORDERER = 3
} pgem_order_choice_t;

/** Sets how the instance's analyses order (choice) and the orderer they may use (copied;
 * NULL: none); the next analysis orders anew (set it before pgem_copy, which hands over an
 * ordering already made). Errors: INVALID_ARGUMENT (an unknown choice, an orderer without an order function,
 * ORDERER without an orderer; nothing changed). */
int pgem_set_ordering(pgem_t *graph, pgem_order_choice_t choice, const pgem_orderer_t *orderer);

/** Copies the poses (estimates, held flags), edges (with their robust weights and states) of
 * `from` into `to`, an instance of the same dimension with no poses yet and room for them,
 * and hands over from's fill-reducing ordering when from was analysed for the graph it holds,
 * so to's first analysis does not order again (the result is the same as ordering anew). The
 * use: size a block exactly - analyse in an instance of any fill budget (PGEM_ERR_FILL_BUDGET
 * still reports the nonzeros needed in pgem_memory_use), init a block of exactly that
 * budget, copy. Errors: INVALID_ARGUMENT, DIMENSION, CAPACITY (nothing copied). */
int pgem_copy(pgem_t *to, const pgem_t *from);

/** Memory diagnostics of an instance. */
typedef struct pgem_memory_stats {
    size_t block_bytes;        /**< bytes of the block the instance was given */
    size_t used_bytes;         /**< bytes carved from it at init */
    uint32_t factor_nonzeros;  /**< scalar nonzeros of L for the current structure (0 = none) */
    uint32_t factor_budget;    /**< config.fill_budget */
    uint32_t analyses;         /**< symbolic analyses run so far (one per topology change) */
    size_t csparse_pool_bytes; /**< part of used_bytes reserved for CSparse's symbolic routines
                                    (0 when CSparse is the system library and uses the heap) */
    size_t csparse_pool_peak;  /**< most of that part in use at once so far */
} pgem_memory_stats_t;

void pgem_memory_use(const pgem_t *graph, pgem_memory_stats_t *stats);

#ifndef PGEM_NO_FORMER_NAMES
/* The former names of the getters, which lost their get_ prefix (docs/API.md, "Changes to the
 * API"); define PGEM_NO_FORMER_NAMES to check that a program no longer uses them. */
#define pgem_get_config pgem_resolved_config
#define pgem_get_memory_stats pgem_memory_use
#define pgem_get_memory_parts pgem_memory_layout
#endif

#ifdef __cplusplus
}
#endif

#endif /* PGEM_CORE_H */
