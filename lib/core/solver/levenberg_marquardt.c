/* Levenberg-Marquardt: H + lambda I with Nielsen's damping update; rejected steps are undone
 * from the last accepted estimate and the linear system is reused. */
#include <math.h>
#include <string.h>

#include "solver/solver.h"

#define PGEM_LM_LAMBDA_LIMIT 1e32
#define PGEM_LM_TRIALS 10

/* State of one LM run. */
typedef struct pgem_lm {
    double chi2;     /* weighted chi2 of the last accepted estimate */
    double lambda;   /* current damping */
    double growth;   /* factor for the next rejection (Nielsen's nu) */
} pgem_lm_t;

/* The scale of the first damping: H's largest diagonal entry (1 if H is zero). */
static double pgem_lm_scale(const pgem_solve_parts_t *parts)
{
    const double largest = pgem_linear_largest_diagonal(parts->linear);
    return largest > 0.0 ? largest : 1.0;
}

static void pgem_lm_save(const pgem_solve_parts_t *parts)
{
    memcpy(parts->state->pose_accepted, parts->store->pose, pgem_solve_pose_bytes(parts));
    pgem_linear_keep_gradient(parts->linear);
}

static void pgem_lm_undo(const pgem_solve_parts_t *parts)
{
    memcpy(parts->store->pose, parts->state->pose_accepted, pgem_solve_pose_bytes(parts));
    pgem_linear_restore_gradient(parts->linear);
}

/* One damped trial step: returns 1 if accepted; *step_norm and *status are set. */
static int pgem_lm_trial(const pgem_solve_parts_t *parts, pgem_lm_t *lm, double *step_norm,
                         int *status)
{
    *status = PGEM_OK;
    *step_norm = 0.0;
    pgem_linear_damp(parts->linear, lm->lambda);
    if (pgem_linear_factor(parts->linear, parts->store, parts->executor, parts->message) !=
        PGEM_OK) {
        return 0; /* damping too small to make H positive definite: grow it */
    }
    if (pgem_solve_newton(parts->linear, parts->store) != PGEM_OK) {
        *status = PGEM_ERR_NUMERIC;
        return 0;
    }
    *step_norm = pgem_norm(pgem_linear_step(parts->linear), pgem_linear_unknowns(parts->linear));
    if (!isfinite(*step_norm)) {
        *status = PGEM_ERR_NUMERIC;
        return 0;
    }
    double predicted = pgem_linear_predicted_gain(parts->linear, lm->lambda);
    pgem_apply_step(parts, pgem_linear_step(parts->linear));
    double trial = pgem_weighted_chi2(parts->store, PGEM_TANGENT_SIZE(parts->config->dimension));
    double rho = (lm->chi2 - trial) / predicted;
    if (isfinite(trial) && predicted > 0.0 && rho > 0.0) {
        /* Nielsen's factor, kept in [1/3, 2/3]: an accepted step never grows the damping */
        double shrink = 1.0 - pow(2.0 * rho - 1.0, 3.0);
        shrink = shrink < 2.0 / 3.0 ? shrink : 2.0 / 3.0;
        lm->lambda *= shrink > 1.0 / 3.0 ? shrink : 1.0 / 3.0;
        lm->growth = 2.0;
        return 1;
    }
    pgem_lm_undo(parts);
    return 0;
}

/* Damped trials until one is accepted (at most PGEM_LM_TRIALS, as g2o counts an iteration);
 * returns 1 if a step was accepted, 0 if not, or a negative error. */
static int pgem_lm_iteration(const pgem_solve_parts_t *parts, pgem_lm_t *lm,
                             pgem_summary_t *summary, double *step_norm)
{
    for (int trial = 0; trial < PGEM_LM_TRIALS && lm->lambda <= PGEM_LM_LAMBDA_LIMIT; trial++) {
        int status;
        int accepted = pgem_lm_trial(parts, lm, step_norm, &status);
        summary->factorizations++;
        if (status != PGEM_OK) {
            return status;
        }
        if (accepted) {
            return 1;
        }
        lm->lambda *= lm->growth;
        lm->growth *= 2.0;
    }
    return 0;
}

int pgem_levenberg_marquardt(const pgem_solve_parts_t *parts, const pgem_solve_options_t *options,
                             pgem_summary_t *summary)
{
    pgem_lm_t lm = {pgem_linear_assemble(parts->linear, parts->store), 0.0, 2.0};
    summary->initial_chi2 = summary->final_chi2 = lm.chi2;
    if (!isfinite(lm.chi2)) {
        return pgem_fail_numeric(parts->message, "initial chi2", 0);
    }
    lm.lambda = options->initial_lambda * pgem_lm_scale(parts);
    pgem_lm_save(parts);
    for (uint32_t iteration = 1; iteration <= options->max_iterations; iteration++) {
        double step_norm = 0.0;
        pgem_linear_progress_iteration(parts->linear, iteration);
        int accepted = pgem_lm_iteration(parts, &lm, summary, &step_norm);
        summary->iterations = iteration;
        if (accepted < 0) {
            summary->termination = PGEM_TERM_NUMERIC;
            return pgem_fail_numeric(parts->message, "step", iteration);
        }
        double previous = lm.chi2;
        if (accepted) {
            lm.chi2 = pgem_linear_assemble(parts->linear, parts->store);
            summary->final_chi2 = lm.chi2;
            pgem_lm_save(parts);
        }
        if (pgem_report(options, iteration, lm.chi2, step_norm, lm.lambda, accepted)) {
            summary->termination = PGEM_TERM_STOPPED;
            return PGEM_OK;
        }
        if (!accepted) {
            summary->termination = PGEM_TERM_NO_PROGRESS;
            return PGEM_OK;
        }
        if (pgem_chi2_converged(previous, lm.chi2, options->relative_chi2_tolerance)) {
            summary->termination = PGEM_TERM_CHI2_CONVERGED;
            return PGEM_OK;
        }
        if (options->step_tolerance >= 0.0 && step_norm < options->step_tolerance) {
            summary->termination = PGEM_TERM_STEP_CONVERGED;
            return PGEM_OK;
        }
    }
    summary->termination = PGEM_TERM_MAX_ITERATIONS;
    return PGEM_OK;
}
