/* pgem_optimize: options defaults, symbolic analysis when the topology changed, the chosen
 * method, and restoring the previous estimate when the solve fails. */
#include <math.h>
#include <string.h>

#include "solver/solver.h"

static pgem_solve_options_t pgem_options_resolve(const pgem_solve_options_t *options)
{
    pgem_solve_options_t out;
    memset(&out, 0, sizeof out);
    if (options != NULL) {
        out = *options;
    }
    if (out.max_iterations == 0u) {
        out.max_iterations = 100u;
    }
    if (out.relative_chi2_tolerance == 0.0) {
        out.relative_chi2_tolerance = 1e-9;
    }
    if (out.step_tolerance == 0.0) {
        out.step_tolerance = 1e-10;
    }
    if (out.initial_lambda <= 0.0) {
        out.initial_lambda = 1e-5;
    }
    return out;
}

int pgem_solver_analyze(const pgem_solve_parts_t *parts)
{
    if (parts->store->edge_count == 0u) {
        return pgem_text_fail(parts->message, PGEM_ERR_EMPTY,
                              "the graph has no edges: nothing to optimize");
    }
    return pgem_linear_prepare(parts->linear, parts->store, parts->config, parts->message);
}

int pgem_solver_fill_needed(const pgem_solve_parts_t *parts, uint32_t *nonzeros)
{
    if (parts->store->edge_count == 0u) {
        return pgem_text_fail(parts->message, PGEM_ERR_EMPTY,
                              "the graph has no edges: nothing to optimize");
    }
    return pgem_linear_fill_needed(parts->linear, parts->store, parts->config, parts->message,
                                   nonzeros);
}

int pgem_solver_check_solvable(const pgem_solve_parts_t *parts)
{
    const int tangent = PGEM_TANGENT_SIZE(parts->config->dimension);
    int status = pgem_solver_analyze(parts);
    if (status == PGEM_OK) {
        status = pgem_linear_check_parts(parts->linear, parts->store, parts->message);
    }
    if (status == PGEM_OK && !isfinite(pgem_store_total_chi2(parts->store, tangent))) {
        status = pgem_text_fail(parts->message, PGEM_ERR_NUMERIC,
                                "the chi2 at the current estimate is not finite");
    }
    if (status == PGEM_OK) {
        parts->message[0] = '\0';
    }
    return status;
}

static pgem_termination_t pgem_failure_termination(int status)
{
    switch (status) {
    case PGEM_ERR_FILL_BUDGET:
        return PGEM_TERM_FILL_BUDGET;
    case PGEM_ERR_NOT_POSITIVE_DEFINITE:
        return PGEM_TERM_NOT_POSITIVE_DEFINITE;
    case PGEM_ERR_NUMERIC:
        return PGEM_TERM_NUMERIC;
    default:
        return PGEM_TERM_NONE;
    }
}

/* A solve that moved a pose past the translation limit has diverged (no well-posed graph within
 * the input limits has its optimum 1e8 m away); keeping it would leave the instance holding
 * what it refuses as input, and a written result that does not read back. */
static int pgem_check_solved_poses(const pgem_solve_parts_t *parts)
{
    const pgem_store_t *store = parts->store;
    const size_t pose_size = (size_t)PGEM_POSE_SIZE(parts->config->dimension);
    for (uint32_t p = 0; p < store->pose_count; p++) {
        const double *pose = store->pose + (size_t)p * pose_size;
        for (int k = 0; k < parts->config->dimension; k++) {
            if (!(fabs(pose[k]) <= PGEM_TRANSLATION_LIMIT)) {
                char *message = parts->message;
                message[0] = '\0';
                pgem_text_append(message, PGEM_MESSAGE_SIZE, "the solve diverged: it moved pose ");
                pgem_text_u64(message, PGEM_MESSAGE_SIZE, store->pose_id[p]);
                pgem_text_append(message, PGEM_MESSAGE_SIZE,
                                 " beyond the translation limit (1e8 m, PGEM_TRANSLATION_LIMIT)");
                return PGEM_ERR_NUMERIC;
            }
        }
    }
    return PGEM_OK;
}

