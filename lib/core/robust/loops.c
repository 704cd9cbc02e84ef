/* The loops' states around a robust solve: reset, dormant ones woken, counted and reported to
 * the round callback, and the estimate, weights and states saved and put back if the solve
 * fails. */
#include <string.h>

#include "robust/robust.h"

void pgem_robust_reset_loops(pgem_linear_t *linear, pgem_store_t *store)
{
    store->revision++; /* the weights change: the covariance calls' factor is old */
    (void)pgem_pose_release_parts(store, 0u); /* every part is joined as the caller made it */
    uint32_t returned = 0, reweighted = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        returned += store->edge_active[k] != PGEM_EDGE_ACTIVE;
        reweighted += store->edge_weight[k] != 1.0;
        store->edge_weight[k] = 1.0;
        store->edge_active[k] = PGEM_EDGE_ACTIVE;
    }
    if (returned > 0u) {
        pgem_linear_invalidate(linear); /* pruned loops were out of H's structure */
    }
    if (returned > 0u || reweighted > 0u) {
        store->solves++; /* the incremental factor holds the old weights: it rebuilds */
    }
}

/* Dormant loops back to active, for a solve at their weights' full Newton matrix (the polish)
 * or for whatever the caller does after the robust solve; the structure is reviewed. */
void pgem_wake_dormant(pgem_linear_t *linear, pgem_store_t *store)
{
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_active[k] == PGEM_EDGE_DORMANT) {
            store->edge_active[k] = PGEM_EDGE_ACTIVE;
        }
    }
    pgem_linear_review(linear, store);
}

/* Loop closures in the graph and how many are pruned, into the summary. */
void pgem_count_loops(const pgem_store_t *store, pgem_robust_summary_t *summary)
{
    summary->loops = summary->pruned = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_kind[k] == PGEM_EDGE_LOOP) {
            summary->loops++;
            summary->pruned += store->edge_active[k] == PGEM_EDGE_PRUNED;
        }
    }
}

void pgem_restore_initial(const pgem_robust_state_t *robust, pgem_store_t *store, int pose_size)
{
    memcpy(store->pose, robust->pose_initial,
           (size_t)store->pose_count * (size_t)pose_size * sizeof(double));
}

/* The loops' weights and states before a robust solve, put back if it fails (with the
 * estimate), so a failed call changes nothing the caller can see. */
void pgem_save_loops(pgem_robust_state_t *robust, const pgem_store_t *store)
{
    memcpy(robust->edge_weight_saved, store->edge_weight, store->edge_count * sizeof(double));
    memcpy(robust->edge_active_saved, store->edge_active, store->edge_count);
}

void pgem_restore_loops(const pgem_robust_state_t *robust, pgem_store_t *store,
                        pgem_linear_t *linear)
{
    memcpy(store->edge_weight, robust->edge_weight_saved, store->edge_count * sizeof(double));
    memcpy(store->edge_active, robust->edge_active_saved, store->edge_count);
    /* the structure was built for the states of the failed solve */
    pgem_linear_invalidate(linear);
}


int pgem_report_round(const pgem_store_t *store, int tangent, const pgem_robust_options_t *options,
                      pgem_robust_summary_t *summary, pgem_robust_progress_t *progress)
{
    if (options->on_round == NULL) {
        return 0;
    }
    progress->round = summary->rounds;
    progress->chi2 = pgem_weighted_chi2(store, tangent);
    pgem_count_loops(store, summary);
    progress->active_loops = summary->loops - summary->pruned;
    progress->pruned_loops = summary->pruned;
    if (options->on_round(progress, options->user)) {
        pgem_robust_ended(summary, PGEM_ROBUST_STOPPED);
        return 1;
    }
    return 0;
}
