/* The portable build of the dense kernels (linalg/factor/dense_kernel.h), and the choice of the
 * build the CPU runs fastest. Two doubles per vector where the compiler has vectors for them (SSE2,
 * NEON; GCC and clang vector extensions), plain scalar code elsewhere (the Cortex-M7). */
#include "dense.h"

#define PGEM_DENSE_NAME(name) pgem_dense_##name##_portable
#if defined(__GNUC__) && (defined(__SSE2__) || defined(__ARM_NEON) || defined(__aarch64__))
#define PGEM_VW 2
#define PGEM_MV 2
#define PGEM_NR 4
#else
#define PGEM_VW 1
#define PGEM_MV 4
#define PGEM_NR 2
#endif
#include "dense_kernel.h"

const pgem_dense_ops_t pgem_dense_portable = {pgem_dense_update_portable,
                                              pgem_dense_factor_portable, "portable"};

const pgem_dense_ops_t *pgem_dense_select(void)
{
#ifdef PGEM_DENSE_X86
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) {
        return &pgem_dense_avx512;
    }
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
        return &pgem_dense_avx2;
    }
#endif
    return &pgem_dense_portable;
}
