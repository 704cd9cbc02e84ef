/* Robust solves: the EM loop of Lee et al. (E-step weights, weighted Gauss-Newton M-step,
 * pruning rounds) and IRLS for the other kernels. Weights live on the edges, in the block. */
#include <math.h>
#include <string.h>

#include "instance.h"

static pgem_robust_options_t pgem_robust_resolve(const pgem_robust_options_t *options)
{
    pgem_robust_options_t out;
    memset(&out, 0, sizeof out);
    if (options != NULL) {
        out = *options;
    }
    out.scale = out.scale > 0.0 ? out.scale : 1.0;
    out.prune_threshold = out.prune_threshold > 0.0 ? out.prune_threshold : 0.01;
    out.weight_tolerance = out.weight_tolerance > 0.0 ? out.weight_tolerance : 1e-3;
    out.m_step_iterations = out.m_step_iterations > 0u ? out.m_step_iterations : 1u;
    out.max_em_iterations = out.max_em_iterations > 0u ? out.max_em_iterations
                                                       : (out.literal ? 100u : 5u);
    out.max_rounds = out.max_rounds > 0u ? out.max_rounds : 20u;
    out.odometry_inflation = out.odometry_inflation > 0.0 ? out.odometry_inflation : 4.0;
    out.predictable_rotation = out.predictable_rotation > 0.0 ? out.predictable_rotation : 0.1;
    if (out.literal || out.kernel != PGEM_KERNEL_EM) {
        out.distance = PGEM_DISTANCE_POINT; /* the paper, and the IRLS kernels: point chi2 */
    }
    if (out.literal || out.kernel != PGEM_KERNEL_EM || out.dormant_threshold < 0.0) {
        out.dormant_threshold = 0.0; /* no weight is below 0: never dormant */
    } else if (out.dormant_threshold == 0.0) {
        out.dormant_threshold = out.prune_threshold / 100.0;
    }
    return out;
}

/* NaN fails every "> 0" test in pgem_robust_resolve and would silently become the default;
 * Inf would disable the kernel or the gate. Both are refused, naming the option. */
static int pgem_check_robust_options(pgem_t *graph, const pgem_robust_options_t *options)
{
    if (options == NULL) {
        return PGEM_OK;
    }
    if ((unsigned)options->distance > (unsigned)PGEM_DISTANCE_POINT) {
        return pgem_fail(graph, PGEM_ERR_INVALID_ARGUMENT, "unknown loop distance");
    }
    const double values[] = {options->scale, options->prune_threshold, options->weight_tolerance,
                             options->gate, options->dormant_threshold,
                             options->odometry_inflation, options->predictable_rotation};
    const char *const names[] = {"scale", "prune_threshold", "weight_tolerance", "gate",
                                 "dormant_threshold", "odometry_inflation",
                                 "predictable_rotation"};
    for (size_t k = 0; k < sizeof values / sizeof values[0]; k++) {
        int status = pgem_check_option(graph, values[k], names[k]);
        if (status != PGEM_OK) {
            return status;
        }
    }
    return PGEM_OK;
}

void pgem_robust_reset(pgem_t *graph)
{
    if (graph == NULL) {
        return;
    }
    uint32_t returned = 0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        returned += graph->store.edge_active[k] != PGEM_EDGE_ACTIVE;
        graph->store.edge_weight[k] = 1.0;
        graph->store.edge_active[k] = PGEM_EDGE_ACTIVE;
    }
    if (returned > 0u) {
        pgem_linear_invalidate(graph); /* pruned loops were out of H's structure */
    }
}

/* Dormant loops back to active, for a solve at their weights' full Newton matrix (the polish)
 * or for whatever the caller does after the robust solve; the structure is reviewed. */
static void pgem_wake_dormant(pgem_t *graph)
{
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_active[k] == PGEM_EDGE_DORMANT) {
            graph->store.edge_active[k] = PGEM_EDGE_ACTIVE;
        }
    }
    pgem_linear_review(graph);
}

/* Prunes the loops (active or dormant) whose weight fell below the threshold; returns how many.
 * The structure is reviewed before the next M-step. */
static uint32_t pgem_prune(pgem_t *graph, double threshold)
{
    uint32_t pruned = 0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_kind[k] == PGEM_EDGE_LOOP && graph->store.edge_active[k] != PGEM_EDGE_PRUNED &&
            graph->store.edge_weight[k] < threshold) {
            graph->store.edge_active[k] = PGEM_EDGE_PRUNED;
            pruned++;
        }
    }
    return pruned;
}

