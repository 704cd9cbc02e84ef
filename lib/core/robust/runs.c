/* Runs of loop closures, what a place recogniser produces along a revisit: loops from poses a,
 * a+1, a+2, ... to b, b+s, b+2s, ... (s = +1 or -1), found by scanning the edges (no storage);
 * and the chi-square quantile the tests on them use. */
#include <math.h>

#include "robust/robust.h"

/* Standard normal quantile of the tests on runs (99.9%). */
#define PGEM_RUN_Z 3.0902

static int pgem_run_member(const pgem_store_t *store, uint32_t j, pgem_run_members_t members)
{
    if (store->edge_kind[j] != PGEM_EDGE_LOOP) {
        return 0;
    }
    const int pruned = store->edge_active[j] == PGEM_EDGE_PRUNED;
    return members == PGEM_RUN_ANY || (members == PGEM_RUN_ACCEPTED) == !pruned;
}

uint32_t pgem_run_next(const pgem_store_t *store, uint32_t k, int direction,
                       pgem_run_members_t members)
{
    const uint32_t from = store->edge_from[k] + 1u;
    const int64_t to = (int64_t)store->edge_to[k] + direction;
    for (uint32_t j = 0; j < store->edge_count; j++) {
        if (store->edge_from[j] == from && (int64_t)store->edge_to[j] == to &&
            pgem_run_member(store, j, members)) {
            return j;
        }
    }
    return UINT32_MAX;
}

uint32_t pgem_run_length(const pgem_store_t *store, uint32_t k, int direction,
                         pgem_run_members_t members)
{
    if (!pgem_run_member(store, k, members)) {
        return 0;
    }
    uint32_t next = pgem_run_next(store, k, direction, members);
    if (next == UINT32_MAX) {
        return 1; /* shorter than any run tested: no need to look for a predecessor */
    }
    const uint32_t from = store->edge_from[k];
    const int64_t to = (int64_t)store->edge_to[k];
    for (uint32_t j = 0; j < store->edge_count; j++) {
        if (store->edge_from[j] + 1u == from && (int64_t)store->edge_to[j] + direction == to &&
            pgem_run_member(store, j, members)) {
            return 0; /* not a run's start */
        }
    }
    uint32_t length = 1;
    for (; next != UINT32_MAX && length < store->edge_count;
         next = pgem_run_next(store, next, direction, members)) {
        length++;
    }
    return length;
}

void pgem_run_set(pgem_store_t *store, const pgem_loop_run_t *run, pgem_run_members_t members,
                  double weight, int state)
{
    uint32_t j = run->first;
    for (uint32_t n = 0; n < run->length && j != UINT32_MAX; n++) {
        /* the next before the state changes */
        const uint32_t next = pgem_run_next(store, j, run->direction, members);
        store->edge_weight[j] = weight;
        if (state != PGEM_RUN_KEEP_STATE) {
            store->edge_active[j] = (uint8_t)state;
        }
        j = next;
    }
}

double pgem_chi2_quantile(double dof)
{
    const double spread = sqrt(2.0 / (9.0 * dof));
    const double cube = 1.0 - 2.0 / (9.0 * dof) + PGEM_RUN_Z * spread;
    return dof * cube * cube * cube;
}

double pgem_chi2_lower_quantile(double dof)
{
    const double spread = sqrt(2.0 / (9.0 * dof));
    const double cube = 1.0 - 2.0 / (9.0 * dof) - PGEM_RUN_Z * spread;
    return cube > 0.0 ? dof * cube * cube * cube : 0.0;
}

int pgem_most_rejected(const pgem_store_t *store)
{
    uint32_t loops = 0, accepted = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_kind[k] == PGEM_EDGE_LOOP) {
            loops++;
            accepted += store->edge_active[k] != PGEM_EDGE_PRUNED;
        }
    }
    return pgem_share_most_rejected(loops - accepted, loops);
}

double pgem_redundancy(const pgem_store_t *store, const pgem_linear_t *linear, int tangent)
{
    uint32_t rows = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        rows += store->edge_active[k] != PGEM_EDGE_PRUNED ? (uint32_t)tangent : 0u;
    }
    return (double)rows - (double)pgem_linear_unknowns(linear);
}
