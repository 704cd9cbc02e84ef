/* The public calls that read the graph layer, over the instance's store: thin wrappers, so the
 * graph layer itself never sees struct pgem (docs/design/core-layers.md). */
#include "instance.h"

int pgem_loop_weight(const pgem_t *graph, uint32_t index, double *weight)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_loop_weight(&graph->store, index, weight);
}

int pgem_loop_state(const pgem_t *graph, uint32_t index, pgem_loop_state_t *state)
{
    return graph == NULL ? PGEM_ERR_INVALID_ARGUMENT
                         : pgem_store_loop_state(&graph->store, index, state);
}