/* Loop closures in the graph and how many are pruned, into the summary. */
static void pgem_count_loops(const pgem_t *graph, pgem_robust_summary_t *summary)
{
    summary->loops = summary->pruned = 0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_kind[k] == PGEM_EDGE_LOOP) {
            summary->loops++;
            summary->pruned += graph->store.edge_active[k] == PGEM_EDGE_PRUNED;
        }
    }
}

/* M-step: a few weighted Gauss-Newton iterations from the current estimate. *settled is set
 * when they changed the weighted chi2 by less than 1e-6 relatively (the estimate is at the
 * weighted optimum, so small weight changes mean EM has converged). */
static int pgem_m_step(pgem_t *graph, const pgem_robust_options_t *options,
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
    pgem_linear_review(graph);
    int status = pgem_optimize(graph, &inner, &result);
    summary->gn_iterations += result.iterations;
    summary->em_iterations++;
    *settled = fabs(result.initial_chi2 - result.final_chi2) <= 1e-6 * fmax(result.initial_chi2, 1e-300);
    return status;
}

/* E/M iterations until the M-step has settled and no weight moves more than the tolerance.
 * Every call ends with an E-step at the final estimate; weights_current says the weights
 * already are that E-step's (the previous round's, when pruning left the estimate alone), so
 * the first E-step is skipped. */
static int pgem_em_iterate(pgem_t *graph, const pgem_robust_options_t *options,
                           const pgem_solve_options_t *solve, pgem_robust_summary_t *summary,
                           int weights_current, double *largest_change)
{
    int settled = 0;
    for (uint32_t iteration = 0; iteration < options->max_em_iterations; iteration++) {
        if (iteration > 0u || !weights_current) {
            *largest_change = pgem_em_e_step(graph, options);
        }
        if (settled && *largest_change < options->weight_tolerance) {
            return PGEM_OK;
        }
        int status = pgem_m_step(graph, options, solve, summary, &settled);
        if (status != PGEM_OK) {
            return status;
        }
    }
    *largest_change = pgem_em_e_step(graph, options);
    return PGEM_OK;
}

static void pgem_restore_initial(pgem_t *graph)
{
    memcpy(graph->store.pose, graph->robust.pose_initial, pgem_pose_bytes(graph));
}

/* The loops' weights and states before a robust solve, put back if it fails (with the
 * estimate), so a failed call changes nothing the caller can see. */
static void pgem_save_loops(pgem_t *graph)
{
    memcpy(graph->robust.edge_weight_saved, graph->store.edge_weight, graph->store.edge_count * sizeof(double));
    memcpy(graph->robust.edge_active_saved, graph->store.edge_active, graph->store.edge_count);
}

static void pgem_restore_loops(pgem_t *graph)
{
    memcpy(graph->store.edge_weight, graph->robust.edge_weight_saved, graph->store.edge_count * sizeof(double));
    memcpy(graph->store.edge_active, graph->robust.edge_active_saved, graph->store.edge_count);
    pgem_linear_invalidate(graph); /* the structure was built for the states of the failed solve */
}

/* Rounds of E/M iterations, each followed by pruning, until a round prunes nothing. */
static int pgem_em_rounds(pgem_t *graph, const pgem_robust_options_t *options,
                          const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    pgem_robust_progress_t progress;
    memset(&progress, 0, sizeof progress);
    for (uint32_t round = 1; round <= options->max_rounds; round++) {
        int status = pgem_em_iterate(graph, options, solve, summary, round > 1u && !options->restart,
                                     &progress.largest_change);
        if (status != PGEM_OK) {
            return status;
        }
        uint32_t pruned = options->kernel == PGEM_KERNEL_EM ? pgem_prune(graph, options->prune_threshold) : 0u;
        summary->rounds++; /* counted across re-admission passes */
        if (options->on_round != NULL) {
            progress.round = summary->rounds;
            progress.chi2 = pgem_weighted_chi2(graph);
            pgem_count_loops(graph, summary);
            progress.active_loops = summary->loops - summary->pruned;
            progress.pruned_loops = summary->pruned;
            if (options->on_round(&progress, options->user)) {
                return PGEM_OK;
            }
        }
        if (pruned == 0u) {
            return PGEM_OK;
        }
        if (options->restart) {
            pgem_restore_initial(graph);
        }
    }
    return PGEM_OK;
}

