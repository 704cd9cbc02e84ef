/* FOR TESTS AND BENCHMARKS ONLY: a narrow window on an instance's factorisation, for
 * tools/bench/bench_factor.c (pgem-bench-factor), which times the stages that pgem_optimize
 * runs together and reports the factor's size. Not installed, not part of the API (include/pgem),
 * no stable interface: it follows linalg (instance/factor_hook.c, linalg/factor_hook.c). A program
 * that uses it puts lib/core/hooks, and nothing else of lib/core, on its include path. */
#ifndef PGEM_FACTOR_HOOK_H
#define PGEM_FACTOR_HOOK_H

#include "pgem/pgem.h"

#ifdef __cplusplus
extern "C" {
#endif

/* What the last analysis and factorisation made (the values the factor stores are
 * pgem_memory_use's factor_nonzeros). */
typedef struct pgem_factor_hook_figures {
    int unknowns;           /* scalar unknowns: free poses times 3 or 6 */
    int exact_nonzeros;     /* nonzeros of the exact pattern of L */
    double exact_flops;     /* sum of squared scalar column counts (CHOLMOD's measure) */
    double flops;           /* multiply-adds of one numeric factorisation, zeros included */
    int supernodes;
    const char *kernels;    /* the dense kernels this CPU runs: "portable", "avx2", "avx512" */
    const char *ordering;   /* the ordering chosen: "amd", "nested" or "orderer" */
    double amd_flops;       /* exact_flops under each ordering the analysis measured, */
    double nested_flops;    /* -1 if not tried */
    double orderer_flops;
} pgem_factor_hook_figures_t;

/* Forgets the symbolic analysis, so that the next pgem_analyze makes it anew (orders, analyses)
 * rather than keeping it for an unchanged graph. */
void pgem_factor_hook_forget(pgem_t *graph);
/* Assembles H and -b at the current estimate and weights (after an analysis); returns the
 * weighted chi2. */
double pgem_factor_hook_assemble(pgem_t *graph);
/* One numeric factorisation of the assembled H (on the instance's executor): PGEM_OK, or the
 * error with pgem_last_error set. */
int pgem_factor_hook_factor(pgem_t *graph);
/* The figures of the current analysis and factor. */
void pgem_factor_hook_figures(const pgem_t *graph, pgem_factor_hook_figures_t *figures);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_FACTOR_HOOK_H */
