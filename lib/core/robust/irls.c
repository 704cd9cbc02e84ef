/* IRLS for the kernels that weigh but never prune (Cauchy, Huber, DCS, a user's kernel): E/M
 * iterations (robust/iterate.c) to settled weights, reported as one round. */
#include <string.h>

#include "instance.h"

int pgem_irls(pgem_t *graph, const pgem_robust_options_t *options,
              const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    pgem_robust_progress_t progress;
    memset(&progress, 0, sizeof progress);
    int status = pgem_em_iterate(graph, options, solve, summary, 0, &progress.largest_change);
    if (status != PGEM_OK) {
        return status;
    }
    summary->rounds++;
    if (options->on_round != NULL) {
        progress.round = summary->rounds;
        progress.chi2 = pgem_weighted_chi2(graph);
        pgem_count_loops(graph, summary);
        progress.active_loops = summary->loops - summary->pruned;
        progress.pruned_loops = summary->pruned;
        if (options->on_round(&progress, options->user)) {
            pgem_robust_ended(summary, PGEM_ROBUST_STOPPED);
        }
    }
    return PGEM_OK;
}
