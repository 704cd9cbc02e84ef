/* EM's leave-group-out test on outcomes that are not degenerate. A group is a run of loops in
 * any state (robust/runs.c), tested through its accepted members: a place recogniser fooled
 * along a stretch gives such a run, its members predict each other, and once the map has bent
 * to them (they outweigh the odometry between the run's ends) no test of one loop, nor the own
 * chi2 of the run, tells them from true ones; what does is the fall of the chi2 when the group
 * leaves the adjustment (robust/leave_run.c's measure). Pruned members of the run join it, so
 * that a false run EM cut into pieces, each holding the map for the others, leaves whole.
 *
 * Two things differ from the degenerate outcome's test. Falls are measured from the Gauss-Newton
 * model's minimum with every accepted loop, not from the polished chi2: a polish stops short of
 * the minimum when a false run fights the odometry. And the quantiles are scaled by the variance
 * factor, the chi2 per redundant row at that minimum: it is the covariances' own scale (M3500's
 * are ten times too loose, so that a false run there costs the odometry less than the unscaled
 * quantile for its rows while true runs cost a tenth of it); on calibrated covariances it is
 * near 1 and the test is the unscaled one.
 *
 * Cost: a fall only grows with what leaves, so every group leaving at once is the test of them
 * all; two factorisations when it passes. Only when it fails is each group tested alone, one
 * factorisation each, and the group whose fall exceeds its quantile by the largest factor is
 * pruned (a true run next to a false one that bent the map fails too, by less). At most one
 * group per pass of EM, and the passes are bounded by max_rounds. */
#include "robust/robust.h"

/* Members of a group are looked for within this many edges of each other in the graph's
 * order: a front-end writes a run's loops together (the files' runs and pgem corrupt's groups
 * are at most a few odometry edges apart), and a bounded window keeps a scan of the groups at
 * O(edges x window) where runs.c's whole-graph search is O(edges^2). */
#define PGEM_GROUP_WINDOW 64u

/* The run (any state) that starts at loop k in `direction`, and its accepted members. */
typedef struct pgem_loop_group {
    uint32_t first;     /* edge index of its first loop */
    int direction;      /* as a run's */
    uint32_t length;    /* loops in it, pruned ones included */
    uint32_t accepted;  /* its accepted members (0: not a group to test) */
} pgem_loop_group_t;

static int pgem_group_accepted(const pgem_robust_parts_t *parts, uint32_t j)
{
    return parts->solve.store->edge_active[j] != PGEM_EDGE_PRUNED;
}

/* The loop within the window of loop k that follows it (step +1) or precedes it (step -1) in
 * a run of `direction`: the first in the graph's order, UINT32_MAX if none. */
static uint32_t pgem_group_neighbour(const pgem_robust_parts_t *parts, uint32_t k, int direction, int step)
{
    const int64_t from = (int64_t)parts->solve.store->edge_from[k] + step;
    const int64_t to = (int64_t)parts->solve.store->edge_to[k] + (int64_t)step * direction;
    const uint32_t low = k > PGEM_GROUP_WINDOW ? k - PGEM_GROUP_WINDOW : 0u;
    const uint32_t high = parts->solve.store->edge_count - k > PGEM_GROUP_WINDOW ? k + PGEM_GROUP_WINDOW : parts->solve.store->edge_count - 1u;
    for (uint32_t j = low; j <= high; j++) {
        if (j != k && parts->solve.store->edge_kind[j] == PGEM_EDGE_LOOP && (int64_t)parts->solve.store->edge_from[j] == from &&
            (int64_t)parts->solve.store->edge_to[j] == to) {
            return j;
        }
    }
    return UINT32_MAX;
}

/* The group starting at loop k (accepted = 0 when k starts none, or it has fewer than
 * PGEM_RUN_MIN accepted members). */
static pgem_loop_group_t pgem_group_at(const pgem_robust_parts_t *parts, uint32_t k, int direction)
{
    pgem_loop_group_t group = {k, direction, 0u, 0u};
    if (parts->solve.store->edge_kind[k] != PGEM_EDGE_LOOP || pgem_group_neighbour(parts, k, direction, -1) != UINT32_MAX) {
        return group;
    }
    for (uint32_t j = k; j != UINT32_MAX && group.length < parts->solve.store->edge_count;
         j = pgem_group_neighbour(parts, j, direction, 1)) {
        group.length++;
        group.accepted += (uint32_t)pgem_group_accepted(parts, j);
    }
    group.accepted = group.length >= PGEM_RUN_MIN && group.accepted >= 1u ? group.accepted : 0u;
    return group;
}

/* Every accepted member of the group at weight, and at state unless PGEM_RUN_KEEP_STATE. */
static void pgem_group_set(const pgem_robust_parts_t *parts, const pgem_loop_group_t *group, double weight, int state)
{
    uint32_t j = group->first;
    for (uint32_t n = 0; n < group->length && j != UINT32_MAX; n++) {
        const uint32_t next = pgem_group_neighbour(parts, j, group->direction, 1);
        if (pgem_group_accepted(parts, j)) {
            parts->solve.store->edge_weight[j] = weight;
            if (state != PGEM_RUN_KEEP_STATE) {
                parts->solve.store->edge_active[j] = (uint8_t)state;
            }
        }
        j = next;
    }
}

/* The group's quantile: the 99.9% chi-square quantile for its accepted rows, scaled. */
static double pgem_group_quantile(const pgem_robust_parts_t *parts, const pgem_loop_group_t *group, double scale)
{
    return scale * pgem_chi2_quantile((double)group->accepted * (double)parts->tangent);
}

