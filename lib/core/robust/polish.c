/* EM's polish (robust/em.c), also the plain least-squares solve (robust/solve.c) and the end of
 * the rescue (robust/rescue.c): accepted loops at weight 1, held parts held, Gauss-Newton to
 * convergence. */
#include "robust/robust.h"

/* Accepted loops back to weight 1, then Gauss-Newton to convergence. */
int pgem_em_polish(const pgem_robust_parts_t *parts, const pgem_solve_options_t *solve,
                   pgem_robust_summary_t *summary)
{
    pgem_store_t *store = parts->solve.store;
    pgem_summary_t result;
    pgem_wake_dormant(parts->solve.linear, store);
    for (uint32_t k = 0; k < store->edge_count; k++) {
        store->edge_weight[k] =
            store->edge_active[k] == PGEM_EDGE_ACTIVE ? 1.0 : store->edge_weight[k];
    }
    pgem_robust_hold_parts(parts->solve.linear, store);
    int status = pgem_solver_optimize(&parts->solve, solve, &result);
    summary->gn_iterations += result.iterations;
    pgem_robust_note_stop(summary, &result);
    return status;
}
