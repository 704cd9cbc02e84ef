/* The covariance calls (pgem/covariance.h): the factor at the current estimate, then marginals
 * from linalg, turned from the system's tangent into the one on the right of each pose (in 2D
 * the system's translation step is in the world frame; in 3D it is already the body's). The
 * incremental factor's covariance call is the online layer's (online/covariance.c). */
#include <math.h>
#include <string.h>

#include "solver/solver.h"

int pgem_solver_covariance_prepare(const pgem_solve_parts_t *parts)
{
    int status = pgem_solver_analyze(parts);
    if (status == PGEM_OK) {
        status = pgem_linear_check_parts(parts->linear, parts->store, parts->message);
    }
    if (status != PGEM_OK) {
        return status;
    }
    if (!isfinite(pgem_linear_assemble(parts->linear, parts->store))) {
        return pgem_text_fail(parts->message, PGEM_ERR_NUMERIC,
                              "the chi2 at the current estimate is not finite: no covariance");
    }
    status = pgem_linear_factor(parts->linear, parts->store, parts->executor, parts->message);
    if (status != PGEM_OK) {
        return status;
    }
    pgem_linear_covariance_mark(parts->linear, parts->store, PGEM_COVARIANCE_FACTOR);
    parts->message[0] = '\0';
    return PGEM_OK;
}

/* PGEM_OK if the covariance calls' factor is the graph's, else NO_FACTOR with its message. */
static int pgem_covariance_current(const pgem_solve_parts_t *parts)
{
    if (pgem_linear_covariance_state(parts->linear, parts->store) != PGEM_COVARIANCE_NONE) {
        return PGEM_OK;
    }
    return pgem_text_fail(parts->message, PGEM_ERR_NO_FACTOR,
                          "no factor is current for the covariance calls: call "
                          "pgem_covariance_prepare after the last change to the graph, its "
                          "estimate or its weights (a solve, pgem_update, pgem_set_pose, an added "
                          "pose or edge)");
}

int pgem_covariance_pose(const pgem_store_t *store, char *message, pgem_id_t id, uint32_t *p)
{
    const int64_t index = pgem_map_find(store, id);
    if (index < 0) {
        message[0] = '\0';
        pgem_text_append(message, PGEM_MESSAGE_SIZE, "no pose with id ");
        pgem_text_u64(message, PGEM_MESSAGE_SIZE, id);
        return PGEM_ERR_UNKNOWN_ID;
    }
    *p = (uint32_t)index;
    return PGEM_OK;
}

void pgem_covariance_to_body(const pgem_store_t *store, uint32_t p, int n, int offset,
                             double *matrix)
{
    const double theta = store->pose[(size_t)p * 3u + 2u];
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

int pgem_solver_covariance(const pgem_solve_parts_t *parts, pgem_id_t id, double *covariance)
{
    uint32_t p = 0;
    int status = pgem_covariance_pose(parts->store, parts->message, id, &p);
    if (status == PGEM_OK) {
        status = pgem_covariance_current(parts);
    }
    if (status != PGEM_OK) {
        return status;
    }
    pgem_linear_pose_covariance(parts->linear, p, covariance);
    if (parts->config->dimension == 2) {
        pgem_covariance_to_body(parts->store, p, 3, 0, covariance);
    }
    parts->message[0] = '\0';
    return PGEM_OK;
}

int pgem_solver_joint_covariance(const pgem_solve_parts_t *parts, pgem_id_t a, pgem_id_t b,
                                 double *covariance)
{
    uint32_t p = 0, q = 0;
    int status = pgem_covariance_pose(parts->store, parts->message, a, &p);
    if (status == PGEM_OK) {
        status = pgem_covariance_pose(parts->store, parts->message, b, &q);
    }
    if (status == PGEM_OK) {
        status = pgem_covariance_current(parts);
    }
    if (status == PGEM_OK) {
        status = pgem_linear_joint_covariance(parts->linear, parts->store, parts->executor,
                                              parts->message, p, q, covariance);
    }
    if (status != PGEM_OK) {
        return status;
    }
    if (parts->config->dimension == 2) {
        pgem_covariance_to_body(parts->store, p, 6, 0, covariance);
        pgem_covariance_to_body(parts->store, q, 6, 3, covariance);
    }
    parts->message[0] = '\0';
    return PGEM_OK;
}

int pgem_solver_covariances(const pgem_solve_parts_t *parts, double *covariances)
{
    const int status = pgem_covariance_current(parts);
    if (status != PGEM_OK) {
        return status;
    }
    pgem_linear_all_covariances(parts->linear, parts->store, covariances);
    if (parts->config->dimension == 2) {
        for (uint32_t p = 0; p < parts->store->pose_count; p++) {
            pgem_covariance_to_body(parts->store, p, 3, 0, covariances + (size_t)p * 9u);
        }
    }
    parts->message[0] = '\0';
    return PGEM_OK;
}
