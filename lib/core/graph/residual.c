/* Edge errors, Jacobians and chi2 under the current estimate. */
#include "graph/graph.h"
#include "instance.h"

void pgem_edge_error(const pgem_t *graph, uint32_t k, double *error, double *jacobian_from,
                     double *jacobian_to)
{
    const size_t size = (size_t)graph->pose_size;
    const double *from = graph->store.pose + (size_t)graph->store.edge_from[k] * size;
    const double *to = graph->store.pose + (size_t)graph->store.edge_to[k] * size;
    const double *measurement = graph->store.edge_measurement + (size_t)k * size;
    if (graph->config.dimension == 3) {
        pgem_se3_error(from, to, measurement, error, jacobian_from, jacobian_to);
    } else {
        pgem_se2_error(from, to, measurement, error, jacobian_from, jacobian_to);
    }
}

double pgem_edge_mahalanobis(const pgem_t *graph, uint32_t k)
{
    double error[PGEM_TANGENT_SIZE_MAX];
    const int n = graph->tangent;
    const double *information = graph->store.edge_information + (size_t)k * (size_t)(n * n);
    pgem_edge_error(graph, k, error, NULL, NULL);
    return n == 6 ? pgem_quadratic_form(information, error, 6)
                  : pgem_quadratic_form(information, error, 3);
}

int pgem_edge_chi2(const pgem_t *graph, uint32_t index, double *chi2)
{
    if (graph == NULL || chi2 == NULL || index >= graph->store.edge_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    *chi2 = pgem_edge_mahalanobis(graph, index);
    return PGEM_OK;
}

double pgem_total_chi2(const pgem_t *graph)
{
    double chi2 = 0.0;
    if (graph == NULL) {
        return 0.0;
    }
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        chi2 += pgem_edge_mahalanobis(graph, k);
    }
    return chi2;
}

double pgem_weighted_chi2(const pgem_t *graph)
{
    double chi2 = 0.0;
    for (uint32_t k = 0; k < graph->store.edge_count; k++) {
        if (graph->store.edge_active[k] != PGEM_EDGE_PRUNED) {
            chi2 += graph->store.edge_weight[k] * pgem_edge_mahalanobis(graph, k);
        }
    }
    return chi2;
}
