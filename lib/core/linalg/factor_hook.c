/* The figures of the factor for the test and benchmark hook on the factorisation
 * (hooks/factor_hook.h, whose calls on an instance are instance/factor_hook.c). Nothing else
 * of the core calls it, so a program that does not (firmware, the tools) links none of it. */
#include "hooks/factor_hook.h"
#include "linalg/linear.h"

void pgem_linear_hook_figures(const pgem_linear_t *linear, pgem_factor_hook_figures_t *figures)
{
    const pgem_factor_t *factor = &linear->factor;
    static const char *const orderings[] = {"amd", "nested", "orderer"};
    figures->unknowns = linear->scalar_count;
    figures->exact_nonzeros = factor->exact_nonzeros;
    figures->exact_flops = factor->exact_flops;
    figures->flops = factor->flops;
    figures->supernodes = factor->super_count;
    figures->kernels = linear->dense->name;
    figures->ordering = orderings[factor->ordering];
    figures->amd_flops = factor->amd_flops;
    figures->nested_flops = factor->nested_flops;
    figures->orderer_flops = factor->orderer_flops;
}
