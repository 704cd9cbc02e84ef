/* Open-addressing map from 64-bit pose id to pose index, sized at init (no growth), and an
 * edge named by its poses' ids in messages. */
#include "graph/graph.h"
#include "instance.h"

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

int64_t pgem_map_find(const pgem_t *graph, pgem_id_t id)
{
    uint32_t slot = pgem_id_hash(id) & graph->store.map_mask;
    while (graph->store.map_slot[slot] != 0u) {
        uint32_t index = graph->store.map_slot[slot] - 1u;
        if (graph->store.pose_id[index] == id) {
            return (int64_t)index;
        }
        slot = (slot + 1u) & graph->store.map_mask;
    }
    return -1;
}

/* The map has at least twice as many slots as poses, so a free slot always exists. */
void pgem_map_insert(pgem_t *graph, pgem_id_t id, uint32_t index)
{
    uint32_t slot = pgem_id_hash(id) & graph->store.map_mask;
    while (graph->store.map_slot[slot] != 0u) {
        slot = (slot + 1u) & graph->store.map_mask;
    }
    graph->store.map_slot[slot] = index + 1u;
}

void pgem_message_edge(pgem_t *graph, uint32_t k)
{
    pgem_message_u64(graph, graph->store.pose_id[graph->store.edge_from[k]]);
    pgem_message_text(graph, "-");
    pgem_message_u64(graph, graph->store.pose_id[graph->store.edge_to[k]]);
}
