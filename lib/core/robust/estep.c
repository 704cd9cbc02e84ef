/* EM's E-step and the consistency test's distances. The E-step is the paper's: each loop's
 * weight from its point chi2 under the current estimate. The test's innovation distance
 * measures a loop against what the rest of the graph predicts for its two poses
 * (robust/innovation.c), so a loop that the odometry's drift explains is not called an
 * outlier. It is used where the map predicts the loop's rotation to
 * options->predictable_rotation; where it does not, any measurement would look consistent,
 * and the point chi2 (or, for an accepted loop, the innovation without the odometry
 * allowance) is used instead. */
#include <math.h>

#include "robust/robust.h"

/* A factor of H under the current estimate at the current weights, and the Gauss-Newton step
 * from it in pgem_linear_step (the innovations predict from where that step leads). */
static int pgem_factor_current(const pgem_robust_parts_t *parts)
{
    const pgem_solve_parts_t *solve = &parts->solve;
    pgem_robust_hold_parts(solve->linear, solve->store);
    int status = pgem_solver_analyze(solve);
    if (status == PGEM_OK) {
        (void)pgem_linear_assemble(solve->linear, solve->store);
        status = pgem_linear_factor(solve->linear, solve->store, solve->executor, solve->message);
    }
    if (status == PGEM_OK) {
        status = pgem_solve_newton(solve->linear, solve->store);
    }
    return status;
}

/* Loop k's distance into edge_distance, and edge_checked: 1 if the map predicted it. Where
 * it did not, the innovation under the stated covariances alone (no allowance) is divided by
 * `scale` (robust/gate.c: the variance factor with its margin, at most 1); a pruned loop must
 * also fit the map as it is (its chi2), so the test cannot re-admit what it would prune. */
static void pgem_loop_distance(const pgem_robust_parts_t *parts,
                               const pgem_robust_options_t *options, uint32_t k,
                               int from_inverse, double scale)
{
    const pgem_store_t *store = parts->solve.store;
    pgem_robust_state_t *robust = parts->state;
    const int pruned = store->edge_active[k] == PGEM_EDGE_PRUNED;
    pgem_innovation_t innovation;
    pgem_loop_innovation(parts->solve.linear, store, parts->tangent, k,
                         pruned ? 0.0 : store->edge_weight[k], options->odometry_inflation,
                         from_inverse, &innovation);
    const int checked = innovation.rotation_sd <= options->predictable_rotation;
    robust->edge_checked[k] = (uint8_t)checked;
    if (checked) {
        robust->edge_distance[k] = innovation.distance;
    } else if (!pruned) {
        robust->edge_distance[k] = innovation.plain / scale; /* leave-one-out */
    } else {
        robust->edge_distance[k] =
            fmax(pgem_edge_mahalanobis(store, k, parts->tangent), innovation.plain / scale);
    }
}

/* edge_checked while a pruned loop waits for its solve with L. */
#define PGEM_CHECK_PENDING 2

void pgem_em_distances(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                       double gate, double scale)
{
    pgem_store_t *store = parts->solve.store;
    pgem_robust_state_t *robust = parts->state;
    pgem_linear_t *linear = parts->solve.linear;
    const int innovation = options->distance == PGEM_DISTANCE_INNOVATION &&
                           pgem_factor_current(parts) == PGEM_OK;
    uint32_t on_pattern = 0, off_pattern = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_kind[k] != PGEM_EDGE_LOOP) {
            continue;
        }
        if (!innovation) { /* the point distance, or a singular problem: no covariance */
            robust->edge_distance[k] = pgem_edge_mahalanobis(store, k, parts->tangent);
            robust->edge_checked[k] = 0;
        } else if (pgem_linear_on_pattern(linear, store, k)) {
            on_pattern++;
        } else {
            off_pattern++;
        }
    }
    if (!innovation || on_pattern + off_pattern == 0u) {
        return;
    }
    pgem_linear_invert(linear);
    uint32_t unsure = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_kind[k] != PGEM_EDGE_LOOP) {
            continue;
        }
        if (pgem_linear_on_pattern(linear, store, k)) {
            pgem_loop_distance(parts, options, k, 1, scale);
            continue;
        }
        /* a pruned loop off the pattern: a solve with L along its poses' paths, unless bounds
         * from the inverse's diagonal blocks already decide the test */
        double distance = 0.0;
        int screened = pgem_loop_screen(linear, store, parts->tangent, k,
                                        options->odometry_inflation, gate, &distance);
        if (screened > 0 && !(distance < gate * scale)) {
            screened = 0; /* its scaled innovation could still fail: computed */
        }
        robust->edge_distance[k] = distance;
        robust->edge_checked[k] = screened == 0 ? PGEM_CHECK_PENDING : 0;
        unsure += (uint32_t)(screened == 0);
    }
    if (unsure == 0u ||
        pgem_linear_factor(linear, store, parts->solve.executor, parts->solve.message) !=
            PGEM_OK) {
        return; /* (the factor was fine before the inverse: it cannot fail now) */
    }
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_kind[k] == PGEM_EDGE_LOOP && robust->edge_checked[k] == PGEM_CHECK_PENDING) {
            pgem_loop_distance(parts, options, k, 0, scale);
        }
    }
}

int pgem_em_e_step(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                   double *largest_change)
{
    pgem_store_t *store = parts->solve.store;
    pgem_robust_state_t *robust = parts->state;
    double largest = 0.0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_kind[k] != PGEM_EDGE_LOOP || store->edge_active[k] == PGEM_EDGE_PRUNED) {
            continue;
        }
        robust->edge_distance[k] = pgem_edge_mahalanobis(store, k, parts->tangent);
        robust->edge_checked[k] = 0;
        double weight = 1.0;
        const int status = pgem_loop_kernel_weight(robust, store, options, k, &weight,
                                                   parts->solve.message);
        if (status != PGEM_OK) {
            return status;
        }
        largest = fmax(largest, fabs(weight - store->edge_weight[k]));
        store->edge_weight[k] = weight;
        store->edge_active[k] = weight < options->dormant_threshold ? PGEM_EDGE_DORMANT
                                                                    : PGEM_EDGE_ACTIVE;
    }
    *largest_change = largest;
    return PGEM_OK;
}
