/* EM's consistency test under the polished estimate: the gate (a chi-square quantile, or the
 * options' gate) and the loops it re-admits or prunes. */
#include "robust/robust.h"

/* 99.9% quantiles of the chi-square distribution with 3 and 6 degrees of freedom. */
#define PGEM_CHI2_999_DOF3 16.266
#define PGEM_CHI2_999_DOF6 22.458

double pgem_em_gate_value(int tangent, const pgem_robust_options_t *options)
{
    if (options->gate > 0.0) {
        return options->gate;
    }
    return tangent == 6 ? PGEM_CHI2_999_DOF6 : PGEM_CHI2_999_DOF3;
}

/* The scale of the test of a loop whose rotation the map does not predict: that loop is
 * measured by its innovation under the stated covariances alone, which nothing else
 * calibrates (the odometry allowance is for optimistic covariances, and such a loop gets
 * none). Loose covariances (M3500's, Sphere2500's) would let a false loop near what the
 * odometry gives pass, so the gate is scaled by the variance factor of the polished
 * adjustment: its chi2 per redundant row at the 99.9 % upper confidence bound (the chi2 over
 * the 0.1 % quantile for the redundancy), times PGEM_VARIANCE_MARGIN, at most 1. */
static double pgem_em_unpredicted_scale(const pgem_robust_parts_t *parts)
{
    const pgem_store_t *store = parts->solve.store;
    const double redundancy = pgem_redundancy(store, parts->solve.linear, parts->tangent);
    const double lower = redundancy > 0.0 ? pgem_chi2_lower_quantile(redundancy) : 0.0;
    const double chi2 = pgem_weighted_chi2(store, parts->tangent);
    const double scale = lower > 0.0 ? PGEM_VARIANCE_MARGIN * chi2 / lower : 1.0;
    return scale < 1.0 && scale > 0.0 ? scale : 1.0;
}

/* The consistency test under the polished estimate: a pruned loop whose distance passes the
 * gate is re-admitted, an accepted loop that fails it is pruned. Every loop is tested against
 * the same estimate. Returns how many changed state. */
uint32_t pgem_em_gate(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                      double gate, pgem_robust_summary_t *summary)
{
    pgem_store_t *store = parts->solve.store;
    uint32_t changed = 0;
    pgem_em_distances(parts, options, gate, pgem_em_unpredicted_scale(parts));
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_kind[k] != PGEM_EDGE_LOOP) {
            continue;
        }
        /* a loop the leave-run-out test pruned (weight 0) was tested with its run */
        const int run_out = store->edge_active[k] == PGEM_EDGE_PRUNED && store->edge_weight[k] == 0.0;
        const int consistent = parts->state->edge_distance[k] < gate && !run_out;
        if (consistent != (store->edge_active[k] != PGEM_EDGE_PRUNED)) {
            store->edge_active[k] = consistent ? PGEM_EDGE_ACTIVE : PGEM_EDGE_PRUNED;
            summary->readmitted += (uint32_t)consistent;
            summary->gated += (uint32_t)!consistent;
            changed++;
        }
    }
    if (changed > 0u) {
        pgem_linear_invalidate(parts->solve.linear);
    }
    return changed;
}