/* 99.9% quantiles of the chi-square distribution with 3 and 6 degrees of freedom. */
#define PGEM_CHI2_999_DOF3 16.266
/* The share of rejected loop closures above which the outcome is PGEM_ROBUST_MOST_REJECTED. */
#define PGEM_MOST_REJECTED 0.9
#define PGEM_CHI2_999_DOF6 22.458

static double pgem_gate_value(const pgem_t *graph, const pgem_robust_options_t *options)
{
    if (options->gate > 0.0) {
        return options->gate;
    }
    return graph->tangent == 6 ? PGEM_CHI2_999_DOF6 : PGEM_CHI2_999_DOF3;
}

/* The consistency test under the polished estimate: a pruned loop whose distance passes the
 * gate is re-admitted, an accepted loop that fails it is pruned. Every loop is tested against
 * the same estimate. Returns how many changed state. */
static uint32_t pgem_gate(pgem_t *graph, const pgem_robust_options_t *options, double gate,
                          pgem_robust_summary_t *summary)
{
    uint32_t changed = 0;
    pgem_em_distances(graph, options, 1, gate);
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_kind[k] != PGEM_EDGE_LOOP) {
            continue;
        }
        int consistent = graph->robust.edge_distance[k] < gate;
        if (consistent != (graph->store.edge_active[k] != PGEM_EDGE_PRUNED)) {
            graph->store.edge_active[k] = consistent ? PGEM_EDGE_ACTIVE : PGEM_EDGE_PRUNED;
            summary->readmitted += (uint32_t)consistent;
            summary->gated += (uint32_t)!consistent;
            changed++;
        }
    }
    if (changed > 0u) {
        pgem_linear_invalidate(graph);
    }
    return changed;
}

/* Accepted loops back to weight 1, then Gauss-Newton to convergence. */
static int pgem_polish(pgem_t *graph, const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    pgem_summary_t result;
    pgem_wake_dormant(graph);
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        graph->store.edge_weight[k] = graph->store.edge_active[k] == PGEM_EDGE_ACTIVE ? 1.0 : graph->store.edge_weight[k];
    }
    int status = pgem_optimize(graph, solve, &result);
    summary->gn_iterations += result.iterations;
    return status;
}

/* EM rounds; then, under the polished estimate, the consistency test, and EM again while it
 * changes any loop's state (bounded by max_rounds passes). Ends polished. With the innovation
 * distance, the first rounds are the paper's (point chi2, from wherever the estimate starts);
 * the test and the rounds after it measure loops against the map they produced. */
static int pgem_em_with_gate(pgem_t *graph, const pgem_robust_options_t *options,
                             const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    const double gate = pgem_gate_value(graph, options);
    pgem_robust_options_t first = *options, later = *options;
    first.distance = PGEM_DISTANCE_POINT;
    if (options->distance == PGEM_DISTANCE_INNOVATION) {
        later.dormant_threshold = 0.0; /* the innovations need the factor of the whole matrix */
    }
    int status = pgem_em_rounds(graph, &first, solve, summary);
    for (uint32_t pass = 0; status == PGEM_OK; pass++) {
        status = pgem_polish(graph, solve, summary);
        if (status != PGEM_OK || pass == options->max_rounds ||
            pgem_gate(graph, &later, gate, summary) == 0u) {
            break;
        }
        status = pgem_em_rounds(graph, &later, solve, summary);
    }
    return status;
}

static int pgem_plain(pgem_t *graph, const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    pgem_robust_reset(graph);
    summary->rounds = 1u;
    return pgem_polish(graph, solve, summary);
}

/* A loop closure whose chi2 is not finite (a pose or measurement near the double range) is an
 * outlier before any E-step: pruned at weight 0, so the rest of the graph can be solved. An
 * odometry edge like that fails the solve, naming its poses. */
static int pgem_prune_non_finite(pgem_t *graph, pgem_robust_summary_t *summary)
{
    summary->first_non_finite = UINT32_MAX;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (isfinite(pgem_edge_mahalanobis(graph, k))) {
            continue;
        }
        if (graph->store.edge_kind[k] != PGEM_EDGE_LOOP) {
            pgem_message_clear(graph);
            pgem_message_text(graph, "the chi2 of odometry edge ");
            pgem_message_u64(graph, graph->store.pose_id[graph->store.edge_from[k]]);
            pgem_message_text(graph, "-");
            pgem_message_u64(graph, graph->store.pose_id[graph->store.edge_to[k]]);
            pgem_message_text(graph, " is not finite under the initial estimate");
            return PGEM_ERR_NUMERIC;
        }
        if (summary->non_finite++ == 0u) {
            summary->first_non_finite = k;
        }
        graph->store.edge_weight[k] = 0.0;
        if (graph->store.edge_active[k] != PGEM_EDGE_PRUNED) {
            graph->store.edge_active[k] = PGEM_EDGE_PRUNED;
            pgem_linear_invalidate(graph);
        }
    }
    return PGEM_OK;
}

