/* pgem I/O edge kinds: the first edge between consecutive ids in file order is odometry, later
 * ones are loop closures; the writer puts a pair's odometry first so a round trip keeps both. */
#include <stdlib.h>

#include "io_internal.h"

/* An edge between consecutive ids (a step): the smaller id, and the edge's index in the graph. */
typedef pgem_io_pose_index_t io_step_t;

/* Ids that differ by exactly one, without unsigned wrap-around (2^64 - 1 and 0 do not). */
static int io_ids_consecutive(pgem_id_t from, pgem_id_t to)
{
    return (from > to ? from - to : to - from) == 1u;
}

static int io_consecutive(const pgem_io_edge_t *edge)
{
    return io_ids_consecutive(edge->from, edge->to);
}

pgem_edge_kind_t io_edge_kind(pgem_id_t from, pgem_id_t to)
{
    return io_ids_consecutive(from, to) ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP;
}

/* The edges between consecutive ids, sorted by pair and then graph order; NULL with *count 0
 * when there are none, NULL with *count nonzero when out of memory. */
static io_step_t *io_sorted_steps(const pgem_io_graph_t *graph, size_t *count)
{
    io_step_t *steps;
    size_t i;
    *count = 0;
    for (i = 0; i < graph->edge_count; ++i) {
        *count += (size_t)io_consecutive(&graph->edges[i]);
    }
    if (*count == 0) {
        return NULL;
    }
    steps = (io_step_t *)malloc(*count * sizeof *steps);
    if (steps == NULL) {
        return NULL;
    }
    *count = 0;
    for (i = 0; i < graph->edge_count; ++i) {
        const pgem_io_edge_t *edge = &graph->edges[i];
        if (io_consecutive(edge)) {
            steps[*count].id = edge->from < edge->to ? edge->from : edge->to;
            steps[(*count)++].index = i;
        }
    }
    io_sort_keyed_ids(steps, *count);
    return steps;
}

int io_assign_edge_kinds(pgem_io_graph_t *graph)
{
    size_t count;
    size_t k;
    io_step_t *steps = io_sorted_steps(graph, &count);
    if (steps == NULL) {
        return count == 0 ? PGEM_OK : PGEM_ERR_OUT_OF_MEMORY;
    }
    for (k = 0; k < count; ++k) {
        const int repeat = k > 0 && steps[k].id == steps[k - 1].id;
        graph->edges[steps[k].index].kind = repeat ? PGEM_EDGE_LOOP : PGEM_EDGE_ODOMETRY;
    }
    free(steps);
    return PGEM_OK;
}

/* 1 when a loop closure between consecutive ids comes before an odometry edge of its pair. */
static int io_loop_before_odometry(const pgem_io_graph_t *graph, const io_step_t *steps,
                                   size_t count)
{
    size_t k;
    for (k = 1; k < count; ++k) {
        if (steps[k].id == steps[k - 1].id &&
            graph->edges[steps[k - 1].index].kind == PGEM_EDGE_LOOP &&
            graph->edges[steps[k].index].kind == PGEM_EDGE_ODOMETRY) {
            return 1;
        }
    }
    return 0;
}

/* Within each pair's run of steps, the odometry edges take the run's first places. */
static void io_odometry_first(const pgem_io_graph_t *graph, const io_step_t *steps,
                              size_t count, size_t *order)
{
    size_t first = 0;
    while (first < count) {
        size_t end = first + 1;
        size_t slot = first;
        size_t k;
        int pass;
        while (end < count && steps[end].id == steps[first].id) {
            end++;
        }
        for (pass = 0; pass < 2; ++pass) { /* odometry, then loop closures */
            for (k = first; k < end; ++k) {
                const int odometry = graph->edges[steps[k].index].kind == PGEM_EDGE_ODOMETRY;
                if (odometry == (pass == 0)) {
                    order[steps[slot++].index] = steps[k].index;
                }
            }
        }
        first = end;
    }
}

int io_write_order(const pgem_io_graph_t *graph, size_t **order)
{
    size_t count;
    size_t i;
    int status = PGEM_OK;
    io_step_t *steps = io_sorted_steps(graph, &count);
    *order = NULL;
    if (steps == NULL) {
        return count == 0 ? PGEM_OK : PGEM_ERR_OUT_OF_MEMORY;
    }
    if (io_loop_before_odometry(graph, steps, count)) {
        *order = (size_t *)malloc(graph->edge_count * sizeof **order);
        if (*order == NULL) {
            status = PGEM_ERR_OUT_OF_MEMORY;
        } else {
            for (i = 0; i < graph->edge_count; ++i) {
                (*order)[i] = i;
            }
            io_odometry_first(graph, steps, count, *order);
        }
    }
    free(steps);
    return status;
}
