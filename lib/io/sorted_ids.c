/* pgem I/O sorted ids: ids sorted ascending (alone, or keyed with the index or file line they
 * came from) and found by binary search; ids.c's checks and chain.c's spanning tree use them. */
#include <stdlib.h>

#include "io_internal.h"

static int io_compare_ids(const void *a, const void *b)
{
    pgem_id_t x = *(const pgem_id_t *)a;
    pgem_id_t y = *(const pgem_id_t *)b;
    return (x > y) - (x < y);
}

static int io_compare_keyed_ids(const void *a, const void *b)
{
    const pgem_io_pose_index_t *x = (const pgem_io_pose_index_t *)a;
    const pgem_io_pose_index_t *y = (const pgem_io_pose_index_t *)b;
    if (x->id != y->id) {
        return (x->id > y->id) - (x->id < y->id);
    }
    return (x->index > y->index) - (x->index < y->index);
}

void io_sort_keyed_ids(pgem_io_pose_index_t *items, size_t count)
{
    if (count > 1) {
        qsort(items, count, sizeof *items, io_compare_keyed_ids);
    }
}

void io_sort_ids(pgem_id_t *ids, size_t count)
{
    if (count > 1) {
        qsort(ids, count, sizeof *ids, io_compare_ids);
    }
}

pgem_io_pose_index_t *pgem_io_index_poses(const pgem_io_graph_t *graph)
{
    const size_t count = graph->pose_count;
    pgem_io_pose_index_t *sorted =
        (pgem_io_pose_index_t *)malloc((count > 0 ? count : 1u) * sizeof *sorted);
    size_t i;
    if (sorted == NULL) {
        return NULL;
    }
    for (i = 0; i < count; ++i) {
        sorted[i].id = graph->poses[i].id;
        sorted[i].index = i;
    }
    io_sort_keyed_ids(sorted, count);
    return sorted;
}

/* The first of sorted[0, count) whose id is not below id (count when there is none). */
static size_t io_lower_bound(const pgem_io_pose_index_t *sorted, size_t count, pgem_id_t id)
{
    size_t low = 0;
    size_t high = count;
    while (low < high) {
        size_t middle = low + (high - low) / 2;
        if (sorted[middle].id < id) {
            low = middle + 1;
        } else {
            high = middle;
        }
    }
    return low;
}

size_t pgem_io_find_pose(const pgem_io_pose_index_t *sorted, size_t count, pgem_id_t id)
{
    const size_t at = io_lower_bound(sorted, count, id);
    return at < count && sorted[at].id == id ? sorted[at].index : PGEM_IO_NO_POSE;
}

int io_find_id(const pgem_id_t *sorted, size_t count, pgem_id_t id, size_t *index)
{
    size_t low = 0;
    size_t high = count;
    while (low < high) {
        size_t middle = low + (high - low) / 2;
        if (sorted[middle] < id) {
            low = middle + 1;
        } else {
            high = middle;
        }
    }
    if (low < count && sorted[low] == id) {
        if (index != NULL) {
            *index = low;
        }
        return 1;
    }
    return 0;
}
