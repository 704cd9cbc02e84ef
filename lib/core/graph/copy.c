/* A graph's poses and edges copied into an empty instance (pgem_copy's graph part). */
#include <string.h>

#include "graph/graph.h"

void pgem_store_copy(pgem_store_t *to, const pgem_store_t *from, int pose_size, int tangent)
{
    const size_t poses = from->pose_count, edges = from->edge_count;
    const size_t pose_bytes = poses * (size_t)pose_size * sizeof(double);
    const size_t info = (size_t)tangent * (size_t)tangent;
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
           edges * (size_t)pose_size * sizeof(double));
    memcpy(to->edge_information, from->edge_information, edges * info * sizeof(double));
    memcpy(to->edge_kind, from->edge_kind, edges);
    memcpy(to->edge_active, from->edge_active, edges);
    memcpy(to->edge_weight, from->edge_weight, edges * sizeof(double));
    to->edge_count = from->edge_count;
    to->topology++;
}
