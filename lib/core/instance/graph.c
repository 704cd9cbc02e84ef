/* The public calls on the graph, over the instance's store: thin wrappers, so the graph layer
 * itself never sees struct pgem (docs/design/core-layers.md). */
#include "instance.h"

int pgem_add_pose(pgem_t *graph, pgem_id_t id, const double *pose)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_add_pose(&graph->store, &graph->config, id, pose,
                                               graph->message);
}

int pgem_fix_pose(pgem_t *graph, pgem_id_t id, int fixed)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_hold(&graph->store, id,
                                           fixed ? (uint8_t)PGEM_POSE_FIXED : 0u,
                                           graph->message);
}

int pgem_hold_gauge(pgem_t *graph, pgem_id_t id, int on)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_hold(&graph->store, id, on ? (uint8_t)PGEM_POSE_GAUGE : 0u,
                                           graph->message);
}

int pgem_pose_index(const pgem_t *graph, pgem_id_t id, uint32_t *index)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_pose_index(&graph->store, id, index);
}

int pgem_pose(const pgem_t *graph, pgem_id_t id, double *pose)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_pose(&graph->store, graph->config.dimension, id, pose);
}

int pgem_set_pose(pgem_t *graph, pgem_id_t id, const double *pose)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_set_pose(&graph->store, graph->config.dimension, id, pose,
                                               graph->message);
}

int pgem_dimension(const pgem_t *graph)
{
    return graph != NULL ? graph->config.dimension : 0;
}

uint32_t pgem_pose_count(const pgem_t *graph)
{
    return graph != NULL ? graph->store.pose_count : 0u;
}

int pgem_pose_at(const pgem_t *graph, uint32_t index, pgem_id_t *id, double *pose, int *fixed)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_pose_at(&graph->store, graph->config.dimension, index, id,
                                              pose, fixed);
}

int pgem_add_edge(pgem_t *graph, pgem_id_t from, pgem_id_t to, const double *measurement,
                  const double *information, pgem_edge_kind_t kind, uint32_t *edge_index)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_add_edge(&graph->store, &graph->config, from, to,
                                               measurement, information, kind, edge_index,
                                               graph->message);
}

uint32_t pgem_edge_count(const pgem_t *graph)
{
    return graph != NULL ? graph->store.edge_count : 0u;
}

int pgem_edge_at(const pgem_t *graph, uint32_t index, pgem_edge_view_t *view)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_edge_at(&graph->store, index, view, graph->tangent);
}

int pgem_edge_chi2(const pgem_t *graph, uint32_t index, double *chi2)
{
    if (graph == NULL || chi2 == NULL || index >= graph->store.edge_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    *chi2 = pgem_edge_mahalanobis(&graph->store, index, graph->tangent);
    return PGEM_OK;
}

double pgem_total_chi2(const pgem_t *graph)
{
    return graph == NULL ? 0.0 : pgem_store_total_chi2(&graph->store, graph->tangent);
}

int pgem_loop_weight(const pgem_t *graph, uint32_t index, double *weight)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_loop_weight(&graph->store, index, weight);
}

int pgem_loop_state(const pgem_t *graph, uint32_t index, pgem_loop_state_t *state)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_loop_state(&graph->store, index, state);
}
