/* A loop closure's robust weight and state, read from the store (pgem_loop_weight and
 * pgem_loop_state are these over the instance's store, instance/graph.c). */
#include "graph/graph.h"

int pgem_store_loop_weight(const pgem_store_t *store, uint32_t index, double *weight)
{
    if (weight == NULL || index >= store->edge_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    *weight = store->edge_weight[index];
    return PGEM_OK;
}

int pgem_store_loop_state(const pgem_store_t *store, uint32_t index, pgem_loop_state_t *state)
{
    if (state == NULL || index >= store->edge_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    switch ((pgem_edge_state_t)store->edge_active[index]) {
    case PGEM_EDGE_PRUNED:
        *state = PGEM_LOOP_PRUNED;
        break;
    case PGEM_EDGE_DORMANT:
        *state = PGEM_LOOP_DORMANT;
        break;
    case PGEM_EDGE_ACTIVE:
    default:
        *state = PGEM_LOOP_ACCEPTED;
        break;
    }
    return PGEM_OK;
}
