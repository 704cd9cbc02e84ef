/* pgem I/O ids: after the last line, checks that every id an edge or FIX names has a pose. */
#include <stdlib.h>
#include <string.h>

#include "io_internal.h"

/* Reports the duplicate seen earliest in the file: the earliest VERTEX line whose id an
 * earlier VERTEX line already had. sorted is ordered by (id, line). */
static int io_report_duplicate(const io_reader_t *reader, const pgem_io_pose_index_t *sorted,
                               size_t count)
{
    size_t i;
    size_t found = 0; /* index of the reported line; 0 = none (index 0 is never a repeat) */
    size_t first;
    for (i = 1; i < count; ++i) {
        if (sorted[i].id == sorted[i - 1].id &&
            (found == 0 || sorted[i].index < sorted[found].index)) {
            found = i;
        }
    }
    if (found == 0) {
        return PGEM_OK;
    }
    first = found;
    while (first > 0 && sorted[first - 1].id == sorted[found].id) {
        first--;
    }
    return io_fail(reader, (unsigned long)sorted[found].index, PGEM_ERR_DUPLICATE_ID,
                   "duplicate VERTEX id %llu (first on line %lu)",
                   (unsigned long long)sorted[found].id, (unsigned long)sorted[first].index);
}

/* Sorted ids of the vertices into *ids (caller frees); duplicate ids are an error. */
static int io_sorted_vertex_ids(const io_reader_t *reader, pgem_id_t **ids)
{
    const pgem_io_graph_t *graph = reader->graph;
    size_t count = graph->pose_count;
    pgem_io_pose_index_t *sorted = (pgem_io_pose_index_t *)malloc(count * sizeof *sorted);
    int status;
    size_t i;
    *ids = (pgem_id_t *)calloc(count, sizeof **ids);
    if (sorted == NULL || *ids == NULL) {
        free(sorted);
        return io_fail(reader, 0, PGEM_ERR_OUT_OF_MEMORY, "out of memory");
    }
    for (i = 0; i < count; ++i) {
        sorted[i].id = graph->poses[i].id;
        sorted[i].index = (size_t)graph->poses[i].line;
    }
    io_sort_keyed_ids(sorted, count);
    status = io_report_duplicate(reader, sorted, count);
    for (i = 0; i < count; ++i) {
        (*ids)[i] = sorted[i].id;
    }
    free(sorted);
    return status;
}

static int io_check_edge_ids(const io_reader_t *reader, const pgem_id_t *ids, size_t count)
{
    pgem_io_graph_t *graph = reader->graph;
    size_t e;
    for (e = 0; e < graph->edge_count; ++e) {
        const pgem_io_edge_t *edge = &graph->edges[e];
        pgem_id_t missing = edge->from;
        if (io_find_id(ids, count, edge->from, NULL)) {
            missing = edge->to;
            if (io_find_id(ids, count, edge->to, NULL)) {
                continue;
            }
        }
        if (reader->foreign_ids) { /* another source's pose: kept, counted */
            if (graph->foreign_edges++ == 0) {
                graph->first_foreign_line = edge->line;
            }
            continue;
        }
        return io_fail(reader, edge->line, PGEM_ERR_UNKNOWN_ID,
                       "edge %llu -> %llu names id %llu, which has no VERTEX line",
                       (unsigned long long)edge->from, (unsigned long long)edge->to,
                       (unsigned long long)missing);
    }
    return PGEM_OK;
}

/* FIX ids must name a pose (with a VERTEX line, or referenced by an edge if there is none);
 * ids are the sorted pose ids. */
static int io_check_fixed_ids(const io_reader_t *reader, const pgem_id_t *ids, size_t count)
{
    const pgem_io_graph_t *graph = reader->graph;
    size_t i;
    for (i = 0; i < graph->fixed_count; ++i) {
        if (!io_find_id(ids, count, graph->fixed[i], NULL)) {
            return io_fail(reader, reader->fixed_lines[i], PGEM_ERR_UNKNOWN_ID,
                           "FIX names id %llu, which has no pose",
                           (unsigned long long)graph->fixed[i]);
        }
    }
    return PGEM_OK;
}

int io_check_ids(io_reader_t *reader)
{
    pgem_io_graph_t *graph = reader->graph;
    pgem_id_t *ids = NULL;
    int status = PGEM_OK;
    if (graph->pose_count > 0) {
        status = io_sorted_vertex_ids(reader, &ids);
        if (status == PGEM_OK) {
            status = io_check_edge_ids(reader, ids, graph->pose_count);
        }
    } else if (graph->edge_count > 0) {
        status = io_chain_poses(reader);
        /* chained poses have unique ids: this only sorts them, for the FIX check */
        if (status == PGEM_OK && graph->fixed_count > 0) {
            status = io_sorted_vertex_ids(reader, &ids);
        }
    }
    if (status == PGEM_OK) {
        status = io_check_fixed_ids(reader, ids, graph->pose_count);
    }
    free(ids);
    return status;
}
