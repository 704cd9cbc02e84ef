/* EM's second chance when it rejected nearly every loop closure (more than PGEM_MOST_REJECTED
 * of them): a run of loops that a place recogniser would produce along a revisit (poses a,
 * a+1, ... matched to b, b+s, b+2s, ..., s = +1 or -1), longer than the set EM accepted, is
 * tried alone from the initial estimate, and kept, with EM's passes run again from it, if the
 * map it gives passes the global chi-square test of the adjustment: a larger consistent set
 * than EM's. */
#include "robust/robust.h"

/* Runs tried, longest first, before the outcome is left at every loop rejected. */
#define PGEM_RESCUE_ATTEMPTS 3u

/* 1 if run a comes before run b in the order of trial: longer first, then by first loop and
 * direction. */
static int pgem_run_before(const pgem_loop_run_t *a, const pgem_loop_run_t *b)
{
    if (a->length != b->length) {
        return a->length > b->length;
    }
    if (a->first != b->first) {
        return a->first < b->first;
    }
    return a->direction > b->direction;
}

/* The first run in the order of trial after `last` (every run if last->length is 0), of at
 * least PGEM_RUN_MIN loops; 0 if there is none. */
static int pgem_run_after(const pgem_robust_parts_t *parts, const pgem_loop_run_t *last, pgem_loop_run_t *out)
{
    int found = 0;
    for (uint32_t k = 0; k < parts->solve.store->edge_count; k++) {
        if (parts->solve.store->edge_kind[k] != PGEM_EDGE_LOOP) {
            continue;
        }
        for (int direction = 1; direction >= -1; direction -= 2) {
            const pgem_loop_run_t run = {
                k, direction, pgem_run_length(parts->solve.store, k, direction, PGEM_RUN_ANY)};
            if (run.length >= PGEM_RUN_MIN && (last->length == 0u || pgem_run_before(last, &run)) &&
                (!found || pgem_run_before(&run, out))) {
                *out = run;
                found = 1;
            }
        }
    }
    return found;
}

/* Every loop pruned but the run's, active at weight 1 (the others keep their weights, so the
 * consistency test may re-admit them); the initial estimate. */
static void pgem_run_alone(const pgem_robust_parts_t *parts, const pgem_loop_run_t *run)
{
    for (uint32_t k = 0; k < parts->solve.store->edge_count; k++) {
        if (parts->solve.store->edge_kind[k] == PGEM_EDGE_LOOP) {
            parts->solve.store->edge_active[k] = PGEM_EDGE_PRUNED;
        }
    }
    pgem_run_set(parts->solve.store, run, PGEM_RUN_ANY, 1.0, PGEM_EDGE_ACTIVE);
    pgem_linear_invalidate(parts->solve.linear);
    pgem_restore_initial(parts->state, parts->solve.store, PGEM_POSE_SIZE(parts->solve.config->dimension));
}

/* The global test of the adjustment after a polish: its chi2 below the 99.9% quantile of the
 * chi-square distribution with the redundancy's degrees of freedom (Wilson-Hilferty). */
static int pgem_adjustment_consistent(const pgem_robust_parts_t *parts)
{
    const double dof = pgem_redundancy(parts->solve.store, parts->solve.linear, parts->tangent);
    if (!(dof > 0.0)) {
        return 0;
    }
    return pgem_weighted_chi2(parts->solve.store, parts->tangent) <= pgem_chi2_quantile(dof);
}

/* Loops accepted; each loop's state marked in edge_checked (free between E-steps). */
static uint32_t pgem_mark_accepted(const pgem_robust_parts_t *parts)
{
    uint32_t accepted = 0;
    for (uint32_t k = 0; k < parts->solve.store->edge_count; k++) {
        const int active = parts->solve.store->edge_kind[k] == PGEM_EDGE_LOOP && parts->solve.store->edge_active[k] != PGEM_EDGE_PRUNED;
        parts->state->edge_checked[k] = (uint8_t)active;
        accepted += (uint32_t)active;
    }
    return accepted;
}

/* Back to the loops marked accepted, at weight 1, from the initial estimate. */
static void pgem_back_to_marked(const pgem_robust_parts_t *parts)
{
    for (uint32_t k = 0; k < parts->solve.store->edge_count; k++) {
        if (parts->state->edge_checked[k]) {
            parts->solve.store->edge_weight[k] = 1.0;
            parts->solve.store->edge_active[k] = PGEM_EDGE_ACTIVE;
        } else if (parts->solve.store->edge_kind[k] == PGEM_EDGE_LOOP) {
            parts->solve.store->edge_active[k] = PGEM_EDGE_PRUNED;
        }
    }
    pgem_linear_invalidate(parts->solve.linear);
    pgem_restore_initial(parts->state, parts->solve.store, PGEM_POSE_SIZE(parts->solve.config->dimension));
}

int pgem_em_rescue(const pgem_robust_parts_t *parts, const pgem_solve_options_t *solve,
                   pgem_robust_summary_t *summary, int *rescued)
{
    *rescued = 0;
    if (!pgem_most_rejected(parts->solve.store)) {
        return PGEM_OK; /* not a degenerate outcome */
    }
    const uint32_t accepted = pgem_mark_accepted(parts);
    pgem_loop_run_t last = {0, 0, 0}, run = {0, 0, 0};
    for (uint32_t attempt = 0; attempt < PGEM_RESCUE_ATTEMPTS && pgem_run_after(parts, &last, &run) &&
                               run.length > accepted; attempt++) {
        pgem_run_alone(parts, &run);
        const int status = pgem_em_polish(parts, solve, summary);
        if (pgem_robust_stopped(summary)) {
            return status; /* asked to stop: the run is left as it is */
        }
        if (status == PGEM_OK && pgem_adjustment_consistent(parts)) {
            summary->readmitted += run.length;
            *rescued = 1;
            return PGEM_OK;
        }
        last = run;
    }
    if (last.length > 0u) { /* back to EM's loops */
        pgem_back_to_marked(parts);
        return pgem_em_polish(parts, solve, summary);
    }
    return PGEM_OK;
}
