/* A graph's poses and edges copied into an empty instance (pgem_copy's graph part). */
#include <string.h>

#include "graph/graph.h"
#include "instance.h"

void pgem_store_copy(pgem_t *to, const pgem_t *from)
{
    const size_t poses = from->store.pose_count, edges = from->store.edge_count;
    const size_t pose_bytes = poses * (size_t)from->pose_size * sizeof(double);
    const size_t info = (size_t)from->tangent * (size_t)from->tangent;
    memcpy(to->store.pose_id, from->store.pose_id, poses * sizeof *to->store.pose_id);
    memcpy(to->store.pose, from->store.pose, pose_bytes);
    memcpy(to->store.pose_fixed, from->store.pose_fixed, poses);
    for (uint32_t p = 0; p < from->store.pose_count; p++) {
        pgem_map_insert(to, from->store.pose_id[p], p);
    }
    to->store.pose_count = from->store.pose_count;
    to->store.fixed_count = from->store.fixed_count;
    memcpy(to->store.edge_from, from->store.edge_from, edges * sizeof *to->store.edge_from);
    memcpy(to->store.edge_to, from->store.edge_to, edges * sizeof *to->store.edge_to);
    memcpy(to->store.edge_measurement, from->store.edge_measurement,
           edges * (size_t)from->pose_size * sizeof(double));
    memcpy(to->store.edge_information, from->store.edge_information, edges * info * sizeof(double));
    memcpy(to->store.edge_kind, from->store.edge_kind, edges);
    memcpy(to->store.edge_active, from->store.edge_active, edges);
    memcpy(to->store.edge_weight, from->store.edge_weight, edges * sizeof(double));
    to->store.edge_count = from->store.edge_count;
    to->store.topology++;
}
