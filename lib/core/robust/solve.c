/* A robust solve: options checked, loops whose chi2 is not finite pruned, the method run (EM,
 * IRLS, or plain least squares), a failure undone, and the summary's account of the loops. */
#include <math.h>
#include <string.h>

#include "robust/robust.h"

/* Bytes of the whole estimate (every pose), for the copy a solve starts from. */
static size_t pgem_estimate_bytes(const pgem_robust_parts_t *parts)
{
    return (size_t)parts->solve.store->pose_count *
           (size_t)PGEM_POSE_SIZE(parts->solve.config->dimension) * sizeof(double);
}

static int pgem_plain(const pgem_robust_parts_t *parts, const pgem_solve_options_t *solve,
                      pgem_robust_summary_t *summary)
{
    pgem_robust_reset_loops(parts->solve.linear, parts->solve.store);
    summary->rounds = 1u;
    return pgem_em_polish(parts, solve, summary);
}

/* A loop closure whose chi2 is not finite (a pose or measurement near the double range) is an
 * outlier before any E-step: pruned at weight 0, so the rest of the graph can be solved. An
 * odometry edge like that fails the solve, naming its poses. */
static int pgem_prune_non_finite(const pgem_robust_parts_t *parts, pgem_robust_summary_t *summary)
{
    pgem_store_t *store = parts->solve.store;
    char *message = parts->solve.message;
    summary->first_non_finite = UINT32_MAX;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (isfinite(pgem_edge_mahalanobis(store, k, parts->tangent))) {
            continue;
        }
        if (store->edge_kind[k] != PGEM_EDGE_LOOP) {
            message[0] = '\0';
            pgem_text_append(message, PGEM_MESSAGE_SIZE, "the chi2 of odometry edge ");
            pgem_store_edge_name(store, k, message);
            pgem_text_append(message, PGEM_MESSAGE_SIZE,
                             " is not finite under the initial estimate");
            return PGEM_ERR_NUMERIC;
        }
        if (summary->non_finite++ == 0u) {
            summary->first_non_finite = k;
        }
        store->edge_weight[k] = 0.0;
        if (store->edge_active[k] != PGEM_EDGE_PRUNED) {
            store->edge_active[k] = PGEM_EDGE_PRUNED;
            pgem_linear_invalidate(parts->solve.linear);
        }
    }
    return PGEM_OK;
}

pgem_robust_outcome_t pgem_loops_outcome(uint32_t rejected, uint32_t loops)
{
    if (loops == 0u) {
        return PGEM_ROBUST_NO_LOOPS;
    }
    if (rejected == loops) {
        return PGEM_ROBUST_ALL_REJECTED;
    }
    return pgem_share_most_rejected(rejected, loops) ? PGEM_ROBUST_MOST_REJECTED
                                                     : PGEM_ROBUST_LOOPS_ACCEPTED;
}

/* The summary's account of the loops after a successful solve: how many were rejected (pruned,
 * or for the kernels that never prune, weighing less than the prune threshold) and the
 * outcome that says so. */
static void pgem_summarise(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                           pgem_robust_summary_t *summary)
{
    const pgem_store_t *store = parts->solve.store;
    pgem_count_loops(store, summary);
    summary->rejected = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        summary->rejected += (uint32_t)(store->edge_kind[k] == PGEM_EDGE_LOOP &&
                                        (store->edge_active[k] == PGEM_EDGE_PRUNED ||
                                         store->edge_weight[k] < options->prune_threshold));
    }
    summary->outcome = pgem_loops_outcome(summary->rejected, summary->loops);
    summary->final_chi2 = pgem_weighted_chi2(store, parts->tangent);
    summary->final_chi2_all = pgem_store_total_chi2(store, parts->tangent);
    summary->estimate_changed =
        memcmp(store->pose, parts->state->pose_initial, pgem_estimate_bytes(parts)) != 0;
}

int pgem_robust_solve(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                      const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    pgem_store_t *store = parts->solve.store;
    pgem_linear_t *linear = parts->solve.linear;
    char *message = parts->solve.message;
    pgem_robust_summary_t local = {0};
    pgem_robust_summary_t *out = summary != NULL ? summary : &local;
    memset(out, 0, sizeof *out);
    out->first_non_finite = UINT32_MAX;
    int checked = pgem_check_robust_options(options, message);
    if (checked == PGEM_OK) {
        checked = pgem_check_solve_options(message, solve);
    }
    if (checked != PGEM_OK) {
        return checked;
    }
    pgem_robust_options_t resolved = pgem_robust_resolve(options);
    memcpy(parts->state->pose_initial, store->pose, pgem_estimate_bytes(parts));
    pgem_save_loops(parts->state, store);
    out->initial_chi2 = pgem_weighted_chi2(store, parts->tangent);
    int status = PGEM_OK;
    if (!isfinite(pgem_store_total_chi2(store, parts->tangent))) {
        /* before any E-step: a NaN chi2 would become a NaN weight on the loops */
        status = resolved.kernel == PGEM_KERNEL_NONE
                     ? pgem_fail_numeric(message, "initial chi2", 0)
                     : pgem_prune_non_finite(parts, out);
    }
    if (status == PGEM_OK && resolved.kernel == PGEM_KERNEL_EM && resolved.frames >= 0) {
        out->frames_placed = pgem_robust_frames(parts, &resolved, 0);
    }
    if (status == PGEM_OK && resolved.kernel == PGEM_KERNEL_NONE) {
        status = pgem_plain(parts, solve, out);
    } else if (status == PGEM_OK && resolved.kernel == PGEM_KERNEL_EM && !resolved.literal) {
        status = pgem_em_with_gate(parts, &resolved, solve, out);
    } else if (status == PGEM_OK && resolved.kernel == PGEM_KERNEL_EM) {
        status = pgem_em_rounds(parts, &resolved, solve, out);
    } else if (status == PGEM_OK) {
        status = pgem_irls(parts, &resolved, solve, out);
    }
    pgem_wake_dormant(linear, store); /* none stays dormant after the solve */
    pgem_robust_parts_settled(linear, store, status == PGEM_OK, out);
    if (status != PGEM_OK) {
        pgem_restore_initial(parts->state, store, PGEM_POSE_SIZE(parts->solve.config->dimension));
        pgem_restore_loops(parts->state, store, linear);
        out->termination = PGEM_ROBUST_FAILED;
        return status;
    }
    pgem_summarise(parts, &resolved, out);
    out->usable = 1;
    message[0] = '\0';
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

const char *pgem_robust_termination_name(pgem_robust_termination_t termination)
{
    switch (termination) {
    case PGEM_ROBUST_CONVERGED: return "converged";
    case PGEM_ROBUST_ROUND_LIMIT: return "round_limit";
    case PGEM_ROBUST_ITERATION_LIMIT: return "iteration_limit";
    case PGEM_ROBUST_STOPPED: return "stopped";
    case PGEM_ROBUST_FAILED: return "failed";
    case PGEM_ROBUST_OSCILLATED: return "oscillated";
    }
    return "unknown";
}
