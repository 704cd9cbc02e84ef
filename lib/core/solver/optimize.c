/* pgem_optimize: options defaults, symbolic analysis when the topology changed, the chosen
 * method, and restoring the previous estimate when the solve fails. */
#include <math.h>
#include <string.h>

#include "instance.h"
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

int pgem_analyze(pgem_t *graph)
{
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (graph->store.edge_count == 0u) {
        return pgem_fail(graph, PGEM_ERR_EMPTY, "the graph has no edges: nothing to optimize");
    }
    return pgem_linear_prepare(graph->linear, &graph->store, &graph->config, graph->message);
}

int pgem_fill_needed(pgem_t *graph, uint32_t *nonzeros)
{
    if (graph == NULL || nonzeros == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (graph->store.edge_count == 0u) {
        return pgem_fail(graph, PGEM_ERR_EMPTY, "the graph has no edges: nothing to optimize");
    }
    return pgem_linear_fill_needed(graph->linear, &graph->store, &graph->config, graph->message,
                                   nonzeros);
}

int pgem_check_solvable(pgem_t *graph)
{
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int status = pgem_analyze(graph);
    if (status == PGEM_OK) {
        status = pgem_linear_check_parts(graph->linear, &graph->store, graph->message);
    }
    if (status == PGEM_OK && !isfinite(pgem_store_total_chi2(&graph->store, graph->tangent))) {
        status = pgem_fail(graph, PGEM_ERR_NUMERIC, "the chi2 at the current estimate is not "
                                                    "finite");
    }
    if (status == PGEM_OK) {
        pgem_message_clear(graph);
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
static int pgem_check_solved_poses(pgem_t *graph)
{
    for (uint32_t p = 0; p < graph->store.pose_count; p++) {
        const double *pose = graph->store.pose + (size_t)p * (size_t)graph->pose_size;
        for (int k = 0; k < graph->config.dimension; k++) {
            if (!(fabs(pose[k]) <= PGEM_TRANSLATION_LIMIT)) {
                pgem_message_clear(graph);
                pgem_message_text(graph, "the solve diverged: it moved pose ");
                pgem_message_u64(graph, graph->store.pose_id[p]);
                pgem_message_text(graph, " beyond the translation limit (1e8 m, "
                                         "PGEM_TRANSLATION_LIMIT)");
                return PGEM_ERR_NUMERIC;
            }
        }
    }
    return PGEM_OK;
}

static int pgem_run(pgem_t *graph, const pgem_solve_options_t *options, pgem_summary_t *summary)
{
    const size_t pose_bytes = pgem_pose_bytes(graph);
    int status = pgem_analyze(graph);
    if (status == PGEM_OK) {
        status = pgem_linear_check_parts(graph->linear, &graph->store, graph->message);
    }
    summary->factor_nonzeros = pgem_linear_nonzeros(graph->linear);
    if (status != PGEM_OK) {
        summary->termination = pgem_failure_termination(status);
        return status;
    }
    summary->variables = (uint32_t)pgem_linear_unknowns(graph->linear);
    memcpy(graph->solver.pose_saved, graph->store.pose, pose_bytes);
    /* the factorisations report to options->on_progress */
    pgem_linear_progress(graph->linear, options);
    status = options->method == PGEM_LEVENBERG_MARQUARDT
                 ? pgem_levenberg_marquardt(graph, options, summary)
                 : pgem_gauss_newton(graph, options, summary);
    pgem_linear_progress(graph->linear, NULL);
    if (status == PGEM_OK && (status = pgem_check_solved_poses(graph)) != PGEM_OK) {
        summary->termination = PGEM_TERM_NUMERIC;
    }
    if (status != PGEM_OK) {
        memcpy(graph->store.pose, graph->solver.pose_saved, pose_bytes);
        if (summary->termination == PGEM_TERM_NONE) {
            summary->termination = pgem_failure_termination(status);
        }
        summary->final_chi2 = summary->initial_chi2;
        return status;
    }
    summary->usable = 1;
    summary->estimate_changed = memcmp(graph->store.pose, graph->solver.pose_saved, pose_bytes) != 0;
    return PGEM_OK;
}

/* A NaN would slip past every "0 means the default" test below and stop the solve from ever
 * converging (or, as a damping, poison the matrix): refused, naming the option. */
int pgem_check_solve_options(pgem_t *graph, const pgem_solve_options_t *options)
{
    if (options == NULL) {
        return PGEM_OK;
    }
    if (options->method != PGEM_GAUSS_NEWTON && options->method != PGEM_LEVENBERG_MARQUARDT) {
        return pgem_fail(graph, PGEM_ERR_INVALID_ARGUMENT, "unknown solver method");
    }
    int status = pgem_check_option(graph, options->relative_chi2_tolerance,
                                   "relative_chi2_tolerance");
    if (status == PGEM_OK) {
        status = pgem_check_option(graph, options->step_tolerance, "step_tolerance");
    }
    if (status == PGEM_OK) {
        status = pgem_check_option(graph, options->initial_lambda, "initial_lambda");
    }
    return status;
}

int pgem_optimize(pgem_t *graph, const pgem_solve_options_t *options, pgem_summary_t *summary)
{
    pgem_summary_t local;
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int checked = pgem_check_solve_options(graph, options);
    graph->store.solves++; /* the estimate changes under pgem_update: it rebuilds */
    if (checked != PGEM_OK) {
        if (summary != NULL) {
            memset(summary, 0, sizeof *summary);
        }
        return checked;
    }
    pgem_solve_options_t resolved = pgem_options_resolve(options);
    pgem_summary_t *out = summary != NULL ? summary : &local;
    memset(out, 0, sizeof *out);
    int status = pgem_run(graph, &resolved, out);
    if (status == PGEM_OK) {
        pgem_message_clear(graph);
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
