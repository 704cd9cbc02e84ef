/* When H's structure no longer holds: the graph's topology version changed, the edge states left
 * an active edge without a place, or too many idle loops hold a place (the policy the robust
 * layer asks for by pgem_linear_review); and which loops meet on the factor's pattern. It only
 * marks the structure stale; linalg/analysis/analyze.c rebuilds it (pgem_linear_prepare). */
#include "linalg/linear.h"

void pgem_linear_follow(pgem_linear_t *linear, const pgem_store_t *store)
{
    if (linear->topology != store->topology) {
        linear->valid = 0;
        linear->ordered = 0;
        linear->topology = store->topology;
    }
}

void pgem_linear_invalidate(pgem_linear_t *linear)
{
    linear->valid = 0;
    linear->ordered = 0;
    linear->covariance = PGEM_COVARIANCE_NONE;
}

/* 1 if edge k, made active, can be assembled into the current (valid) structure: it has a
 * place there, or touches a held pose (no off-diagonal block). */
static int pgem_edge_in_structure(const pgem_linear_t *linear, const pgem_store_t *store,
                                   uint32_t k)
{
    return linear->all_edges || linear->edge_offset[k] >= 0 ||
           linear->pose_block[store->edge_from[k]] < 0 || linear->pose_block[store->edge_to[k]] < 0;
}

/* The structure must grow when an active edge has no place in it (a loop woke up or was
 * re-admitted). It may shrink: dormant and pruned loops still in it cost fill, so it is
 * rebuilt without them once they are more than a sixteenth of the loops it holds (the
 * full-structure fallback, which holds every edge by design, is kept). */
void pgem_linear_review(pgem_linear_t *linear, const pgem_store_t *store)
{
    pgem_linear_follow(linear, store);
    if (!linear->valid) {
        return;
    }
    uint32_t held = 0, idle = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        const int active = store->edge_active[k] == PGEM_EDGE_ACTIVE;
        if (active && !pgem_edge_in_structure(linear, store, k)) {
            pgem_linear_invalidate(linear);
            return;
        }
        if (store->edge_kind[k] == PGEM_EDGE_LOOP && linear->edge_offset[k] >= 0) {
            held++;
            idle += (uint32_t)!active;
        }
    }
    if (!linear->all_edges && idle > 0u && idle * 16u > held) {
        pgem_linear_invalidate(linear);
    }
}

int pgem_linear_on_pattern(const pgem_linear_t *linear, const pgem_store_t *store, uint32_t k)
{
    return linear->edge_offset[k] >= 0 || linear->pose_block[store->edge_from[k]] < 0 ||
           linear->pose_block[store->edge_to[k]] < 0;
}
