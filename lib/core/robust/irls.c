/* IRLS for the kernels that weigh but never prune (Cauchy, Huber, DCS, a user's kernel): E/M
 * iterations (robust/iterate.c) to settled weights, reported as one round. */
#include <string.h>

#include "robust/robust.h"

int pgem_irls(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
              const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    pgem_robust_progress_t progress;
    memset(&progress, 0, sizeof progress);
    int status = pgem_em_iterate(parts, options, solve, summary, 0, &progress.largest_change);
    if (status != PGEM_OK) {
        return status;
    }
    summary->rounds++;
    (void)pgem_report_round(parts->solve.store, parts->tangent, options, summary, &progress);
    return PGEM_OK;
}
