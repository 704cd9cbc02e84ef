/* The AVX-512 build of the dense kernels (x86-64 hosts; compiled with -mavx512f -mfma
 * -ffp-contract=fast, chosen at init when the CPU has it): micro-tiles of 24 x 8. */
#include "dense.h"

#define PGEM_DENSE_NAME(name) pgem_dense_##name##_avx512
#define PGEM_VW 8
#define PGEM_MV 3
#define PGEM_NR 8
#include "dense_kernel.h"

const pgem_dense_ops_t pgem_dense_avx512 = {pgem_dense_update_avx512, pgem_dense_factor_avx512,
                                            "avx512"};
