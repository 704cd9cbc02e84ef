/* pgem I/O file graph: growing arrays of a pgem_io_graph_t and their release. */
#include <stdlib.h>
#include <string.h>

#include "io_internal.h"

void *io_append(void **array, size_t *count, size_t *capacity, size_t element_size)
{
    char *slot;
    if (*count >= *capacity) {
        size_t new_capacity;
        void *grown;
        new_capacity = *capacity == 0 ? 64 : *capacity * 2;
        if (new_capacity < *capacity || new_capacity > (size_t)-1 / element_size) {
            return NULL;
        }
        grown = realloc(*array, new_capacity * element_size);
        if (grown == NULL) {
            return NULL;
        }
        *array = grown;
        *capacity = new_capacity;
    }
    slot = (char *)*array + *count * element_size;
    memset(slot, 0, element_size);
    ++*count;
    return slot;
}

pgem_io_pose_t *io_graph_new_pose(pgem_io_graph_t *graph)
{
    void *poses = graph->poses;
    void *pose = io_append(&poses, &graph->pose_count, &graph->pose_capacity, sizeof *graph->poses);
    graph->poses = (pgem_io_pose_t *)poses;
    return (pgem_io_pose_t *)pose;
}

pgem_io_edge_t *io_graph_new_edge(pgem_io_graph_t *graph)
{
    void *edges = graph->edges;
    void *edge = io_append(&edges, &graph->edge_count, &graph->edge_capacity, sizeof *graph->edges);
    graph->edges = (pgem_io_edge_t *)edges;
    return (pgem_io_edge_t *)edge;
}

pgem_io_edge_t *io_graph_new_self_loop(pgem_io_graph_t *graph)
{
    void *edges = graph->self_loops;
    void *edge = io_append(&edges, &graph->self_loop_count, &graph->self_loop_capacity,
                           sizeof *graph->self_loops);
    graph->self_loops = (pgem_io_edge_t *)edges;
    return (pgem_io_edge_t *)edge;
}

int io_graph_add_fixed(pgem_io_graph_t *graph, pgem_id_t id)
{
    void *fixed = graph->fixed;
    pgem_id_t *slot = (pgem_id_t *)io_append(&fixed, &graph->fixed_count, &graph->fixed_capacity,
                                             sizeof *graph->fixed);
    graph->fixed = (pgem_id_t *)fixed;
    if (slot == NULL) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    *slot = id;
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
    free(graph->self_loops);
    memset(graph, 0, sizeof *graph);
}
