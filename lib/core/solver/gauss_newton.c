/* Gauss-Newton: linearise, factor, solve, step; stops on chi2 decrease, step norm or count. */
#include <math.h>

#include "solver/solver.h"

int pgem_gauss_newton(const pgem_solve_parts_t *parts, const pgem_solve_options_t *options,
                      pgem_summary_t *summary)
{
    const int tangent = PGEM_TANGENT_SIZE(parts->config->dimension);
    double chi2 = pgem_linear_assemble(parts->linear, parts->store);
    summary->initial_chi2 = chi2;
    summary->final_chi2 = chi2;
    if (!isfinite(chi2)) {
        return pgem_fail_numeric(parts->message, "initial chi2", 0);
    }
    for (uint32_t iteration = 1; iteration <= options->max_iterations; iteration++) {
        pgem_linear_progress_iteration(parts->linear, iteration);
        int status =
            pgem_linear_factor(parts->linear, parts->store, parts->executor, parts->message);
        summary->factorizations++;
        summary->iterations = iteration;
        if (status != PGEM_OK) {
            summary->termination = PGEM_TERM_NOT_POSITIVE_DEFINITE;
            return status;
        }
        status = pgem_solve_newton(parts->linear, parts->store);
        if (status != PGEM_OK) {
            summary->termination = PGEM_TERM_NUMERIC;
            return pgem_fail_numeric(parts->message, "step (conjugate gradients)", iteration);
        }
        double step_norm =
            pgem_norm(pgem_linear_step(parts->linear), pgem_linear_unknowns(parts->linear));
        if (!isfinite(step_norm)) {
            summary->termination = PGEM_TERM_NUMERIC;
            return pgem_fail_numeric(parts->message, "step", iteration);
        }
        pgem_apply_step(parts, pgem_linear_step(parts->linear));
        /* the system is re-assembled only if another iteration will use it; after the last
         * one (every M-step of EM, with one iteration) the chi2 alone is enough */
        double next = iteration < options->max_iterations
                          ? pgem_linear_assemble(parts->linear, parts->store)
                          : pgem_weighted_chi2(parts->store, tangent);
        if (!isfinite(next)) {
            summary->termination = PGEM_TERM_NUMERIC;
            return pgem_fail_numeric(parts->message, "chi2", iteration);
        }
        summary->final_chi2 = next;
        if (pgem_report(options, iteration, next, step_norm, 0.0, 1)) {
            summary->termination = PGEM_TERM_STOPPED;
            return PGEM_OK;
        }
        if (options->step_tolerance >= 0.0 && step_norm < options->step_tolerance) {
            summary->termination = PGEM_TERM_STEP_CONVERGED;
            return PGEM_OK;
        }
        if (pgem_chi2_converged(chi2, next, options->relative_chi2_tolerance)) {
            summary->termination = PGEM_TERM_CHI2_CONVERGED;
            return PGEM_OK;
        }
        chi2 = next;
    }
    summary->termination = PGEM_TERM_MAX_ITERATIONS;
    return PGEM_OK;
}
