/* Gauss-Newton: linearise, factor, solve, step; stops on chi2 decrease, step norm or count. */
#include <math.h>

#include "instance.h"
#include "solver/solver.h"

int pgem_gauss_newton(pgem_t *graph, const pgem_solve_options_t *options, pgem_summary_t *summary)
{
    double chi2 = pgem_linear_assemble(graph->linear, &graph->store);
    summary->initial_chi2 = chi2;
    summary->final_chi2 = chi2;
    if (!isfinite(chi2)) {
        return pgem_fail_numeric(graph, "initial chi2", 0);
    }
    for (uint32_t iteration = 1; iteration <= options->max_iterations; iteration++) {
        pgem_linear_progress_iteration(graph->linear, iteration);
        int status =
            pgem_linear_factor(graph->linear, &graph->store, &graph->executor, graph->message);
        summary->factorizations++;
        summary->iterations = iteration;
        if (status != PGEM_OK) {
            summary->termination = PGEM_TERM_NOT_POSITIVE_DEFINITE;
            return status;
        }
        status = pgem_solve_newton(graph->linear, &graph->store);
        if (status != PGEM_OK) {
            summary->termination = PGEM_TERM_NUMERIC;
            return pgem_fail_numeric(graph, "step (conjugate gradients)", iteration);
        }
        double step_norm =
            pgem_norm(pgem_linear_step(graph->linear), pgem_linear_unknowns(graph->linear));
        if (!isfinite(step_norm)) {
            summary->termination = PGEM_TERM_NUMERIC;
            return pgem_fail_numeric(graph, "step", iteration);
        }
        pgem_apply_step(graph, pgem_linear_step(graph->linear));
        /* the system is re-assembled only if another iteration will use it; after the last
         * one (every M-step of EM, with one iteration) the chi2 alone is enough */
        double next = iteration < options->max_iterations
                          ? pgem_linear_assemble(graph->linear, &graph->store)
                          : pgem_weighted_chi2(&graph->store, graph->tangent);
        if (!isfinite(next)) {
            summary->termination = PGEM_TERM_NUMERIC;
            return pgem_fail_numeric(graph, "chi2", iteration);
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
