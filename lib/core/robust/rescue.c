/* EM's second chance when it accepted fewer loop closures than a run holds: a run of loops that a place
 * recogniser would produce along a revisit (poses a, a+1, ... matched to b, b+s, b+2s, ...,
 * s = +1 or -1) is tried alone from the initial estimate, and kept, with EM's passes run again
 * from it, if the map it gives passes the global chi-square test of the adjustment: a larger
 * consistent set than EM's. */
#include <math.h>

#include "instance.h"
#include "robust/robust.h"

/* Runs shorter than this are not tried: one or two loops are what the consistency test
 * already re-examines one by one. */
#define PGEM_RESCUE_MIN_RUN 3u
/* Runs tried, longest first, before the outcome is left at every loop rejected. */
#define PGEM_RESCUE_ATTEMPTS 3u
/* Standard normal quantile of the global test (99.9%). */
#define PGEM_RESCUE_Z 3.0902

/* A run of loops: its first loop, its direction s (+1 or -1) and its length. */
typedef struct pgem_loop_run {
    uint32_t first;  /* edge index of the run's first loop */
    int direction;   /* s: the second pose moves by s as the first moves by 1 */
    uint32_t length; /* loops in the run */
} pgem_loop_run_t;

/* The loop from pose `from` + 1 to pose `to` + direction, if any (the first in edge order). */
static uint32_t pgem_run_next(const pgem_t *graph, uint32_t k, int direction)
{
    const uint32_t from = graph->store.edge_from[k] + 1u;
    const uint32_t to = (uint32_t)((int64_t)graph->store.edge_to[k] + direction);
    for (uint32_t j = 0; j < graph->store.edge_count; j++) {
        if (graph->store.edge_kind[j] == PGEM_EDGE_LOOP && graph->store.edge_from[j] == from &&
            graph->store.edge_to[j] == to) {
            return j;
        }
    }
    return UINT32_MAX;
}

/* Loops in the run that starts at loop k in `direction` (0 if a loop precedes k in it). */
static uint32_t pgem_run_length(const pgem_t *graph, uint32_t k, int direction)
{
    const uint32_t from = graph->store.edge_from[k], to = graph->store.edge_to[k];
    for (uint32_t j = 0; j < graph->store.edge_count; j++) {
        if (graph->store.edge_kind[j] == PGEM_EDGE_LOOP && graph->store.edge_from[j] + 1u == from &&
            (int64_t)graph->store.edge_to[j] + direction == (int64_t)to) {
            return 0; /* not a run's start */
        }
    }
    uint32_t length = 0;
    for (uint32_t j = k; j != UINT32_MAX && length < graph->store.edge_count; j = pgem_run_next(graph, j, direction)) {
        length++;
    }
    return length;
}

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
 * least PGEM_RESCUE_MIN_RUN loops; 0 if there is none. */
static int pgem_run_after(const pgem_t *graph, const pgem_loop_run_t *last, pgem_loop_run_t *out)
{
    int found = 0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_kind[k] != PGEM_EDGE_LOOP) {
            continue;
        }
        for (int direction = 1; direction >= -1; direction -= 2) {
            const pgem_loop_run_t run = {k, direction, pgem_run_length(graph, k, direction)};
            if (run.length >= PGEM_RESCUE_MIN_RUN && (last->length == 0u || pgem_run_before(last, &run)) &&
                (!found || pgem_run_before(&run, out))) {
                *out = run;
                found = 1;
            }
        }
    }
    return found;
}

/* Every loop pruned at weight 0 but the run's, active at weight 1; the initial estimate. */
static void pgem_run_alone(pgem_t *graph, const pgem_loop_run_t *run)
{
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_kind[k] == PGEM_EDGE_LOOP && graph->store.edge_active[k] != PGEM_EDGE_PRUNED) {
            graph->store.edge_weight[k] = 0.0;
            graph->store.edge_active[k] = PGEM_EDGE_PRUNED;
        }
    }
    for (uint32_t j = run->first, n = 0; j != UINT32_MAX && n < run->length; j = pgem_run_next(graph, j, run->direction), n++) {
        graph->store.edge_weight[j] = 1.0;
        graph->store.edge_active[j] = PGEM_EDGE_ACTIVE;
    }
    pgem_linear_invalidate(graph);
    pgem_restore_initial(graph);
}

/* The global test of the adjustment after a polish: its chi2 below the 99.9% quantile of the
 * chi-square distribution with the redundancy's degrees of freedom (Wilson-Hilferty). */
static int pgem_adjustment_consistent(const pgem_t *graph)
{
    uint32_t rows = 0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        rows += graph->store.edge_active[k] != PGEM_EDGE_PRUNED ? (uint32_t)graph->tangent : 0u;
    }
    const double dof = (double)rows - (double)pgem_linear_unknowns(graph);
    if (!(dof > 0.0)) {
        return 0;
    }
    const double spread = sqrt(2.0 / (9.0 * dof));
    const double cube = 1.0 - 2.0 / (9.0 * dof) + PGEM_RESCUE_Z * spread;
    return pgem_weighted_chi2(graph) <= dof * cube * cube * cube;
}

/* Loops accepted; each loop's state marked in edge_checked (free between E-steps). */
static uint32_t pgem_mark_accepted(pgem_t *graph)
{
    uint32_t accepted = 0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        const int active = graph->store.edge_kind[k] == PGEM_EDGE_LOOP && graph->store.edge_active[k] != PGEM_EDGE_PRUNED;
        graph->robust.edge_checked[k] = (uint8_t)active;
        accepted += (uint32_t)active;
    }
    return accepted;
}

/* Back to the loops marked accepted, at weight 1, from the initial estimate. */
static void pgem_back_to_marked(pgem_t *graph)
{
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->robust.edge_checked[k]) {
            graph->store.edge_weight[k] = 1.0;
            graph->store.edge_active[k] = PGEM_EDGE_ACTIVE;
        } else if (graph->store.edge_kind[k] == PGEM_EDGE_LOOP) {
            graph->store.edge_active[k] = PGEM_EDGE_PRUNED;
        }
    }
    pgem_linear_invalidate(graph);
    pgem_restore_initial(graph);
}

int pgem_em_rescue(pgem_t *graph, const pgem_solve_options_t *solve, pgem_robust_summary_t *summary,
                   int *rescued)
{
    *rescued = 0;
    const uint32_t accepted = pgem_mark_accepted(graph);
    if (accepted >= PGEM_RESCUE_MIN_RUN) {
        return PGEM_OK;
    }
    pgem_loop_run_t last = {0, 0, 0}, run = {0, 0, 0};
    for (uint32_t attempt = 0; attempt < PGEM_RESCUE_ATTEMPTS && pgem_run_after(graph, &last, &run); attempt++) {
        pgem_run_alone(graph, &run);
        const int status = pgem_em_polish(graph, solve, summary);
        if (status == PGEM_OK && pgem_adjustment_consistent(graph)) {
            summary->readmitted += run.length;
            *rescued = 1;
            return PGEM_OK;
        }
        last = run;
    }
    if (last.length > 0u) { /* back to EM's loops */
        pgem_back_to_marked(graph);
        return pgem_em_polish(graph, solve, summary);
    }
    return PGEM_OK;
}
