/* pgem I/O load: sizes a core config for a file graph and adds the graph to an instance. */
#include <stdint.h>
#include <stdio.h>
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

/* "SOURCE:LINE: what: the instance's message" (no LINE when the entry has none). */
static int io_load_failed(const pgem_io_graph_t *graph, unsigned long line, const char *what,
                          const pgem_t *instance, int code, char *message, size_t message_size)
{
    if (line > 0) {
        io_message(message, message_size, "%s:%lu: %s: %s", io_source(graph), line, what,
                   pgem_last_error(instance));
    } else {
        io_message(message, message_size, "%s: %s: %s", io_source(graph), what,
                   pgem_last_error(instance));
    }
    return code;
}

static int io_load_poses(const pgem_io_graph_t *graph, pgem_t *instance, char *message,
                         size_t message_size)
{
    size_t i;
    for (i = 0; i < graph->pose_count; ++i) {
        const pgem_io_pose_t *pose = &graph->poses[i];
        int status = pgem_add_pose(instance, pose->id, pose->pose);
        if (status != PGEM_OK) {
            char what[64];
            snprintf(what, sizeof what, "pose %llu", (unsigned long long)pose->id);
            return io_load_failed(graph, pose->line, what, instance, status, message,
                                  message_size);
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
        if (status != PGEM_OK) {
            char what[96];
            snprintf(what, sizeof what, "edge %llu -> %llu", (unsigned long long)edge->from,
                     (unsigned long long)edge->to);
            return io_load_failed(graph, edge->line, what, instance, status, message,
                                  message_size);
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
            char what[64];
            snprintf(what, sizeof what, "FIX %llu", (unsigned long long)graph->fixed[i]);
            return io_load_failed(graph, 0, what, instance, status, message, message_size);
        }
    }
    return PGEM_OK;
}

int pgem_io_load(const pgem_io_graph_t *graph, pgem_t *instance, char *message,
                 size_t message_size)
{
    int status;
    io_message(message, message_size, "%s", "");
    if (graph == NULL || instance == NULL) {
        io_message(message, message_size, "pgem_io_load: NULL graph or instance");
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (graph->dimension != 0 && graph->dimension != pgem_dimension(instance)) {
        io_message(message, message_size, "%s: the graph is %dD but the instance is %dD",
                   io_source(graph), graph->dimension, pgem_dimension(instance));
        return PGEM_ERR_DIMENSION;
    }
    status = io_load_poses(graph, instance, message, message_size);
    if (status == PGEM_OK) {
        status = io_load_edges(graph, instance, message, message_size);
    }
    if (status == PGEM_OK) {
        status = io_load_fixed(graph, instance, message, message_size);
    }
    return status;
}
