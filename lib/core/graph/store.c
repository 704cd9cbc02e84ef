/* The graph layer's part of the block: the pose and edge arrays and the id map's slots. */
#include "graph/graph.h"

/* Slots of the id map: a power of two, at least twice the poses (and 16). */
static uint32_t pgem_map_slots(uint32_t max_poses)
{
    uint32_t slots = 16u;
    while (slots < 2u * max_poses) {
        slots *= 2u;
    }
    return slots;
}

void pgem_store_carve(pgem_store_t *store, const pgem_config_t *config, int pose_doubles,
                      int edge_rows, pgem_arena_t *arena)
{
    const size_t poses = config->max_poses;
    const size_t edges = config->max_edges;
    const size_t pose_size = (size_t)pose_doubles;
    const size_t tangent = (size_t)edge_rows;
    store->pose_id = pgem_arena_take(arena, poses, sizeof(pgem_id_t));
    store->pose = pgem_arena_take(arena, poses * pose_size, sizeof(double));
    store->pose_fixed = pgem_arena_take(arena, poses, 1);
    store->map_mask = pgem_map_slots(config->max_poses) - 1u;
    store->map_slot = pgem_arena_take(arena, (size_t)store->map_mask + 1u, sizeof(uint32_t));
    store->edge_from = pgem_arena_take(arena, edges, sizeof(uint32_t));
    store->edge_to = pgem_arena_take(arena, edges, sizeof(uint32_t));
    store->edge_measurement = pgem_arena_take(arena, edges * pose_size, sizeof(double));
    store->edge_information = pgem_arena_take(arena, edges * tangent * tangent, sizeof(double));
    store->edge_kind = pgem_arena_take(arena, edges, 1);
    store->edge_active = pgem_arena_take(arena, edges, 1);
    store->edge_weight = pgem_arena_take(arena, edges, sizeof(double));
}
