/* The test and benchmark hook on the factorisation (hooks/factor_hook.h): the stages of a
 * solve one at a time, and the figures of the factor. Nothing else of the core calls it, so
 * a program that does not (firmware, the tools) links none of it. */
#include "hooks/factor_hook.h"
#include "linalg/linear.h"

void pgem_factor_hook_forget(pgem_t *graph)
{
    pgem_linear_invalidate(graph->linear);
}

double pgem_factor_hook_assemble(pgem_t *graph)
{
    return pgem_linear_assemble(graph);
}

int pgem_factor_hook_factor(pgem_t *graph)
{
    return pgem_linear_factor(graph);
}

void pgem_factor_hook_figures(const pgem_t *graph, pgem_factor_hook_figures_t *figures)
{
    const pgem_factor_t *factor = &graph->linear->factor;
    static const char *const orderings[] = {"amd", "nested", "orderer"};
    figures->unknowns = graph->linear->scalar_count;
    figures->exact_nonzeros = factor->exact_nonzeros;
    figures->exact_flops = factor->exact_flops;
    figures->flops = factor->flops;
    figures->supernodes = factor->super_count;
    figures->kernels = graph->linear->dense->name;
    figures->ordering = orderings[factor->ordering];
    figures->amd_flops = factor->amd_flops;
    figures->nested_flops = factor->nested_flops;
    figures->orderer_flops = factor->orderer_flops;
}
