/* The composition of a pgem instance, private to lib/core: struct pgem holds the instance's
 * own fields (configuration, block, message) and one part per layer, each defined and carved
 * by its layer (common/common.h, graph/graph.h, linalg/linalg.h, solver/solver.h,
 * robust/robust.h, online/online.h). The linear system and the incremental solve's state are
 * pointers to types only linalg/ and online/ see whole. This
 * replaces the former lib/core/internal.h, which exposed every layer's arrays to every other. */
#ifndef PGEM_INSTANCE_H
#define PGEM_INSTANCE_H

#include "common/common.h"
#include "graph/graph.h"
#include "instance/message.h"
#include "linalg/linalg.h"
#include "online/online.h"
#include "robust/robust.h"
#include "solver/solver.h"

struct pgem {
    pgem_config_t config;      /* resolved configuration */
    int pose_size;             /* doubles per pose: 3 or 7 */
    int tangent;               /* error rows per edge: 3 or 6 */
    size_t block_bytes;        /* size of the caller's block */
    size_t used_bytes;         /* bytes carved at init */
    void *hosted_block;        /* block malloc'ed by pgem_create (NULL for pgem_init) */

    pgem_store_t store;        /* graph layer: poses, edges, id map, edge states */
    pgem_solver_state_t solver; /* solver layer: its estimate copies */
    pgem_robust_state_t robust; /* robust layer: what a robust solve keeps */
    pgem_linear_t *linear;     /* linalg layer: the normal equations (opaque here) */
    pgem_executor_t executor;  /* threads of the factorisation (run NULL: the caller's only) */
    pgem_online_t *online;     /* online layer: the incremental solve (opaque here) */
    char message[PGEM_MESSAGE_SIZE]; /* last error message */
};

/* Bytes of the whole estimate (every pose), for copies between the estimate buffers. */
static inline size_t pgem_pose_bytes(const pgem_t *graph)
{
    return (size_t)graph->store.pose_count * (size_t)graph->pose_size * sizeof(double);
}

/* The parts of the instance a solve works on (pgem_solve_parts_t). */
static inline pgem_solve_parts_t pgem_solve_parts(pgem_t *graph)
{
    pgem_solve_parts_t parts;
    parts.store = &graph->store;
    parts.state = &graph->solver;
    parts.linear = graph->linear;
    parts.config = &graph->config;
    parts.executor = &graph->executor;
    parts.message = graph->message;
    return parts;
}

/* The parts of the instance a robust solve works on (pgem_robust_parts_t): a solve's, and
 * the robust state. */
static inline pgem_robust_parts_t pgem_robust_parts(pgem_t *graph)
{
    pgem_robust_parts_t parts;
    parts.solve = pgem_solve_parts(graph);
    parts.state = &graph->robust;
    parts.tangent = graph->tangent;
    return parts;
}

/* The parts of the instance the incremental factor works on (pgem_online_parts_t). */
static inline pgem_online_parts_t pgem_online_parts(pgem_t *graph)
{
    pgem_online_parts_t parts;
    parts.online = graph->online;
    parts.store = &graph->store;
    parts.linear = graph->linear;
    parts.config = &graph->config;
    parts.tangent = graph->tangent;
    parts.pose_size = graph->pose_size;
    parts.message = graph->message;
    return parts;
}

/* The parts the online layer's entries work on (pgem_online_entry_t): the factor's and the
 * robust ones. */
static inline pgem_online_entry_t pgem_online_entry(pgem_t *graph)
{
    pgem_online_entry_t entry;
    entry.factor = pgem_online_parts(graph);
    entry.robust = pgem_robust_parts(graph);
    return entry;
}

#endif /* PGEM_INSTANCE_H */
