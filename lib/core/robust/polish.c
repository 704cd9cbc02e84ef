/* EM's polish (robust/em.c), also the plain least-squares solve (robust/solve.c) and the end of
 * the rescue (robust/rescue.c): accepted loops at weight 1, held parts held, Gauss-Newton to
 * convergence. */
#include "instance.h"
#include "robust/robust.h"

/* Accepted loops back to weight 1, then Gauss-Newton to convergence. */
int pgem_em_polish(pgem_t *graph, const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    pgem_summary_t result;
    pgem_wake_dormant(graph->linear, &graph->store);
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        graph->store.edge_weight[k] = graph->store.edge_active[k] == PGEM_EDGE_ACTIVE ? 1.0 : graph->store.edge_weight[k];
    }
    pgem_robust_hold_parts(graph->linear, &graph->store);
    int status = pgem_optimize(graph, solve, &result);
    summary->gn_iterations += result.iterations;
    pgem_robust_note_stop(summary, &result);
    return status;
}
