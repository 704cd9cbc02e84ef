/* Parts that pruning leaves alone: when a robust solve prunes the only edges that joined a
 * part of the graph to a held pose, the part is held at its own gauge (its pose with the
 * smallest id, damped as pgem_hold_gauge damps it) where it stands, and the solve goes on.
 * The part's loops stay in the consistency test, which measures them against the estimate;
 * one that passes joins the part back. */
#include "robust/robust.h"

void pgem_robust_hold_parts(pgem_linear_t *linear, pgem_store_t *store)
{
    /* a part that no edge joins to a held pose, pruned or not, is the caller's graph: nothing
     * is held, and the solve fails on it as pgem_optimize does */
    if (pgem_linear_unheld_parts(linear, store, 1, 0u) == 0u) {
        (void)pgem_linear_unheld_parts(linear, store, 0, (uint8_t)PGEM_POSE_PART_NEW);
    }
}

void pgem_robust_parts_settled(pgem_linear_t *linear, pgem_store_t *store, int succeeded,
                               pgem_robust_summary_t *summary)
{
    if (!succeeded) {
        (void)pgem_pose_release_parts(store, (uint8_t)PGEM_POSE_PART_NEW);
        return;
    }
    (void)pgem_pose_release_parts(store, 0u);
    summary->parts_held = pgem_linear_unheld_parts(linear, store, 0, (uint8_t)PGEM_POSE_PART);
}

uint32_t pgem_robust_list_parts(const pgem_store_t *store, pgem_id_t *ids, uint32_t capacity)
{
    uint32_t held = 0;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (store->pose_fixed[p] != PGEM_POSE_PART) {
            continue;
        }
        if (ids != NULL && held < capacity) {
            ids[held] = store->pose_id[p];
        }
        held++;
    }
    return held;
}
