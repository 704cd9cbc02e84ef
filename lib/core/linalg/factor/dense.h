/* Dense kernels of the supernodal factorisation: the update product of a supernode into an
 * ancestor (or of a supernode's left columns into its own panel) and the dense Cholesky of a
 * supernode's trapezoid. Several builds of the same C source exist (linalg/factor/dense_kernel.h):
 * a portable one, and on x86-64 hosts AVX2+FMA and AVX-512 ones chosen at init by the CPU. */
#ifndef PGEM_DENSE_H
#define PGEM_DENSE_H

#include <stddef.h>

/* The k blocking of every product. Fixed for every build and instance size, so an entry's
 * sums are split the same way wherever it is computed (worker, CPU, capacity). */
#define PGEM_DENSE_KC 128

/* Columns of a supernode's panel in its dense factorisation (left-looking, blocked), and of
 * the outer panels wider supernodes are factorised in. */
#define PGEM_DENSE_PANEL 64
#define PGEM_DENSE_OUTER 256

/* Rows plus columns of the largest micro-tile among the builds compiled in: a product of k
 * columns needs at least min(k, PGEM_DENSE_KC) times this many doubles of workspace. */
#ifdef PGEM_DENSE_X86
#define PGEM_DENSE_TILE_SPAN 32
#else
#define PGEM_DENSE_TILE_SPAN 8
#endif

/* C = A A(0:n, :)^T, lower part (i >= j), subtracted from a target trapezoid:
 * A(i, p) = source[p * step - p (p - 1) / 2 + i] (a column range of a trapezoid: each column
 * starts one row further down; step is the trapezoid's height minus the first column's index
 * minus 1), 0 <= i < m, 0 <= p < k, n <= m.
 * Row i of C is the target's local row row0 + i when rows is NULL, else
 * map[rows[i / block]] * block + i % block; column j likewise (the columns are the first n
 * rows). The target's entry (r, c) is target[c h - c (c - 1) / 2 + r - c], h its height. */
typedef struct pgem_dense_update {
    const double *source;  /* A(0, 0) */
    ptrdiff_t step;        /* see above */
    int m;                 /* rows of A and C */
    int n;                 /* columns of C */
    int k;                 /* columns of A */
    double *target;        /* first value of the target trapezoid */
    int target_height;     /* its rows h */
    int row0;              /* rows == NULL: C's rows are the target's row0, row0 + 1, ... */
    const int *rows;       /* else the block rows of A's row blocks */
    const int *map;        /* block row -> block position inside the target */
    int block;             /* rows per block */
} pgem_dense_update_t;

/* One build of the kernels. */
typedef struct pgem_dense_ops {
    /* Subtracts the update's product from its target; work holds work_doubles doubles. */
    void (*update)(const pgem_dense_update_t *update, double *work, size_t work_doubles);
    /* Dense Cholesky in place of the first `width` columns of a trapezoid of `height` rows
     * (the layout of pgem_dense_update_t's target); returns the local column of the first
     * pivot that is not positive and finite, or -1. */
    int (*factor)(double *values, int height, int width, double *work, size_t work_doubles);
    const char *name;      /* "portable", "avx2", "avx512" */
} pgem_dense_ops_t;

/* The fastest build this CPU runs (the portable one off x86-64 hosts). */
const pgem_dense_ops_t *pgem_dense_select(void);

extern const pgem_dense_ops_t pgem_dense_portable;
#ifdef PGEM_DENSE_X86
extern const pgem_dense_ops_t pgem_dense_avx2;
extern const pgem_dense_ops_t pgem_dense_avx512;
#endif

#endif /* PGEM_DENSE_H */
