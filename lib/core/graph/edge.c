/* Adding and reading edges, each input checked before anything changes. */
#include <string.h>

#include "graph/graph.h"
#include "instance.h"

static int pgem_edge_fail_ids(pgem_t *graph, int code, pgem_id_t from, pgem_id_t to)
{
    pgem_message_text(graph, " (edge ");
    pgem_message_u64(graph, from);
    pgem_message_text(graph, " -> ");
    pgem_message_u64(graph, to);
    pgem_message_text(graph, ")");
    return code;
}

static int pgem_edge_check_ends(pgem_t *graph, pgem_id_t from, pgem_id_t to, int64_t *from_index,
                                int64_t *to_index)
{
    *from_index = pgem_map_find(&graph->store, from);
    *to_index = pgem_map_find(&graph->store, to);
    if (*from_index < 0 || *to_index < 0) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "no pose with id ");
        pgem_message_u64(graph, *from_index < 0 ? from : to);
        return pgem_edge_fail_ids(graph, PGEM_ERR_UNKNOWN_ID, from, to);
    }
    if (from == to) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "an edge must join two different poses");
        return pgem_edge_fail_ids(graph, PGEM_ERR_SELF_LOOP, from, to);
    }
    return PGEM_OK;
}

static int pgem_edge_capacity(pgem_t *graph, pgem_id_t from, pgem_id_t to)
{
    pgem_message_clear(graph);
    pgem_message_text(graph, "edge exceeds the edge capacity (max_edges = ");
    pgem_message_u64(graph, graph->config.max_edges);
    pgem_message_text(graph, ")");
    return pgem_edge_fail_ids(graph, PGEM_ERR_CAPACITY, from, to);
}

int pgem_add_edge(pgem_t *graph, pgem_id_t from, pgem_id_t to, const double *measurement,
                  const double *information, pgem_edge_kind_t kind, uint32_t *edge_index)
{
    double checked[PGEM_POSE_SIZE_MAX];
    int64_t from_index, to_index;
    if (graph == NULL || measurement == NULL || information == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (kind != PGEM_EDGE_ODOMETRY && kind != PGEM_EDGE_LOOP) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "edge kind must be odometry or loop");
        return pgem_edge_fail_ids(graph, PGEM_ERR_INVALID_ARGUMENT, from, to);
    }
    if (graph->store.edge_count >= graph->config.max_edges) {
        return pgem_edge_capacity(graph, from, to);
    }
    int status = pgem_edge_check_ends(graph, from, to, &from_index, &to_index);
    if (status == PGEM_OK) {
        status = pgem_check_pose(graph, measurement, checked, "measurement");
    }
    if (status == PGEM_OK) {
        status = pgem_check_information(graph->message, graph->tangent, information);
    }
    if (status != PGEM_OK) {
        return status == PGEM_ERR_UNKNOWN_ID || status == PGEM_ERR_SELF_LOOP
                   ? status
                   : pgem_edge_fail_ids(graph, status, from, to);
    }
    const uint32_t k = graph->store.edge_count;
    const size_t info_size = (size_t)graph->tangent * (size_t)graph->tangent;
    graph->store.edge_from[k] = (uint32_t)from_index;
    graph->store.edge_to[k] = (uint32_t)to_index;
    memcpy(graph->store.edge_measurement + (size_t)k * (size_t)graph->pose_size, checked,
           (size_t)graph->pose_size * sizeof(double));
    memcpy(graph->store.edge_information + (size_t)k * info_size, information, info_size * sizeof(double));
    graph->store.edge_kind[k] = (uint8_t)kind;
    graph->store.edge_active[k] = PGEM_EDGE_ACTIVE;
    graph->store.edge_weight[k] = 1.0;
    graph->store.edge_count++;
    graph->store.topology++;
    pgem_message_clear(graph);
    if (edge_index != NULL) {
        *edge_index = k;
    }
    return PGEM_OK;
}

uint32_t pgem_edge_count(const pgem_t *graph)
{
    return graph != NULL ? graph->store.edge_count : 0u;
}

int pgem_edge_at(const pgem_t *graph, uint32_t index, pgem_edge_view_t *view)
{
    if (graph == NULL || view == NULL || index >= graph->store.edge_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const size_t info_size = (size_t)graph->tangent * (size_t)graph->tangent;
    memset(view, 0, sizeof *view);
    view->from = graph->store.pose_id[graph->store.edge_from[index]];
    view->to = graph->store.pose_id[graph->store.edge_to[index]];
    view->kind = (pgem_edge_kind_t)graph->store.edge_kind[index];
    memcpy(view->measurement, graph->store.edge_measurement + (size_t)index * (size_t)graph->pose_size,
           (size_t)graph->pose_size * sizeof(double));
    memcpy(view->information, graph->store.edge_information + (size_t)index * info_size,
           info_size * sizeof(double));
    view->weight = graph->store.edge_weight[index];
    view->active = graph->store.edge_active[index] != PGEM_EDGE_PRUNED; /* dormant: not pruned */
    return PGEM_OK;
}

/* An edge named by its poses' ids in messages. */
void pgem_message_edge(pgem_t *graph, uint32_t k)
{
    pgem_message_u64(graph, graph->store.pose_id[graph->store.edge_from[k]]);
    pgem_message_text(graph, "-");
    pgem_message_u64(graph, graph->store.pose_id[graph->store.edge_to[k]]);
}
