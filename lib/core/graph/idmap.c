/* Open-addressing map from 64-bit pose id to pose index, sized at init (no growth). */
#include "graph/graph.h"

static uint32_t pgem_id_hash(pgem_id_t id)
{
    uint64_t mixed = id;
    mixed ^= mixed >> 33;
    mixed *= UINT64_C(0xff51afd7ed558ccd);
    mixed ^= mixed >> 33;
    mixed *= UINT64_C(0xc4ceb9fe1a85ec53);
    mixed ^= mixed >> 33;
    return (uint32_t)mixed;
}

int64_t pgem_map_find(const pgem_store_t *store, pgem_id_t id)
{
    uint32_t slot = pgem_id_hash(id) & store->map_mask;
    while (store->map_slot[slot] != 0u) {
        uint32_t index = store->map_slot[slot] - 1u;
        if (store->pose_id[index] == id) {
            return (int64_t)index;
        }
        slot = (slot + 1u) & store->map_mask;
    }
    return -1;
}

/* The map has at least twice as many slots as poses, so a free slot always exists. */
void pgem_map_insert(pgem_store_t *store, pgem_id_t id, uint32_t index)
{
    uint32_t slot = pgem_id_hash(id) & store->map_mask;
    while (store->map_slot[slot] != 0u) {
        slot = (slot + 1u) & store->map_mask;
    }
    store->map_slot[slot] = index + 1u;
}