static int pgem_run(const pgem_solve_parts_t *parts, const pgem_solve_options_t *options,
                    pgem_summary_t *summary)
{
    const size_t pose_bytes = pgem_solve_pose_bytes(parts);
    double *pose = parts->store->pose, *saved = parts->state->pose_saved;
    int status = pgem_solver_analyze(parts);
    if (status == PGEM_OK) {
        status = pgem_linear_check_parts(parts->linear, parts->store, parts->message);
    }
    summary->factor_nonzeros = pgem_linear_nonzeros(parts->linear);
    if (status != PGEM_OK) {
        summary->termination = pgem_failure_termination(status);
        return status;
    }
    summary->variables = (uint32_t)pgem_linear_unknowns(parts->linear);
    memcpy(saved, pose, pose_bytes);
    /* the factorisations report to options->on_progress */
    pgem_linear_progress(parts->linear, options);
    status = options->method == PGEM_LEVENBERG_MARQUARDT
                 ? pgem_levenberg_marquardt(parts, options, summary)
                 : pgem_gauss_newton(parts, options, summary);
    pgem_linear_progress(parts->linear, NULL);
    if (status == PGEM_OK && (status = pgem_check_solved_poses(parts)) != PGEM_OK) {
        summary->termination = PGEM_TERM_NUMERIC;
    }
    if (status != PGEM_OK) {
        memcpy(pose, saved, pose_bytes);
        if (summary->termination == PGEM_TERM_NONE) {
            summary->termination = pgem_failure_termination(status);
        }
        summary->final_chi2 = summary->initial_chi2;
        return status;
    }
    summary->usable = 1;
    summary->estimate_changed = memcmp(pose, saved, pose_bytes) != 0;
    return PGEM_OK;
}

/* A NaN would slip past every "0 means the default" test below and stop the solve from ever
 * converging (or, as a damping, poison the matrix): refused, naming the option. */
int pgem_check_solve_options(char *message, const pgem_solve_options_t *options)
{
    if (options == NULL) {
        return PGEM_OK;
    }
    if (options->method != PGEM_GAUSS_NEWTON && options->method != PGEM_LEVENBERG_MARQUARDT) {
        return pgem_text_fail(message, PGEM_ERR_INVALID_ARGUMENT, "unknown solver method");
    }
    int status = pgem_text_option(message, options->relative_chi2_tolerance,
                                  "relative_chi2_tolerance");
    if (status == PGEM_OK) {
        status = pgem_text_option(message, options->step_tolerance, "step_tolerance");
    }
    if (status == PGEM_OK) {
        status = pgem_text_option(message, options->initial_lambda, "initial_lambda");
    }
    return status;
}

int pgem_solver_optimize(const pgem_solve_parts_t *parts, const pgem_solve_options_t *options,
                         pgem_summary_t *summary)
{
    pgem_summary_t local;
    int checked = pgem_check_solve_options(parts->message, options);
    parts->store->solves++; /* the estimate changes under pgem_update: it rebuilds */
    if (checked != PGEM_OK) {
        if (summary != NULL) {
            memset(summary, 0, sizeof *summary);
        }
        return checked;
    }
    pgem_solve_options_t resolved = pgem_options_resolve(options);
    pgem_summary_t *out = summary;
    if (out == NULL) {
        out = &local;
    }
    memset(out, 0, sizeof *out);
    int status = pgem_run(parts, &resolved, out);
    if (status == PGEM_OK) {
        parts->message[0] = '\0';
    }
    return status;
}

const char *pgem_termination_name(pgem_termination_t termination)
{
    switch (termination) {
    case PGEM_TERM_NONE: return "none";
    case PGEM_TERM_CHI2_CONVERGED: return "chi2-converged";
    case PGEM_TERM_STEP_CONVERGED: return "step-converged";
    case PGEM_TERM_MAX_ITERATIONS: return "max-iterations";
    case PGEM_TERM_STOPPED: return "stopped";
    case PGEM_TERM_NO_PROGRESS: return "no-progress";
    case PGEM_TERM_NOT_POSITIVE_DEFINITE: return "not-positive-definite";
    case PGEM_TERM_NUMERIC: return "non-finite";
    case PGEM_TERM_FILL_BUDGET: return "fill-budget";
    }
    return "unknown";
}

const char *pgem_method_name(pgem_method_t method)
{
    return method == PGEM_LEVENBERG_MARQUARDT ? "levenberg-marquardt" : "gauss-newton";
}
