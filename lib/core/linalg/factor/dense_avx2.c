/* The AVX2 + FMA build of the dense kernels (x86-64 hosts; compiled with -mavx2 -mfma
 * -ffp-contract=fast, chosen at init when the CPU has them): micro-tiles of 8 x 6. */
#include "dense.h"

#define PGEM_DENSE_NAME(name) pgem_dense_##name##_avx2
#define PGEM_VW 4
#define PGEM_MV 2
#define PGEM_NR 6
#include "dense_kernel.h"

const pgem_dense_ops_t pgem_dense_avx2 = {pgem_dense_update_avx2, pgem_dense_factor_avx2, "avx2"};
