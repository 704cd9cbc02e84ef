/* y = H x with the assembled normal equations (the values the factorisation reads, damping
 * included), over the block pattern of H's lower triangle (pgem_lower_column); no allocation. */
#include <string.h>

#include "linalg/linear.h"

/* One block column of H for block size b (a constant at each call). */
static inline void pgem_multiply_column(const pgem_linear_t *linear, int b, int column,
                                        const double *x, double *y)
{
    const int first = linear->block_colptr[column];
    const int count = linear->block_colptr[column + 1] - first;
    const int *rows = linear->block_rows + first;
    const int base = column * b;
    for (int c = 0; c < b; c++) {
        const int j = base + c;
        const double *values = linear->lower_values + pgem_lower_column(linear, column, c);
        y[j] += values[0] * x[j];
        for (int r = c + 1; r < b; r++) { /* H(base + r, j) */
            y[base + r] += values[r - c] * x[j];
            y[j] += values[r - c] * x[base + r];
        }
        const double *off = values + (b - c);
        for (int q = 0; q < count; q++) {
            const int row = rows[q] * b;
            for (int r = 0; r < b; r++) {
                const double h = off[q * b + r]; /* H(row + r, j), row + r > j */
                y[row + r] += h * x[j];
                y[j] += h * x[row + r];
            }
        }
    }
}

void pgem_linear_multiply(const pgem_linear_t *linear, const double *x, double *y)
{
    memset(y, 0, (size_t)linear->scalar_count * sizeof(double));
    for (int column = 0; column < linear->block_count; column++) {
        if (linear->block == 6) {
            pgem_multiply_column(linear, 6, column, x, y);
        } else {
            pgem_multiply_column(linear, 3, column, x, y);
        }
    }
}
