/* pgem_copy: one instance's graph into another (empty) one, with the fill-reducing ordering
 * when it is still the current graph's, so a host can size a block exactly (analyse with any
 * fill budget, read the factor's nonzeros, copy into a block of exactly that budget) without
 * loading or ordering twice. */
#include <string.h>

#include "internal.h"

static int pgem_copy_refused(pgem_t *to, int code, const char *text)
{
    return pgem_fail(to, code, text);
}

int pgem_copy(pgem_t *to, const pgem_t *from)
{
    if (to == NULL || from == NULL || to == from) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (to->config.dimension != from->config.dimension) {
        return pgem_copy_refused(to, PGEM_ERR_DIMENSION, "pgem_copy: the instances' dimensions differ");
    }
    if (to->pose_count != 0u) {
        return pgem_copy_refused(to, PGEM_ERR_INVALID_ARGUMENT, "pgem_copy: the target holds poses already");
    }
    if (from->pose_count > to->config.max_poses || from->edge_count > to->config.max_edges) {
        return pgem_copy_refused(to, PGEM_ERR_CAPACITY,
                                 "pgem_copy: the target has room for fewer poses or edges");
    }
    const size_t poses = from->pose_count, edges = from->edge_count;
    const size_t pose_bytes = poses * (size_t)from->pose_size * sizeof(double);
    const size_t info = (size_t)from->tangent * (size_t)from->tangent;
    memcpy(to->pose_id, from->pose_id, poses * sizeof *to->pose_id);
    memcpy(to->pose, from->pose, pose_bytes);
    memcpy(to->pose_fixed, from->pose_fixed, poses);
    for (uint32_t p = 0; p < from->pose_count; p++) {
        pgem_map_insert(to, from->pose_id[p], p);
    }
    to->pose_count = from->pose_count;
    to->fixed_count = from->fixed_count;
    memcpy(to->edge_from, from->edge_from, edges * sizeof *to->edge_from);
    memcpy(to->edge_to, from->edge_to, edges * sizeof *to->edge_to);
    memcpy(to->edge_measurement, from->edge_measurement,
           edges * (size_t)from->pose_size * sizeof(double));
    memcpy(to->edge_information, from->edge_information, edges * info * sizeof(double));
    memcpy(to->edge_kind, from->edge_kind, edges);
    memcpy(to->edge_active, from->edge_active, edges);
    memcpy(to->edge_weight, from->edge_weight, edges * sizeof(double));
    to->edge_count = from->edge_count;
    pgem_linear_invalidate(to);
    if (from->linear.ordered && !from->linear.all_edges) {
        /* the ordering of this very graph: the analysis reuses it (not the every-edge
         * fallback's, which a larger budget might not need) */
        memcpy(to->linear.pose_block, from->linear.pose_block, poses * sizeof(int));
        to->linear.ordered = 1;
    }
    pgem_message_clear(to);
    return PGEM_OK;
}
