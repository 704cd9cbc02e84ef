/* The test and benchmark hook on the factorisation (hooks/factor_hook.h) over an instance's
 * linear system: the stages of a solve one at a time, and the figures of the factor
 * (linalg/factor_hook.c). Nothing else of the core calls it, so a program that does not
 * (firmware, the tools) links none of it. */
#include "hooks/factor_hook.h"
#include "instance.h"

void pgem_factor_hook_forget(pgem_t *graph)
{
    pgem_linear_invalidate(graph->linear);
}

double pgem_factor_hook_assemble(pgem_t *graph)
{
    return pgem_linear_assemble(graph->linear, &graph->store);
}

int pgem_factor_hook_factor(pgem_t *graph)
{
    return pgem_linear_factor(graph->linear, &graph->store, &graph->executor, graph->message);
}

void pgem_factor_hook_figures(const pgem_t *graph, pgem_factor_hook_figures_t *figures)
{
    pgem_linear_hook_figures(graph->linear, figures);
}