/* The summary's account of the loops after a successful solve: how many were rejected (pruned,
 * or for the kernels that never prune, weighing less than the prune threshold) and the
 * outcome that says so. */
static void pgem_summarise(pgem_t *graph, const pgem_robust_options_t *options,
                           pgem_robust_summary_t *summary)
{
    pgem_count_loops(graph, summary);
    summary->rejected = 0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        summary->rejected += (uint32_t)(graph->store.edge_kind[k] == PGEM_EDGE_LOOP &&
                                        (graph->store.edge_active[k] == PGEM_EDGE_PRUNED ||
                                         graph->store.edge_weight[k] < options->prune_threshold));
    }
    if (summary->loops == 0u) {
        summary->outcome = PGEM_ROBUST_NO_LOOPS;
    } else if (summary->rejected == summary->loops) {
        summary->outcome = PGEM_ROBUST_ALL_REJECTED;
    } else if ((double)summary->rejected > PGEM_MOST_REJECTED * (double)summary->loops) {
        summary->outcome = PGEM_ROBUST_MOST_REJECTED;
    } else {
        summary->outcome = PGEM_ROBUST_LOOPS_ACCEPTED;
    }
    summary->final_chi2 = pgem_weighted_chi2(graph);
    summary->final_chi2_all = pgem_total_chi2(graph);
    summary->estimate_changed = memcmp(graph->store.pose, graph->robust.pose_initial, pgem_pose_bytes(graph)) != 0;
}

int pgem_robust_optimize(pgem_t *graph, const pgem_robust_options_t *options,
                         const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    pgem_robust_summary_t local = {0};
    pgem_robust_summary_t *out = summary != NULL ? summary : &local;
    memset(out, 0, sizeof *out);
    out->first_non_finite = UINT32_MAX;
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int checked = pgem_check_robust_options(graph, options);
    if (checked == PGEM_OK) {
        checked = pgem_check_solve_options(graph, solve);
    }
    if (checked != PGEM_OK) {
        return checked;
    }
    pgem_robust_options_t resolved = pgem_robust_resolve(options);
    if ((unsigned)resolved.kernel > (unsigned)PGEM_KERNEL_DCS) { /* also catches negative values */
        return pgem_fail(graph, PGEM_ERR_INVALID_ARGUMENT, "unknown robust kernel");
    }
    memcpy(graph->robust.pose_initial, graph->store.pose, pgem_pose_bytes(graph));
    pgem_save_loops(graph);
    out->initial_chi2 = pgem_total_chi2(graph);
    int status = PGEM_OK;
    if (!isfinite(out->initial_chi2)) {
        /* before any E-step: a NaN chi2 would become a NaN weight on the loops */
        status = resolved.kernel == PGEM_KERNEL_NONE ? pgem_fail_numeric(graph, "initial chi2", 0)
                                                     : pgem_prune_non_finite(graph, out);
    }
    if (status == PGEM_OK && resolved.kernel == PGEM_KERNEL_NONE) {
        status = pgem_plain(graph, solve, out);
    } else if (status == PGEM_OK && resolved.kernel == PGEM_KERNEL_EM && !resolved.literal) {
        status = pgem_em_with_gate(graph, &resolved, solve, out);
    } else if (status == PGEM_OK) {
        status = pgem_em_rounds(graph, &resolved, solve, out);
    }
    pgem_wake_dormant(graph); /* none stays dormant after the solve */
    if (status != PGEM_OK) {
        pgem_restore_initial(graph);
        pgem_restore_loops(graph);
        return status;
    }
    pgem_summarise(graph, &resolved, out);
    out->usable = 1;
    pgem_message_clear(graph);
    return PGEM_OK;
}

const char *pgem_robust_outcome_name(pgem_robust_outcome_t outcome)
{
    switch (outcome) {
    case PGEM_ROBUST_LOOPS_ACCEPTED: return "loops_accepted";
    case PGEM_ROBUST_NO_LOOPS: return "no_loops";
    case PGEM_ROBUST_MOST_REJECTED: return "most_rejected";
    case PGEM_ROBUST_ALL_REJECTED: return "all_rejected";
    }
    return "unknown";
}
