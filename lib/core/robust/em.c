/* EM of Lee, Fraundorfer & Pollefeys (IROS 2013): rounds of E/M iterations (robust/iterate.c)
 * each followed by pruning, until a round prunes nothing (the literal method); by default then
 * the polish (accepted loops at weight 1, Gauss-Newton to convergence) and the consistency
 * test (robust/gate.c), repeated while the test changes any loop's state. */
#include <string.h>

#include "robust/robust.h"

/* Prunes the loops (active or dormant) whose weight fell below the threshold; returns how many.
 * The structure is reviewed before the next M-step. */
static uint32_t pgem_prune(pgem_store_t *store, double threshold)
{
    uint32_t pruned = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_kind[k] == PGEM_EDGE_LOOP && store->edge_active[k] != PGEM_EDGE_PRUNED &&
            store->edge_weight[k] < threshold) {
            store->edge_active[k] = PGEM_EDGE_PRUNED;
            pruned++;
        }
    }
    return pruned;
}

/* Rounds of E/M iterations, each followed by pruning, until a round prunes nothing. */
int pgem_em_rounds(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                   const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    pgem_store_t *store = parts->solve.store;
    pgem_robust_progress_t progress;
    memset(&progress, 0, sizeof progress);
    for (uint32_t round = 1; round <= options->max_rounds; round++) {
        int status = pgem_em_iterate(parts, options, solve, summary,
                                     round > 1u && !options->restart, &progress.largest_change);
        if (status != PGEM_OK || pgem_robust_stopped(summary)) {
            return status;
        }
        const uint32_t pruned = pgem_prune(store, options->prune_threshold);
        if (options->frames >= 0 && (pruned > 0u || round == 1u)) {
            /* a part left joined only by pruned loops, moved rigidly: its weights stand */
            summary->frames_placed += pgem_robust_frames(parts, options, 1);
        }
        summary->rounds++; /* counted across re-admission passes */
        if (pgem_report_round(store, parts->tangent, options, summary, &progress)) {
            return PGEM_OK;
        }
        if (pruned == 0u) {
            pgem_robust_ended(summary, PGEM_ROBUST_CONVERGED);
            return PGEM_OK;
        }
        if (options->restart) {
            pgem_restore_initial(parts->state, store,
                                 PGEM_POSE_SIZE(parts->solve.config->dimension));
        }
    }
    pgem_robust_ended(summary, PGEM_ROBUST_ROUND_LIMIT);
    return PGEM_OK;
}

/* From EM's rounds: the polish, then under the polished estimate the consistency test, and
 * the polish and test again while it changes any loop's state; when it changes none, on a
 * degenerate outcome (most loops rejected: the map rests on a few, and a false run among them
 * bends it) the leave-run-out test, on any other the leave-group-out test (robust/groups.c),
 * and the next pass if it pruned a run or group (bounded by max_rounds passes). Ends polished.
 * No EM rounds run between passes: the test decides each loop against the leave-one-out
 * prediction of the polished map, which is what the rounds' innovation E-steps converged to,
 * at a tenth of their cost (docs/design/robust-em.md). */
static int pgem_em_passes(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                          const pgem_solve_options_t *solve, pgem_robust_summary_t *summary,
                          double gate)
{
    int status = PGEM_OK;
    pgem_settle_t settle;
    memset(&settle, 0, sizeof settle);
    for (uint32_t pass = 0; status == PGEM_OK; pass++) {
        status = pgem_em_polish(parts, solve, summary);
        if (status != PGEM_OK || pgem_robust_stopped(summary)) {
            break;
        }
        pgem_pass_mark_t mark;
        pgem_pass_mark(parts->solve.store, parts->tangent, options->scale, &mark);
        if (pgem_settle_pass(&settle, &mark)) {
            pgem_robust_ended(summary, PGEM_ROBUST_OSCILLATED);
            break;
        }
        if (pass == options->max_rounds) {
            pgem_robust_ended(summary, settle.cycling ? PGEM_ROBUST_OSCILLATED : PGEM_ROBUST_ROUND_LIMIT);
            break;
        }
        if (pgem_em_gate(parts, options, gate, summary) == 0u &&
            (pgem_most_rejected(parts->solve.store)
                 ? pgem_em_leave_run_out(parts, summary, &status)
                 : pgem_em_leave_group_out(parts, summary, &status)) == 0u) {
            pgem_robust_ended(summary, PGEM_ROBUST_CONVERGED);
            break;
        }
    }
    return status;
}

/* EM rounds, then the passes of polish and consistency test. The rounds are the paper's
 * (point chi2, from wherever the estimate starts); with the innovation distance the test
 * measures loops against the map they produced. If every loop ends rejected, a run of loops
 * that passes the global test alone (robust/rescue.c) starts the passes again. */
int pgem_em_with_gate(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                      const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    const double gate = pgem_em_gate_value(parts->tangent, options);
    int status = pgem_em_rounds(parts, options, solve, summary);
    if (status == PGEM_OK && !pgem_robust_stopped(summary)) {
        status = pgem_em_passes(parts, options, solve, summary, gate);
    }
    int rescued = 0;
    if (status == PGEM_OK && !pgem_robust_stopped(summary)) {
        status = pgem_em_rescue(parts, solve, summary, &rescued);
    }
    if (status == PGEM_OK && rescued && !pgem_robust_stopped(summary)) {
        status = pgem_em_passes(parts, options, solve, summary, gate);
    }
    return status;
}
