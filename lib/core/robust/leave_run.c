/* EM's leave-run-out test: a run of accepted loops, whose members predict each other so that
 * no test of one loop against the map rejects them, is tested as a whole, by how much the
 * adjustment's chi2 falls when the run leaves it. For a linear problem that fall is the run's
 * joint innovation, r^T (Omega^-1 + J Sigma_-run J^T)^-1 r; above the 99.9% chi-square
 * quantile for the run's rows, the run is inconsistent with the rest of the graph and is
 * pruned at weight 0, which keeps the consistency test from re-admitting its loops one by
 * one. */
#include "robust/robust.h"

/* Runs whose own chi2 is below this share of the quantile are not tested (see below). */
#define PGEM_RUN_SCREEN 0.1

/* The run's own chi2 under the current estimate: a lower bound of its fall. */
static double pgem_run_chi2(const pgem_robust_parts_t *parts, const pgem_loop_run_t *run)
{
    const pgem_store_t *store = parts->solve.store;
    double chi2 = 0.0;
    uint32_t j = run->first;
    for (uint32_t n = 0; n < run->length && j != UINT32_MAX; n++) {
        chi2 += pgem_edge_mahalanobis(store, j, parts->tangent);
        j = pgem_run_next(store, j, run->direction, PGEM_RUN_ACCEPTED);
    }
    return chi2;
}

double pgem_model_minimum(const pgem_robust_parts_t *parts, int *status)
{
    pgem_store_t *store = parts->solve.store;
    pgem_linear_t *linear = parts->solve.linear;
    pgem_robust_hold_parts(linear, store);
    *status = pgem_solver_analyze(&parts->solve);
    double chi2 = 0.0, gain = 0.0;
    if (*status == PGEM_OK) {
        chi2 = pgem_linear_assemble(linear, store);
        pgem_linear_keep_gradient(linear);
        *status = pgem_linear_factor(linear, store, parts->solve.executor, parts->solve.message);
    }
    if (*status == PGEM_OK) {
        *status = pgem_solve_newton(linear, store);
    }
    if (*status == PGEM_OK) {
        gain = pgem_linear_predicted_gain(linear, 0.0);
    }
    return chi2 - gain;
}

/* How much the chi2 falls when the run leaves, from the polished estimate: the chi2 of the
 * rest there, less the decrease the Gauss-Newton model of the rest predicts (exact for a
 * linear problem); the estimate is not moved. *status set if the factor fails. */
static double pgem_run_fall(const pgem_robust_parts_t *parts, const pgem_loop_run_t *run,
                            int *status)
{
    pgem_store_t *store = parts->solve.store;
    const double with = pgem_weighted_chi2(store, parts->tangent);
    /* the run without its contribution */
    pgem_run_set(store, run, PGEM_RUN_ACCEPTED, 0.0, PGEM_RUN_KEEP_STATE);
    const double fall = with - pgem_model_minimum(parts, status);
    pgem_run_set(store, run, PGEM_RUN_ACCEPTED, 1.0, PGEM_RUN_KEEP_STATE);
    return fall;
}

uint32_t pgem_em_leave_run_out(const pgem_robust_parts_t *parts, pgem_robust_summary_t *summary,
                               int *status)
{
    pgem_store_t *store = parts->solve.store;
    *status = PGEM_OK;
    for (uint32_t k = 0; k < store->edge_count && *status == PGEM_OK; k++) {
        for (int direction = 1; direction >= -1 && *status == PGEM_OK; direction -= 2) {
            const pgem_loop_run_t run = {
                k, direction, pgem_run_length(store, k, direction, PGEM_RUN_ACCEPTED)};
            if (run.length < PGEM_RUN_MIN) {
                continue;
            }
            const double quantile = pgem_chi2_quantile((double)run.length * (double)parts->tangent);
            const double own = pgem_run_chi2(parts, &run);
            /* the fall is at least the run's own chi2; a run whose own chi2 is below a tenth of
             * the quantile would need the map to have bent to it ten times over (leverage
             * above 0.9) to fail, and is not tested */
            if (own < PGEM_RUN_SCREEN * quantile) {
                continue;
            }
            if ((own > quantile || pgem_run_fall(parts, &run, status) > quantile) &&
                *status == PGEM_OK) {
                /* one run at a time: the others are tested from the next polish; pruned at
                 * weight 0, which the consistency test reads as left out with its run */
                summary->gated += run.length;
                pgem_run_set(store, &run, PGEM_RUN_ACCEPTED, 0.0, PGEM_EDGE_PRUNED);
                pgem_linear_invalidate(parts->solve.linear);
                return 1;
            }
        }
    }
    return 0;
}
