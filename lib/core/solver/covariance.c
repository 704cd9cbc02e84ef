/* The covariance calls (pgem/covariance.h): the factor at the current estimate, then marginals
 * from linalg, turned from the system's tangent into the one on the right of each pose (in 2D
 * the system's translation step is in the world frame; in 3D it is already the body's). The
 * incremental factor's covariance call is the online layer's (online/covariance.c). */
#include <math.h>
#include <string.h>

#include "instance.h"
#include "pgem/covariance.h"
#include "solver/solver.h"

int pgem_covariance_prepare(pgem_t *graph)
{
    int status = pgem_analyze(graph);
    if (status == PGEM_OK) {
        status = pgem_linear_check_parts(graph->linear, &graph->store, graph->message);
    }
    if (status != PGEM_OK) {
        return status;
    }
    if (!isfinite(pgem_linear_assemble(graph->linear, &graph->store))) {
        return pgem_fail(graph, PGEM_ERR_NUMERIC, "the chi2 at the current estimate is not "
                                                  "finite: no covariance");
    }
    status = pgem_linear_factor(graph->linear, &graph->store, &graph->executor, graph->message);
    if (status != PGEM_OK) {
        return status;
    }
    pgem_linear_covariance_mark(graph->linear, &graph->store, PGEM_COVARIANCE_FACTOR);
    pgem_message_clear(graph);
    return PGEM_OK;
}

/* PGEM_OK if the covariance calls' factor is the graph's, else NO_FACTOR with its message. */
static int pgem_covariance_current(pgem_t *graph)
{
    if (pgem_linear_covariance_state(graph->linear, &graph->store) != PGEM_COVARIANCE_NONE) {
        return PGEM_OK;
    }
    return pgem_fail(graph, PGEM_ERR_NO_FACTOR,
                     "no factor is current for the covariance calls: call "
                     "pgem_covariance_prepare after the last change to the graph, its estimate "
                     "or its weights (a solve, pgem_update, pgem_set_pose, an added pose or edge)");
}

int pgem_covariance_pose(pgem_t *graph, pgem_id_t id, uint32_t *p)
{
    const int64_t index = pgem_map_find(&graph->store, id);
    if (index < 0) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "no pose with id ");
        pgem_message_u64(graph, id);
        return PGEM_ERR_UNKNOWN_ID;
    }
    *p = (uint32_t)index;
    return PGEM_OK;
}

void pgem_covariance_to_body(const pgem_t *graph, uint32_t p, int n, int offset, double *matrix)
{
    const double theta = graph->store.pose[(size_t)p * 3u + 2u];
    const double c = cos(theta), s = sin(theta);
    for (int j = 0; j < n; j++) { /* rows: R^T [row x; row y] */
        double *x = matrix + (size_t)offset * (size_t)n + (size_t)j;
        double *y = x + n;
        const double a = *x, b = *y;
        *x = c * a + s * b;
        *y = -s * a + c * b;
    }
    for (int i = 0; i < n; i++) { /* columns: [col x, col y] R */
        double *x = matrix + (size_t)i * (size_t)n + (size_t)offset;
        const double a = x[0], b = x[1];
        x[0] = c * a + s * b;
        x[1] = -s * a + c * b;
    }
}

int pgem_covariance(pgem_t *graph, pgem_id_t id, double *covariance)
{
    if (graph == NULL || covariance == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    uint32_t p = 0;
    int status = pgem_covariance_pose(graph, id, &p);
    if (status == PGEM_OK) {
        status = pgem_covariance_current(graph);
    }
    if (status != PGEM_OK) {
        return status;
    }
    pgem_linear_pose_covariance(graph->linear, p, covariance);
    if (graph->config.dimension == 2) {
        pgem_covariance_to_body(graph, p, 3, 0, covariance);
    }
    pgem_message_clear(graph);
    return PGEM_OK;
}

int pgem_joint_covariance(pgem_t *graph, pgem_id_t a, pgem_id_t b, double *covariance)
{
    if (graph == NULL || covariance == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    uint32_t p = 0, q = 0;
    int status = pgem_covariance_pose(graph, a, &p);
    if (status == PGEM_OK) {
        status = pgem_covariance_pose(graph, b, &q);
    }
    if (status == PGEM_OK) {
        status = pgem_covariance_current(graph);
    }
    if (status == PGEM_OK) {
        status = pgem_linear_joint_covariance(graph->linear, &graph->store, &graph->executor,
                                              graph->message, p, q, covariance);
    }
    if (status != PGEM_OK) {
        return status;
    }
    if (graph->config.dimension == 2) {
        pgem_covariance_to_body(graph, p, 6, 0, covariance);
        pgem_covariance_to_body(graph, q, 6, 3, covariance);
    }
    pgem_message_clear(graph);
    return PGEM_OK;
}

int pgem_covariances(pgem_t *graph, double *covariances)
{
    if (graph == NULL || covariances == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const int status = pgem_covariance_current(graph);
    if (status != PGEM_OK) {
        return status;
    }
    pgem_linear_all_covariances(graph->linear, &graph->store, covariances);
    if (graph->config.dimension == 2) {
        for (uint32_t p = 0; p < graph->store.pose_count; p++) {
            pgem_covariance_to_body(graph, p, 3, 0, covariances + (size_t)p * 9u);
        }
    }
    pgem_message_clear(graph);
    return PGEM_OK;
}
