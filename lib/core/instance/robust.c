/* The public calls of the robust layer that need only the graph and the linear system, over
 * the instance's parts: thin wrappers, as instance/graph.c's (docs/design/core-layers.md). */
#include "instance.h"

void pgem_robust_reset(pgem_t *graph)
{
    if (graph != NULL) {
        pgem_robust_reset_loops(graph->linear, &graph->store);
    }
}

uint32_t pgem_robust_held_parts(const pgem_t *graph, pgem_id_t *ids, uint32_t capacity)
{
    return graph != NULL ? pgem_robust_list_parts(&graph->store, ids, capacity) : 0u;
}
