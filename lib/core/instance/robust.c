/* The public calls of the robust layer (pgem/robust.h) over an instance: the argument check,
 * then the layer's own calls on the parts they work on (pgem_robust_parts), so the robust
 * layer itself never sees struct pgem (docs/design/core-layers.md). */
#include <string.h>

#include "instance.h"

int pgem_robust_optimize(pgem_t *graph, const pgem_robust_options_t *options,
                         const pgem_solve_options_t *solve, pgem_robust_summary_t *summary)
{
    if (graph == NULL) {
        if (summary != NULL) { /* as pgem_robust_solve starts it */
            memset(summary, 0, sizeof *summary);
            summary->first_non_finite = UINT32_MAX;
        }
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_robust_parts_t parts = pgem_robust_parts(graph);
    return pgem_robust_solve(&parts, options, solve, summary);
}

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
