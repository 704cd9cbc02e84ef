/* pgem I/O load: sizes a core config for a file graph and adds the graph to an instance. */
#include <stdarg.h>
#include <stdint.h>
#include <string.h>

#include "io_internal.h"

static uint32_t io_capacity(size_t count)
{
    if (count == 0) {
        return 1;
    }
    return count > UINT32_MAX ? UINT32_MAX : (uint32_t)count;
}

void pgem_io_config(const pgem_io_graph_t *graph, pgem_config_t *config)
{
    if (config == NULL) {
        return;
    }
    memset(config, 0, sizeof *config);
    if (graph == NULL) {
        config->max_poses = 1;
        config->max_edges = 1;
        return;
    }
    config->dimension = graph->dimension;
    config->max_poses = io_capacity(graph->pose_count);
    config->max_edges = io_capacity(graph->edge_count);
    config->fill_budget = 0;
}

static const char *io_source(const pgem_io_graph_t *graph)
{
    return graph->source[0] != '\0' ? graph->source : "(graph)";
}

/* "SOURCE:LINE: text" (no LINE when it is 0) into message; returns code. */
static int io_load_failed(const pgem_io_graph_t *graph, unsigned long line, int code,
                          char *message, size_t message_size, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    io_vmessage_at(message, message_size, io_source(graph), line, format, args);
    va_end(args);
    return code;
}

static int io_load_poses(const pgem_io_graph_t *graph, pgem_t *instance, char *message,
                         size_t message_size)
{
    size_t i;
    for (i = 0; i < graph->pose_count; ++i) {
        const pgem_io_pose_t *pose = &graph->poses[i];
        int status = pgem_add_pose(instance, pose->id, pose->pose);
        if (status != PGEM_OK) { /* the core's message names the pose */
            return io_load_failed(graph, pose->line, status, message, message_size, "%s",
                                  pgem_last_error(instance));
        }
    }
    return PGEM_OK;
}

static int io_load_edges(const pgem_io_graph_t *graph, pgem_t *instance, char *message,
                         size_t message_size)
{
    size_t i;
    for (i = 0; i < graph->edge_count; ++i) {
        const pgem_io_edge_t *edge = &graph->edges[i];
        int status = pgem_add_edge(instance, edge->from, edge->to, edge->measurement,
                                   edge->information, edge->kind, NULL);
        if (status != PGEM_OK) { /* the core's message names the edge */
            return io_load_failed(graph, edge->line, status, message, message_size, "%s",
                                  pgem_last_error(instance));
        }
    }
    return PGEM_OK;
}

static int io_load_fixed(const pgem_io_graph_t *graph, pgem_t *instance, char *message,
                         size_t message_size)
{
    size_t i;
    for (i = 0; i < graph->fixed_count; ++i) {
        int status = pgem_fix_pose(instance, graph->fixed[i], 1);
        if (status != PGEM_OK) {
            return io_load_failed(graph, 0, status, message, message_size, "FIX %llu: %s",
                                  (unsigned long long)graph->fixed[i], pgem_last_error(instance));
        }
    }
    return PGEM_OK;
}

/* The capacities are checked before anything is added, so a graph too large for the
 * instance leaves it as it was (the core would refuse only the first pose or edge past them). */
static int io_load_fits(const pgem_io_graph_t *graph, const pgem_t *instance, char *message,
                        size_t message_size)
{
    const pgem_config_t *config = pgem_resolved_config(instance);
    const size_t free_poses = config->max_poses - pgem_pose_count(instance);
    const size_t free_edges = config->max_edges - pgem_edge_count(instance);
    if (graph->pose_count > free_poses) {
        return io_load_failed(graph, 0, PGEM_ERR_CAPACITY, message, message_size,
                              "%zu poses do not fit: the instance has room for %zu more "
                              "(max_poses = %lu)", graph->pose_count, free_poses,
                              (unsigned long)config->max_poses);
    }
    if (graph->edge_count > free_edges) {
        return io_load_failed(graph, 0, PGEM_ERR_CAPACITY, message, message_size,
                              "%zu edges do not fit: the instance has room for %zu more "
                              "(max_edges = %lu)", graph->edge_count, free_edges,
                              (unsigned long)config->max_edges);
    }
    return PGEM_OK;
}

int pgem_io_load(const pgem_io_graph_t *file, pgem_t *graph, char *message,
                 size_t message_size)
{
    int status;
    io_message(message, message_size, "%s", "");
    if (file == NULL || graph == NULL) {
        io_message(message, message_size, "pgem_io_load: NULL graph or instance");
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (file->dimension != 0 && file->dimension != pgem_dimension(graph)) {
        return io_load_failed(file, 0, PGEM_ERR_DIMENSION, message, message_size,
                              "the graph is %dD but the instance is %dD", file->dimension,
                              pgem_dimension(graph));
    }
    if (file->foreign_edges > 0) { /* checked first: nothing is added */
        return io_load_failed(file, file->first_foreign_line, PGEM_ERR_UNKNOWN_ID, message,
                              message_size, "%zu edge%s name%s an id with no pose in the graph "
                              "(read with foreign ids, for a sender): a graph to load needs "
                              "every pose", file->foreign_edges,
                              file->foreign_edges == 1u ? "" : "s",
                              file->foreign_edges == 1u ? "s" : "");
    }
    status = io_load_fits(file, graph, message, message_size);
    if (status == PGEM_OK) {
        status = io_load_poses(file, graph, message, message_size);
    }
    if (status == PGEM_OK) {
        status = io_load_edges(file, graph, message, message_size);
    }
    if (status == PGEM_OK) {
        status = io_load_fixed(file, graph, message, message_size);
    }
    return status;
}
