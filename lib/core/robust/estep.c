/* EM's E-step and the consistency test's distances. The E-step is the paper's: each loop's
 * weight from its point chi2 under the current estimate. The test's innovation distance
 * measures a loop against what the rest of the graph predicts for its two poses
 * (robust/innovation.c), so a loop that the odometry's drift explains is not called an
 * outlier. It is used where the map predicts the loop's rotation to
 * options->predictable_rotation; where it does not, any measurement would look consistent,
 * and the point chi2 (or, for an accepted loop, the innovation without the odometry
 * allowance) is used instead. */
#include <math.h>

#include "instance.h"
#include "robust/robust.h"

/* A factor of H under the current estimate at the current weights, and the Gauss-Newton step
 * from it in pgem_linear_step (the innovations predict from where that step leads). */
static int pgem_factor_current(pgem_t *graph)
{
    pgem_robust_hold_parts(graph->linear, &graph->store);
    int status = pgem_analyze(graph);
    if (status == PGEM_OK) {
        (void)pgem_linear_assemble(graph->linear, &graph->store);
        status =
            pgem_linear_factor(graph->linear, &graph->store, &graph->executor, graph->message);
    }
    if (status == PGEM_OK) {
        status = pgem_solve_newton(graph->linear, &graph->store);
    }
    return status;
}

/* Loop k's distance into edge_distance, and edge_checked: 1 if the map predicted it. Where
 * it did not, the innovation under the stated covariances alone (no allowance) is divided by
 * `scale` (robust/gate.c: the variance factor with its margin, at most 1); a pruned loop must
 * also fit the map as it is (its chi2), so the test cannot re-admit what it would prune. */
static void pgem_loop_distance(pgem_t *graph, const pgem_robust_options_t *options, uint32_t k,
                               int from_inverse, double scale)
{
    const int pruned = graph->store.edge_active[k] == PGEM_EDGE_PRUNED;
    pgem_innovation_t innovation;
    pgem_loop_innovation(graph, k, pruned ? 0.0 : graph->store.edge_weight[k],
                         options->odometry_inflation, from_inverse, &innovation);
    const int checked = innovation.rotation_sd <= options->predictable_rotation;
    graph->robust.edge_checked[k] = (uint8_t)checked;
    if (checked) {
        graph->robust.edge_distance[k] = innovation.distance;
    } else if (!pruned) {
        graph->robust.edge_distance[k] = innovation.plain / scale; /* leave-one-out */
    } else {
        graph->robust.edge_distance[k] =
            fmax(pgem_edge_mahalanobis(&graph->store, k, graph->tangent), innovation.plain / scale);
    }
}

/* edge_checked while a pruned loop waits for its solve with L. */
#define PGEM_CHECK_PENDING 2

void pgem_em_distances(pgem_t *graph, const pgem_robust_options_t *options, double gate, double scale)
{
    const int innovation = options->distance == PGEM_DISTANCE_INNOVATION &&
                           pgem_factor_current(graph) == PGEM_OK;
    uint32_t on_pattern = 0, off_pattern = 0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_kind[k] != PGEM_EDGE_LOOP) {
            continue;
        }
        if (!innovation) { /* the point distance, or a singular problem: no covariance */
            graph->robust.edge_distance[k] =
                pgem_edge_mahalanobis(&graph->store, k, graph->tangent);
            graph->robust.edge_checked[k] = 0;
        } else if (pgem_linear_on_pattern(graph->linear, &graph->store, k)) {
            on_pattern++;
        } else {
            off_pattern++;
        }
    }
    if (!innovation || on_pattern + off_pattern == 0u) {
        return;
    }
    pgem_linear_invert(graph->linear);
    uint32_t unsure = 0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_kind[k] != PGEM_EDGE_LOOP) {
            continue;
        }
        if (pgem_linear_on_pattern(graph->linear, &graph->store, k)) {
            pgem_loop_distance(graph, options, k, 1, scale);
            continue;
        }
        /* a pruned loop off the pattern: a solve with L along its poses' paths, unless bounds
         * from the inverse's diagonal blocks already decide the test */
        double distance = 0.0;
        int screened = pgem_loop_screen(graph, k, options->odometry_inflation, gate, &distance);
        if (screened > 0 && !(distance < gate * scale)) {
            screened = 0; /* its scaled innovation could still fail: computed */
        }
        graph->robust.edge_distance[k] = distance;
        graph->robust.edge_checked[k] = screened == 0 ? PGEM_CHECK_PENDING : 0;
        unsure += (uint32_t)(screened == 0);
    }
    if (unsure == 0u ||
        pgem_linear_factor(graph->linear, &graph->store, &graph->executor, graph->message) !=
            PGEM_OK) {
        return; /* (the factor was fine before the inverse: it cannot fail now) */
    }
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_kind[k] == PGEM_EDGE_LOOP && graph->robust.edge_checked[k] == PGEM_CHECK_PENDING) {
            pgem_loop_distance(graph, options, k, 0, scale);
        }
    }
}

int pgem_em_e_step(pgem_t *graph, const pgem_robust_options_t *options, double *largest_change)
{
    double largest = 0.0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_kind[k] != PGEM_EDGE_LOOP || graph->store.edge_active[k] == PGEM_EDGE_PRUNED) {
            continue;
        }
        graph->robust.edge_distance[k] = pgem_edge_mahalanobis(&graph->store, k, graph->tangent);
        graph->robust.edge_checked[k] = 0;
        double weight = 1.0;
        const int status = pgem_loop_kernel_weight(&graph->robust, &graph->store, options, k,
                                                   &weight, graph->message);
        if (status != PGEM_OK) {
            return status;
        }
        largest = fmax(largest, fabs(weight - graph->store.edge_weight[k]));
        graph->store.edge_weight[k] = weight;
        graph->store.edge_active[k] = weight < options->dormant_threshold ? PGEM_EDGE_DORMANT
                                                                    : PGEM_EDGE_ACTIVE;
    }
    *largest_change = largest;
    return PGEM_OK;
}
