/* Configuration, memory sizing and initialisation of an instance inside one caller block. */
#include <string.h>

#include "instance.h"

/* The first field of a resolved configuration out of range, in words, or NULL. */
static const char *pgem_config_problem(const pgem_config_t *config)
{
    if (config->dimension != 2 && config->dimension != 3) {
        return "config.dimension is not 2 or 3 (0 means 2)";
    }
    if (config->max_poses > PGEM_MAX_POSES_LIMIT) {
        return "config.max_poses is above PGEM_MAX_POSES_LIMIT";
    }
    if (config->max_edges > PGEM_MAX_EDGES_LIMIT) {
        return "config.max_edges is above PGEM_MAX_EDGES_LIMIT";
    }
    if (config->fill_budget > (uint32_t)INT32_MAX) {
        return "config.fill_budget is above INT32_MAX";
    }
    if (config->threads > PGEM_MAX_THREADS) {
        return "config.threads is above PGEM_MAX_THREADS";
    }
    if (config->online_fill > (uint32_t)INT32_MAX) {
        return "config.online_fill is above INT32_MAX";
    }
    return NULL;
}

/* The defaults filled in (each computed, clamped, from max_poses), then the ranges checked. */
static pgem_config_t pgem_config_defaults(const pgem_config_t *config)
{
    pgem_config_t out = *config;
    if (out.dimension == 0) {
        out.dimension = PGEM_DEFAULT_DIMENSION;
    }
    if (out.max_poses == 0) {
        out.max_poses = PGEM_DEFAULT_MAX_POSES;
    }
    if (out.threads == 0) {
        out.threads = 1;
    }
    if (out.max_edges == 0) {
        uint64_t edges = (uint64_t)out.max_poses * PGEM_DEFAULT_EDGES_PER_POSE;
        out.max_edges = edges > PGEM_MAX_EDGES_LIMIT ? PGEM_MAX_EDGES_LIMIT : (uint32_t)edges;
    }
    if (out.fill_budget == 0) {
        uint64_t block = (uint64_t)PGEM_TANGENT_SIZE(out.dimension);
        uint64_t fill = (uint64_t)PGEM_DEFAULT_FILL_PER_POSE * block * block * out.max_poses;
        out.fill_budget = fill > (uint64_t)INT32_MAX ? (uint32_t)INT32_MAX : (uint32_t)fill;
    }
    return out;
}

