/* The holds a robust solve puts on a part that pruning left without a held pose: the part's
 * gauge, damped as pgem_hold_gauge damps it, and released when the solve no longer needs it. */
#include "graph/graph.h"

/* A damping changes the numbers of H, not its structure: the topology stands, while the
 * incremental factor and the covariance calls see a new matrix. */
static void pgem_pose_damping_changed(pgem_store_t *store, uint32_t index)
{
    store->edited_low = index < store->edited_low ? index : store->edited_low;
    store->revision++;
}

void pgem_pose_hold_part(pgem_store_t *store, uint32_t index, uint8_t flag)
{
    if (store->pose_fixed[index] != flag) {
        store->pose_fixed[index] = flag;
        pgem_pose_damping_changed(store, index);
    }
}

uint32_t pgem_pose_release_parts(pgem_store_t *store, uint8_t flag)
{
    uint32_t released = 0;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        const uint8_t held = store->pose_fixed[p];
        if ((held == PGEM_POSE_PART || held == PGEM_POSE_PART_NEW) && (flag == 0u || held == flag)) {
            store->pose_fixed[p] = 0u;
            pgem_pose_damping_changed(store, p);
            released++;
        }
    }
    return released;
}
