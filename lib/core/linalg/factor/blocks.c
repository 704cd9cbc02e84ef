/* Kernels for supernodes of one pose block (b = 3 or 6 columns), the common case in sparse
 * graphs: the update of such a supernode into an ancestor as b x b block products, and the
 * factorisation of its trapezoid (the diagonal block, then each block below solved against
 * it). b is a constant at each call, so the loops unroll and vectorise; blocks are copied to
 * local arrays so the compiler knows they alias nothing. */
#include <math.h>

#include "linalg/linear.h"

/* Block row t (0 = the supernode's own block) of a one-block supernode of height h:
 * out[r * b + c] = L(t b + r, c). */
static inline void pgem_block_load(const double *values, int h, int b, int t, double *out)
{
    for (int c = 0; c < b; c++) {
        const double *column = values + pgem_factor_column(h, c) - c + (ptrdiff_t)t * b;
        for (int r = 0; r < b; r++) {
            out[r * b + c] = column[r];
        }
    }
}

/* The update of one-block supernode d (rows from position[d], the first `inside` of them in
 * target s) into s: for each block u inside and each block t from u on,
 * L_s(t, u) -= L_d(t) L_d(u)^T, only the lower part of the diagonal blocks. */
static inline void pgem_block_update_b(const pgem_factor_t *factor, int b, int d, int s, int inside,
                                       const int *map)
{
    const int first = factor->position[d], end = factor->row_start[d + 1];
    const int hd = pgem_factor_height(factor, d), hs = pgem_factor_height(factor, s);
    const double *source = factor->values + factor->value_start[d];
    double *target = factor->values + factor->value_start[s];
    const int *rows = factor->rows;
    for (int u = first; u < first + inside; u++) {
        double y[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
        pgem_block_load(source, hd, b, 1 + u - factor->row_start[d], y);
        const int column0 = map[rows[u]] * b;
        double *columns[PGEM_TANGENT_SIZE_MAX];
        for (int c = 0; c < b; c++) {
            columns[c] = target + pgem_factor_column(hs, column0 + c) - (column0 + c);
        }
        for (int t = u; t < end; t++) {
            double l[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
            pgem_block_load(source, hd, b, 1 + t - factor->row_start[d], l);
            const int row0 = map[rows[t]] * b;
            for (int c = 0; c < b; c++) {
                double sums[PGEM_TANGENT_SIZE_MAX];
                for (int r = 0; r < b; r++) {
                    double sum = 0.0;
                    for (int m = 0; m < b; m++) {
                        sum += l[r * b + m] * y[c * b + m];
                    }
                    sums[r] = sum;
                }
                double *out = columns[c] + row0;
                for (int r = (t == u ? c : 0); r < b; r++) {
                    /* cppcheck-suppress uninitvar ; sums[0 .. b) is set above */
                    out[r] -= sums[r];
                }
            }
        }
    }
}

void pgem_block_update(const pgem_factor_t *factor, int d, int s, int inside, const int *map)
{
    if (factor->block == 6) {
        pgem_block_update_b(factor, 6, d, s, inside, map);
    } else {
        pgem_block_update_b(factor, 3, d, s, inside, map);
    }
}

/* Cholesky of a one-block supernode's trapezoid of height h: the diagonal block, then every
 * block below it solved against it (L_t = A_t L_diag^-T), row by row. Returns the failing
 * column or -1. */
static inline int pgem_block_factor_b(double *values, int h, int b)
{
    double *columns[PGEM_TANGENT_SIZE_MAX];
    for (int c = 0; c < b; c++) {
        columns[c] = values + pgem_factor_column(h, c) - c; /* columns[c][r]: entry (r, c) */
    }
    double diagonal[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX]; /* [r * b + c], r >= c */
    for (int c = 0; c < b; c++) {
        double pivot = columns[c][c];
        for (int m = 0; m < c; m++) {
            pivot -= diagonal[c * b + m] * diagonal[c * b + m];
        }
        if (!(pivot > 0.0) || !isfinite(pivot)) {
            return c;
        }
        const double root = sqrt(pivot);
        diagonal[c * b + c] = root;
        columns[c][c] = root;
        for (int r = c + 1; r < b; r++) {
            double sum = columns[c][r];
            for (int m = 0; m < c; m++) {
                sum -= diagonal[r * b + m] * diagonal[c * b + m];
            }
            diagonal[r * b + c] = sum / root;
            columns[c][r] = diagonal[r * b + c];
        }
    }
    for (int row = b; row < h; row++) {
        double x[PGEM_TANGENT_SIZE_MAX];
        for (int c = 0; c < b; c++) {
            double sum = columns[c][row];
            for (int m = 0; m < c; m++) {
                sum -= x[m] * diagonal[c * b + m];
            }
            x[c] = sum / diagonal[c * b + c];
            columns[c][row] = x[c];
        }
    }
    return -1;
}

int pgem_block_factor(double *values, int height, int b)
{
    return b == 6 ? pgem_block_factor_b(values, height, 6) : pgem_block_factor_b(values, height, 3);
}