int pgem_config_resolve(const pgem_config_t *config, pgem_config_t *resolved)
{
    if (config == NULL || resolved == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    pgem_config_t out = pgem_config_defaults(config);
    if (pgem_config_problem(&out) != NULL) {
        return PGEM_ERR_CONFIG;
    }
    *resolved = out;
    return PGEM_OK;
}

/* Carves every layer's part of an instance from the arena (measuring when arena->base is
 * NULL), from the bottom layer up; parts (may be NULL) receives the bytes each took. */
static void pgem_carve(pgem_t *graph, pgem_arena_t *arena, pgem_memory_parts_t *parts)
{
    pgem_memory_parts_t taken;
    /* beside struct pgem, in the instance's part */
    graph->online = pgem_online_carve_state(arena);
    size_t mark = arena->used;
    pgem_store_carve(&graph->store, &graph->config, graph->pose_size, graph->tangent, arena);
    taken.graph = arena->used - mark;
    mark = arena->used;
    pgem_solver_carve(&graph->solver, &graph->config, graph->pose_size, arena);
    taken.solver = arena->used - mark;
    mark = arena->used;
    pgem_robust_carve(&graph->robust, &graph->config, graph->pose_size, arena);
    taken.robust = arena->used - mark;
    mark = arena->used;
    graph->linear = pgem_linear_carve(&graph->config, graph->tangent, arena);
    /* the online arrays count with linalg's, as they did */
    pgem_online_carve(graph->online, &graph->config, graph->tangent, arena);
    taken.linalg = arena->used - mark;
    if (parts != NULL) {
        parts->graph = taken.graph;
        parts->solver = taken.solver;
        parts->robust = taken.robust;
        parts->linalg = taken.linalg;
    }
}

/* Sizes of the instance struct and its arrays for a resolved config (measuring pass), and
 * their parts (parts may be NULL). */
static size_t pgem_measure(const pgem_config_t *resolved, pgem_memory_parts_t *parts)
{
    pgem_t probe;
    memset(&probe, 0, sizeof probe);
    probe.config = *resolved;
    probe.pose_size = PGEM_POSE_SIZE(resolved->dimension);
    probe.tangent = PGEM_TANGENT_SIZE(resolved->dimension);
    pgem_arena_t arena = {NULL, 0, 0, 0, 0, 0};
    (void)pgem_arena_take(&arena, 1, sizeof(pgem_t));
    const size_t instance = arena.used;
    pgem_carve(&probe, &arena, parts);
    if (parts != NULL) {
        parts->instance = instance;
    }
    return arena.used;
}

size_t pgem_memory_size(const pgem_config_t *config)
{
    pgem_config_t resolved;
    if (pgem_config_resolve(config, &resolved) != PGEM_OK) {
        return 0;
    }
    size_t bytes = pgem_measure(&resolved, NULL);
    if (bytes == (size_t)-1) {
        return 0;
    }
    return bytes + 16u; /* room to align an arbitrary buffer start */
}

int pgem_memory_layout(const pgem_config_t *config, pgem_memory_parts_t *parts)
{
    if (config == NULL || parts == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    pgem_config_t resolved;
    const size_t total = pgem_memory_size(config);
    if (total == 0 || pgem_config_resolve(config, &resolved) != PGEM_OK) {
        return PGEM_ERR_CONFIG;
    }
    pgem_memory_parts_t out;
    (void)pgem_measure(&resolved, &out);
    out.instance += total - (out.instance + out.graph + out.solver + out.robust + out.linalg);
    pgem_linear_memory_parts(&resolved, &out);
    out.total = total;
    *parts = out;
    return PGEM_OK;
}

/* The message of a failed init: "what" then "N bytes given, this configuration needs M". */
static int pgem_init_fail(int code, const char *what, size_t given, size_t needed, char *message,
                          size_t message_size)
{
    if (message == NULL || message_size == 0) {
        return code;
    }
    message[0] = '\0';
    pgem_text_append(message, message_size, what);
    if (needed > 0) {
        pgem_text_append(message, message_size, ": ");
        pgem_text_u64(message, message_size, given);
        pgem_text_append(message, message_size, " bytes given, this configuration needs ");
        pgem_text_u64(message, message_size, needed);
        pgem_text_append(message, message_size, " (pgem_memory_size)");
    }
    return code;
}

/* A slice the block could not give (the arena's first failed carve), in the message. */
static int pgem_carve_failed(const pgem_arena_t *arena, size_t given, size_t needed,
                             char *message, size_t message_size)
{
    char what[96] = "the memory block could not hold slice ";
    pgem_text_u64(what, sizeof what, arena->failed);
    pgem_text_append(what, sizeof what, " (");
    pgem_text_u64(what, sizeof what, arena->failed_bytes);
    pgem_text_append(what, sizeof what, " bytes) of the instance");
    return pgem_init_fail(PGEM_ERR_BUFFER_TOO_SMALL, what, given, needed, message, message_size);
}

int pgem_init_message(pgem_t **instance, const pgem_config_t *config, void *buffer, size_t size,
                      char *message, size_t message_size)
{
    if (instance == NULL || config == NULL) {
        return pgem_init_fail(PGEM_ERR_INVALID_ARGUMENT,
                              instance == NULL ? "instance is NULL" : "config is NULL", 0, 0,
                              message, message_size);
    }
    if (buffer == NULL) {
        return pgem_init_fail(PGEM_ERR_INVALID_ARGUMENT, "the memory block is NULL", 0,
                              pgem_memory_size(config), message, message_size);
    }
    const pgem_config_t resolved = pgem_config_defaults(config);
    const char *problem = pgem_config_problem(&resolved);
    size_t needed = problem == NULL ? pgem_memory_size(&resolved) : 0;
    if (needed == 0) {
        return pgem_init_fail(PGEM_ERR_CONFIG,
                              problem != NULL ? problem
                                              : "the capacities need more bytes than this "
                                                "machine can address",
                              0, 0, message, message_size);
    }
    if (size < needed) {
        return pgem_init_fail(PGEM_ERR_BUFFER_TOO_SMALL, "the memory block is too small", size,
                              needed, message, message_size);
    }
    /* Any start address works: the slices are aligned inside the block, and needed includes
     * the 15 bytes the worst start can cost. */
    uintptr_t address = (uintptr_t)buffer;
    size_t skip = (size_t)((16u - (address & 15u)) & 15u);
    pgem_arena_t arena = {(unsigned char *)buffer + skip, size - skip, 0, 0, 0, 0};
    pgem_t *graph = pgem_arena_take(&arena, 1, sizeof(pgem_t));
    if (graph == NULL) { /* cannot happen after the size check, unless a test injects it */
        return pgem_carve_failed(&arena, size, needed, message, message_size);
    }
    memset(graph, 0, sizeof *graph);
    graph->config = resolved;
    graph->pose_size = PGEM_POSE_SIZE(resolved.dimension);
    graph->tangent = PGEM_TANGENT_SIZE(resolved.dimension);
    pgem_carve(graph, &arena, NULL);
    if (arena.failed != 0) {
        return pgem_carve_failed(&arena, size, needed, message, message_size);
    }
    graph->block_bytes = size;
    graph->used_bytes = arena.used + skip;
    memset(graph->store.map_slot, 0, ((size_t)graph->store.map_mask + 1u) * sizeof(uint32_t));
    pgem_linear_start(graph->linear);
    *instance = graph;
    if (message != NULL && message_size > 0) {
        message[0] = '\0';
    }
    return PGEM_OK;
}

int pgem_init(pgem_t **instance, const pgem_config_t *config, void *buffer, size_t size)
{
    return pgem_init_message(instance, config, buffer, size, NULL, 0);
}

int pgem_set_executor(pgem_t *instance, const pgem_executor_t *executor)
{
    if (instance == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (executor == NULL) {
        memset(&instance->executor, 0, sizeof instance->executor);
        return PGEM_OK;
    }
    if (executor->run == NULL || executor->workers == 0u ||
        executor->workers > instance->config.threads) {
        pgem_message_clear(instance);
        pgem_message_text(instance, "an executor needs a run function and 1 .. config.threads (");
        pgem_message_u64(instance, instance->config.threads);
        pgem_message_text(instance, ") workers");
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    instance->executor = *executor;
    return PGEM_OK;
}

int pgem_set_ordering(pgem_t *instance, pgem_order_choice_t choice, const pgem_orderer_t *orderer)
{
    if (instance == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const char *wrong = NULL;
    if (choice != PGEM_ORDER_AUTO && choice != PGEM_ORDER_AMD && choice != PGEM_ORDER_NESTED &&
        choice != PGEM_ORDER_ORDERER) {
        wrong = "unknown ordering choice";
    } else if (orderer != NULL && orderer->order == NULL) {
        wrong = "an orderer needs an order function";
    } else if (choice == PGEM_ORDER_ORDERER && orderer == NULL) {
        wrong = "the ordering choice ORDERER needs an orderer";
    }
    if (wrong != NULL) {
        pgem_message_clear(instance);
        pgem_message_text(instance, wrong);
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    pgem_linear_set_ordering(instance->linear, choice, orderer);
    return PGEM_OK;
}

const pgem_config_t *pgem_resolved_config(const pgem_t *instance)
{
    return instance != NULL ? &instance->config : NULL;
}

const char *pgem_last_error(const pgem_t *instance)
{
    return instance != NULL ? instance->message : "no instance";
}

void pgem_memory_use(const pgem_t *instance, pgem_memory_stats_t *stats)
{
    if (instance == NULL || stats == NULL) {
        return;
    }
    stats->block_bytes = instance->block_bytes;
    stats->used_bytes = instance->used_bytes;
    stats->factor_budget = instance->config.fill_budget;
    pgem_linear_memory_stats(instance->linear, stats);
}
