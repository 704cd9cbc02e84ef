/* pgem I/O graph: growing arrays of a file graph and their release. */
#include <stdlib.h>
#include <string.h>

#include "io_internal.h"

/* Makes room for one more element in *array (count used of *capacity); 0 or -1. */
static int io_grow(void **array, size_t *capacity, size_t count, size_t element_size)
{
    size_t new_capacity;
    void *grown;
    if (count < *capacity) {
        return 0;
    }
    new_capacity = *capacity == 0 ? 64 : *capacity * 2;
    if (new_capacity < *capacity || new_capacity > (size_t)-1 / element_size) {
        return -1;
    }
    grown = realloc(*array, new_capacity * element_size);
    if (grown == NULL) {
        return -1;
    }
    *array = grown;
    *capacity = new_capacity;
    return 0;
}

pgem_io_pose_t *io_graph_new_pose(pgem_io_graph_t *graph)
{
    void *array = graph->poses;
    pgem_io_pose_t *pose;
    if (io_grow(&array, &graph->pose_capacity, graph->pose_count, sizeof *pose) != 0) {
        return NULL;
    }
    graph->poses = (pgem_io_pose_t *)array;
    pose = &graph->poses[graph->pose_count++];
    memset(pose, 0, sizeof *pose);
    return pose;
}

pgem_io_edge_t *io_graph_new_edge(pgem_io_graph_t *graph)
{
    void *array = graph->edges;
    pgem_io_edge_t *edge;
    if (io_grow(&array, &graph->edge_capacity, graph->edge_count, sizeof *edge) != 0) {
        return NULL;
    }
    graph->edges = (pgem_io_edge_t *)array;
    edge = &graph->edges[graph->edge_count++];
    memset(edge, 0, sizeof *edge);
    return edge;
}

int io_graph_add_fixed(pgem_io_graph_t *graph, pgem_id_t id)
{
    void *array = graph->fixed;
    if (io_grow(&array, &graph->fixed_capacity, graph->fixed_count, sizeof(pgem_id_t)) != 0) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    graph->fixed = (pgem_id_t *)array;
    graph->fixed[graph->fixed_count++] = id;
    return PGEM_OK;
}

void pgem_io_graph_free(pgem_io_graph_t *graph)
{
    if (graph == NULL) {
        return;
    }
    free(graph->poses);
    free(graph->edges);
    free(graph->fixed);
    memset(graph, 0, sizeof *graph);
}