/* The fall from `with` (the model's minimum with every accepted loop) when the group leaves. */
static double pgem_group_fall(const pgem_robust_parts_t *parts, const pgem_loop_group_t *group, double with, int *status)
{
    pgem_group_set(parts, group, 0.0, PGEM_RUN_KEEP_STATE);
    const double fall = with - pgem_model_minimum(parts, status);
    pgem_group_set(parts, group, 1.0, PGEM_RUN_KEEP_STATE);
    return fall;
}

/* Every group's accepted members leave (weight 0); returns their rows. After the polish every
 * accepted loop weighs 1, so those at 0 are the members. */
static double pgem_groups_leave(const pgem_robust_parts_t *parts)
{
    uint32_t members = 0;
    for (uint32_t k = 0; k < parts->solve.store->edge_count; k++) {
        for (int direction = 1; direction >= -1; direction -= 2) {
            const pgem_loop_group_t group = pgem_group_at(parts, k, direction);
            if (group.accepted > 0u) {
                pgem_group_set(parts, &group, 0.0, PGEM_RUN_KEEP_STATE);
            }
        }
    }
    for (uint32_t k = 0; k < parts->solve.store->edge_count; k++) {
        members += parts->solve.store->edge_kind[k] == PGEM_EDGE_LOOP && pgem_group_accepted(parts, k) &&
                   parts->solve.store->edge_weight[k] == 0.0;
    }
    return (double)members * (double)parts->tangent;
}

/* Every accepted loop back at the polish's weight 1. */
static void pgem_groups_back(const pgem_robust_parts_t *parts)
{
    for (uint32_t k = 0; k < parts->solve.store->edge_count; k++) {
        if (parts->solve.store->edge_kind[k] == PGEM_EDGE_LOOP && pgem_group_accepted(parts, k)) {
            parts->solve.store->edge_weight[k] = 1.0;
        }
    }
}

/* The variance factor: the chi2 per redundant row of the graph without the groups (a false
 * group the map bent to inflates the whole graph's), at its 99.9% upper confidence bound, so
 * that a rest with few redundant rows scales leniently; the whole graph's where the rest has no
 * redundancy. At most 1: calibrated or optimistic covariances get the unscaled test. */
static double pgem_groups_variance(double with, double redundancy, double fall, double rows)
{
    const double rest = redundancy - rows, lower = rest > 0.0 ? pgem_chi2_lower_quantile(rest) : 0.0;
    const double variance = lower > 0.0 ? (with - fall) / lower : with / redundancy;
    return variance < 1.0 ? variance : 1.0;
}

/* A group is pruned when its fall exceeds its quantile scaled by PGEM_VARIANCE_MARGIN times the
 * variance factor (at most 1). The test of every group at once is a screen for cost only, and
 * uses the variance factor alone. */
/* The group to prune (accepted = 0: none): the joint test, then, if it fails, each group. */
static pgem_loop_group_t pgem_failing_group(const pgem_robust_parts_t *parts, double redundancy, int *status)
{
    pgem_loop_group_t worst = {0, 0, 0, 0};
    const double with = pgem_model_minimum(parts, status);
    const double rows = pgem_groups_leave(parts);
    const double fall = *status == PGEM_OK ? with - pgem_model_minimum(parts, status) : 0.0;
    pgem_groups_back(parts);
    const double variance = pgem_groups_variance(with, redundancy, fall, rows);
    if (*status != PGEM_OK || !(with > 0.0) || !(fall > variance * pgem_chi2_quantile(rows))) {
        return worst;
    }
    const double scale = PGEM_VARIANCE_MARGIN * variance < 1.0 ? PGEM_VARIANCE_MARGIN * variance : 1.0;
    double worst_ratio = 1.0;
    for (uint32_t k = 0; k < parts->solve.store->edge_count && *status == PGEM_OK; k++) {
        for (int direction = 1; direction >= -1 && *status == PGEM_OK; direction -= 2) {
            const pgem_loop_group_t group = pgem_group_at(parts, k, direction);
            if (group.accepted == 0u) {
                continue;
            }
            const double ratio = pgem_group_fall(parts, &group, with, status) / pgem_group_quantile(parts, &group, scale);
            if (*status == PGEM_OK && ratio > worst_ratio) {
                worst = group;
                worst_ratio = ratio;
            }
        }
    }
    return worst;
}

uint32_t pgem_em_leave_group_out(const pgem_robust_parts_t *parts, pgem_robust_summary_t *summary, int *status)
{
    *status = PGEM_OK;
    const double redundancy = pgem_redundancy(parts->solve.store, parts->solve.linear, parts->tangent);
    if (!(redundancy > 0.0) || pgem_groups_leave(parts) == 0.0) {
        return 0; /* no group: nothing to factor */
    }
    pgem_groups_back(parts);
    int tested = PGEM_OK;
    const pgem_loop_group_t worst = pgem_failing_group(parts, redundancy, &tested);
    if (tested != PGEM_OK) {
        /* a test the factor could not make decides nothing: the polished estimate stands, and
         * the structure is analysed afresh by whatever solves next */
        pgem_groups_back(parts);
        pgem_linear_invalidate(parts->solve.linear);
        return 0;
    }
    if (worst.accepted == 0u) {
        return 0;
    }
    /* pruned at weight 0, which the consistency test reads as left out with its group */
    summary->gated += worst.accepted;
    pgem_group_set(parts, &worst, 0.0, PGEM_EDGE_PRUNED);
    pgem_linear_invalidate(parts->solve.linear);
    return 1;
}
