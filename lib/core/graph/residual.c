/* Edge errors, Jacobians and chi2 under the current estimate. */
#include "graph/graph.h"

void pgem_edge_error(const pgem_store_t *store, uint32_t k, double *error, double *jacobian_from,
                     double *jacobian_to, int tangent)
{
    const size_t size = pgem_pose_doubles(tangent);
    const double *from = store->pose + (size_t)store->edge_from[k] * size;
    const double *to = store->pose + (size_t)store->edge_to[k] * size;
    const double *measurement = store->edge_measurement + (size_t)k * size;
    if (tangent == 6) {
        pgem_se3_error(from, to, measurement, error, jacobian_from, jacobian_to);
    } else {
        pgem_se2_error(from, to, measurement, error, jacobian_from, jacobian_to);
    }
}

double pgem_edge_mahalanobis(const pgem_store_t *store, uint32_t k, int tangent)
{
    double error[PGEM_TANGENT_SIZE_MAX];
    const int n = tangent;
    const double *information = store->edge_information + (size_t)k * (size_t)(n * n);
    pgem_edge_error(store, k, error, NULL, NULL, tangent);
    return n == 6 ? pgem_quadratic_form(information, error, 6)
                  : pgem_quadratic_form(information, error, 3);
}

double pgem_store_total_chi2(const pgem_store_t *store, int tangent)
{
    double chi2 = 0.0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        chi2 += pgem_edge_mahalanobis(store, k, tangent);
    }
    return chi2;
}

double pgem_weighted_chi2(const pgem_store_t *store, int tangent)
{
    double chi2 = 0.0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_active[k] != PGEM_EDGE_PRUNED) {
            chi2 += store->edge_weight[k] * pgem_edge_mahalanobis(store, k, tangent);
        }
    }
    return chi2;
}
