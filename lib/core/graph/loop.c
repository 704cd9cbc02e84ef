/* A loop closure's robust weight and state, read from the graph's store. */
#include "graph/graph.h"
#include "instance.h"

int pgem_loop_weight(const pgem_t *graph, uint32_t index, double *weight)
{
    if (graph == NULL || weight == NULL || index >= graph->store.edge_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    *weight = graph->store.edge_weight[index];
    return PGEM_OK;
}

int pgem_loop_state(const pgem_t *graph, uint32_t index, pgem_loop_state_t *state)
{
    if (graph == NULL || state == NULL || index >= graph->store.edge_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    switch ((pgem_edge_state_t)graph->store.edge_active[index]) {
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
