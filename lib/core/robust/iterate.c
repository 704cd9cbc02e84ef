/* E/M iterations, shared by EM's rounds and the IRLS kernels: an E-step (each loop's weight
 * from its distance, robust/estep.c) and an M-step (a few weighted Gauss-Newton iterations),
 * until the weights settle. */
#include <math.h>
#include <string.h>

#include "robust/robust.h"

/* M-step: a few weighted Gauss-Newton iterations from the current estimate. *settled is set
 * when they changed the weighted chi2 by less than 1e-6 relatively (the estimate is at the
 * weighted optimum, so small weight changes mean EM has converged). */
static int pgem_m_step(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                       const pgem_solve_options_t *solve, pgem_robust_summary_t *summary,
                       int *settled)
{
    pgem_solve_options_t inner;
    pgem_summary_t result;
    memset(&inner, 0, sizeof inner);
    if (solve != NULL) {
        inner = *solve;
    }
    inner.max_iterations = options->m_step_iterations;
    pgem_linear_review(parts->solve.linear, parts->solve.store);
    pgem_robust_hold_parts(parts->solve.linear, parts->solve.store);
    int status = pgem_solver_optimize(&parts->solve, &inner, &result);
    summary->gn_iterations += result.iterations;
    summary->em_iterations++;
    pgem_robust_note_stop(summary, &result);
    *settled = fabs(result.initial_chi2 - result.final_chi2) <= 1e-6 * fmax(result.initial_chi2, 1e-300);
    return status;
}

/* E/M iterations until the M-step has settled and no weight moves more than the tolerance.
 * Every call ends with an E-step at the final estimate; weights_current says the weights
 * already are that E-step's (the previous round's, when pruning left the estimate alone), so
 * the first E-step is skipped. The summary's termination says whether the weights settled
 * (PGEM_ROBUST_CONVERGED) or the iterations ran out (PGEM_ROBUST_ITERATION_LIMIT); the callers
 * that run rounds replace it with their own. */
int pgem_em_iterate(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                    const pgem_solve_options_t *solve, pgem_robust_summary_t *summary,
                    int weights_current, double *largest_change)
{
    int settled = 0, status = PGEM_OK;
    for (uint32_t iteration = 0; iteration < options->max_em_iterations; iteration++) {
        if (iteration > 0u || !weights_current) {
            status = pgem_em_e_step(parts, options, largest_change);
        }
        if (status != PGEM_OK) {
            return status;
        }
        if (settled && *largest_change < options->weight_tolerance) {
            pgem_robust_ended(summary, PGEM_ROBUST_CONVERGED);
            return PGEM_OK;
        }
        status = pgem_m_step(parts, options, solve, summary, &settled);
        if (status != PGEM_OK || pgem_robust_stopped(summary)) {
            return status;
        }
    }
    pgem_robust_ended(summary, PGEM_ROBUST_ITERATION_LIMIT);
    return pgem_em_e_step(parts, options, largest_change);
}

