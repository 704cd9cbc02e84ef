/* pgem_io_from_instance: the poses, edges and fixed poses of an instance into a file graph. */
#include <string.h>

#include "io_internal.h"

static int io_copy_poses(const pgem_t *instance, pgem_io_graph_t *graph)
{
    uint32_t count = pgem_pose_count(instance);
    uint32_t i;
    for (i = 0; i < count; ++i) {
        pgem_io_pose_t *pose = io_graph_new_pose(graph);
        int fixed = 0;
        int status;
        if (pose == NULL) {
            return PGEM_ERR_OUT_OF_MEMORY;
        }
        status = pgem_pose_at(instance, i, &pose->id, pose->pose, &fixed);
        if (status != PGEM_OK) {
            return status;
        }
        if (fixed && io_graph_add_fixed(graph, pose->id) != PGEM_OK) {
            return PGEM_ERR_OUT_OF_MEMORY;
        }
    }
    return PGEM_OK;
}

static int io_copy_edges(const pgem_t *instance, pgem_io_graph_t *graph)
{
    uint32_t count = pgem_edge_count(instance);
    uint32_t i;
    for (i = 0; i < count; ++i) {
        pgem_edge_view_t view;
        pgem_io_edge_t *edge;
        int status = pgem_edge_at(instance, i, &view);
        if (status != PGEM_OK) {
            return status;
        }
        edge = io_graph_new_edge(graph);
        if (edge == NULL) {
            return PGEM_ERR_OUT_OF_MEMORY;
        }
        edge->from = view.from;
        edge->to = view.to;
        edge->kind = view.kind;
        memcpy(edge->measurement, view.measurement, sizeof edge->measurement);
        memcpy(edge->information, view.information, sizeof edge->information);
    }
    return PGEM_OK;
}

int pgem_io_from_instance(const pgem_t *graph, pgem_io_graph_t *file)
{
    int status;
    if (file == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    memset(file, 0, sizeof *file);
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    file->dimension = pgem_dimension(graph);
    status = io_copy_poses(graph, file);
    if (status == PGEM_OK) {
        status = io_copy_edges(graph, file);
    }
    if (status != PGEM_OK) {
        pgem_io_graph_free(file);
    }
    return status;
}
