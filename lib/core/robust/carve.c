/* The robust layer's part of the block: what a robust solve puts back if it fails, and each
 * loop's last distance. */
#include "instance.h"
#include "robust/robust.h"

void pgem_robust_carve(pgem_t *graph, pgem_arena_t *arena)
{
    const size_t edges = graph->config.max_edges;
    const size_t doubles = (size_t)graph->config.max_poses * (size_t)graph->pose_size;
    graph->robust.pose_initial = pgem_arena_take(arena, doubles, sizeof(double));
    graph->robust.edge_weight_saved = pgem_arena_take(arena, edges, sizeof(double));
    graph->robust.edge_active_saved = pgem_arena_take(arena, edges, 1);
    graph->robust.edge_distance = pgem_arena_take(arena, edges, sizeof(double));
    graph->robust.edge_checked = pgem_arena_take(arena, edges, 1);
}
