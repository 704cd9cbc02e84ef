/* y = H x with the assembled normal equations (the values the factorisation reads, damping
 * included), over the block pattern of H's upper triangle; no allocation. */
#include <string.h>

#include "internal.h"

/* One block column of H for block size b (a constant at each call). */
static inline void pgem_multiply_column(const pgem_linear_t *linear, int b, int column,
                                        const double *x, double *y)
{
    const int first = linear->block_colptr[column];
    const int count = linear->block_colptr[column + 1] - first;
    const int *rows = linear->block_rows + first;
    for (int c = 0; c < b; c++) {
        const int j = column * b + c;
        const double *values = linear->upper_values + linear->upper_colptr[j];
        for (int q = 0; q < count; q++) {
            const int base = rows[q] * b;
            for (int r = 0; r < b; r++) {
                const double h = values[q * b + r]; /* H(base + r, j), base + r < j */
                y[base + r] += h * x[j];
                y[j] += h * x[base + r];
            }
        }
        const double *diagonal = values + (ptrdiff_t)count * b; /* H(column * b + r, j), r <= c */
        for (int r = 0; r < c; r++) {
            y[column * b + r] += diagonal[r] * x[j];
            y[j] += diagonal[r] * x[column * b + r];
        }
        y[j] += diagonal[c] * x[j];
    }
}

void pgem_linear_multiply(const pgem_t *graph, const double *x, double *y)
{
    const pgem_linear_t *linear = &graph->linear;
    memset(y, 0, (size_t)linear->scalar_count * sizeof(double));
    for (int column = 0; column < linear->block_count; column++) {
        if (linear->block == 6) {
            pgem_multiply_column(linear, 6, column, x, y);
        } else {
            pgem_multiply_column(linear, 3, column, x, y);
        }
    }
}
