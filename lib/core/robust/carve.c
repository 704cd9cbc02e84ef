/* The robust layer's part of the block: what a robust solve puts back if it fails, and each
 * loop's last distance. */
#include "robust/robust.h"

void pgem_robust_carve(pgem_robust_state_t *robust, const pgem_config_t *config, int pose_size,
                       pgem_arena_t *arena)
{
    const size_t edges = config->max_edges;
    const size_t doubles = (size_t)config->max_poses * (size_t)pose_size;
    robust->pose_initial = pgem_arena_take(arena, doubles, sizeof(double));
    robust->edge_weight_saved = pgem_arena_take(arena, edges, sizeof(double));
    robust->edge_active_saved = pgem_arena_take(arena, edges, 1);
    robust->edge_distance = pgem_arena_take(arena, edges, sizeof(double));
    robust->edge_checked = pgem_arena_take(arena, edges, 1);
}
