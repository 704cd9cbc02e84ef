/* Numeric block up-looking Cholesky H = L L^T into the preallocated L, and the triangular
 * solves with it; no allocation. Block row K of L comes from CSparse's cs_ereach on the block
 * elimination tree; every operation is on dense b x b pose blocks. L's values are stored by
 * scalar column: in column J*b+c the diagonal block's rows c..b-1 come first, then b rows for
 * each off-diagonal block, in increasing block row order. Row indices are kept per block
 * (factor_block_rows), not per scalar: a third of the factor's memory. */
#include <math.h>
#include <string.h>

#include "internal.h"

/* Index of element (r, c), r >= c, of the diagonal block of column I. */
static int pgem_l_diag(const pgem_linear_t *linear, int column_block, int r, int c)
{
    return linear->factor_colptr[column_block * linear->block + c] + (r - c);
}

/* Scatters column block K of H's upper triangle: off-diagonal blocks into their accumulators
 * (row-major, rows of block I, columns of block K), the diagonal block's lower triangle into
 * diagonal (row-major). */
static inline void pgem_scatter_column(pgem_linear_t *linear, int b, int k, double *diagonal)
{
    const int first = linear->block_colptr[k];
    const int count = linear->block_colptr[k + 1] - first;
    for (int c = 0; c < b; c++) {
        const double *column = linear->upper_values + linear->upper_colptr[k * b + c];
        for (int q = 0; q < count; q++) {
            double *target = linear->block_work + (size_t)linear->block_rows[first + q] * (size_t)(b * b);
            for (int r = 0; r < b; r++) {
                target[r * b + c] = column[q * b + r];
            }
        }
        for (int r = 0; r <= c; r++) {
            diagonal[c * b + r] = column[count * b + r]; /* lower triangle: all the factor reads */
        }
    }
}

/* Y = L_II^-1 X in place (X row-major b x b, rows of block I). */
static inline void pgem_solve_diagonal(const pgem_linear_t *linear, int b, int i, double *x)
{
    const double *values = linear->factor_values;
    for (int r = 0; r < b; r++) {
        double inverse = 1.0 / values[pgem_l_diag(linear, i, r, r)];
        for (int c = 0; c < b; c++) {
            double sum = x[r * b + c];
            for (int m = 0; m < r; m++) {
                sum -= values[pgem_l_diag(linear, i, r, m)] * x[m * b + c];
            }
            x[r * b + c] = sum * inverse;
        }
    }
}

/* X_R -= L_RI Y for every block row R already in column I, then stores L(K, I) = Y^T.
 * b is passed as a constant by the callers so the compiler specialises the loops. Y is copied
 * to the stack and each row of X_R is accumulated in a local array: the compiler then knows
 * they do not alias L or each other, keeps them in registers and vectorises the row update.
 * Every element still subtracts its products in the order m = 0 .. b-1. */
static inline void pgem_eliminate(pgem_linear_t *linear, int b, int i, int k, const double *y_in)
{
    double *values = linear->factor_values;
    const int filled = linear->fill_next[i];
    int *block_rows = linear->factor_block_rows + linear->factor_block_colptr[i];
    int base[PGEM_TANGENT_SIZE_MAX]; /* start of the off-diagonal rows in column i*b+c */
    double y[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    for (int c = 0; c < b; c++) {
        base[c] = linear->factor_colptr[i * b + c] + (b - c);
    }
    for (int q = 0; q < b * b; q++) {
        y[q] = y_in[q];
    }
    for (int slot = 0; slot < filled; slot++) {
        double *target = linear->block_work + (size_t)block_rows[slot] * (size_t)(b * b);
        double l[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX]; /* l[r * b + m] = L_RI(r, m) */
        for (int m = 0; m < b; m++) {
            const double *l_column = values + base[m] + (ptrdiff_t)slot * b;
            for (int r = 0; r < b; r++) {
                l[r * b + m] = l_column[r];
            }
        }
        for (int r = 0; r < b; r++) {
            double row[PGEM_TANGENT_SIZE_MAX];
            for (int c = 0; c < b; c++) {
                row[c] = target[r * b + c];
            }
            for (int m = 0; m < b; m++) {
                const double factor = l[r * b + m];
                for (int c = 0; c < b; c++) {
                    /* cppcheck-suppress uninitvar ; y[0 .. b*b) is copied above (b >= 3) */
                    row[c] -= factor * y[m * b + c];
                }
            }
            for (int c = 0; c < b; c++) {
                target[r * b + c] = row[c];
            }
        }
    }
    for (int c = 0; c < b; c++) {
        /* cppcheck-suppress uninitvar ; base[0 .. b) is set above */
        int first = base[c] + filled * b;
        for (int r = 0; r < b; r++) {
            values[first + r] = y[c * b + r];
        }
    }
    block_rows[filled] = k;
    linear->fill_next[i] = filled + 1;
}

/* D -= Y^T Y, lower triangle only (the part pgem_factor_diagonal reads). */
static inline void pgem_downdate(int b, const double *y, double *diagonal)
{
    for (int r = 0; r < b; r++) {
        for (int c = 0; c <= r; c++) {
            double sum = 0.0;
            for (int m = 0; m < b; m++) {
                sum += y[m * b + r] * y[m * b + c];
            }
            diagonal[r * b + c] -= sum;
        }
    }
}

/* Dense Cholesky of the b x b diagonal block into L; returns the failing row or -1. */
static int pgem_factor_diagonal(pgem_linear_t *linear, int k, const double *diagonal)
{
    const int b = linear->block;
    double *values = linear->factor_values;
    for (int c = 0; c < b; c++) {
        double pivot = diagonal[c * b + c];
        for (int m = 0; m < c; m++) {
            double l = values[pgem_l_diag(linear, k, c, m)];
            pivot -= l * l;
        }
        if (!(pivot > 0.0) || !isfinite(pivot)) {
            return c;
        }
        double root = sqrt(pivot);
        values[pgem_l_diag(linear, k, c, c)] = root;
        for (int r = c + 1; r < b; r++) {
            double sum = diagonal[r * b + c];
            for (int m = 0; m < c; m++) {
                sum -= values[pgem_l_diag(linear, k, r, m)] * values[pgem_l_diag(linear, k, c, m)];
            }
            values[pgem_l_diag(linear, k, r, c)] = sum / root;
        }
    }
    return -1;
}

static int pgem_not_positive_definite(pgem_t *graph, int unknown)
{
    const int block = unknown / graph->linear.block;
    pgem_message_clear(graph);
    pgem_message_text(graph, "normal equations not positive definite at unknown ");
    pgem_message_i64(graph, unknown);
    for (uint32_t p = 0; p < graph->pose_count; p++) {
        if (graph->linear.pose_block[p] == block) {
            pgem_message_text(graph, " (pose ");
            pgem_message_u64(graph, graph->pose_id[p]);
            pgem_message_text(graph, ")");
        }
    }
    pgem_message_text(graph, ": is the information of its edges too small or degenerate?");
    return PGEM_ERR_NOT_POSITIVE_DEFINITE;
}

/* The factorisation for block size b (called with the constants 3 and 6). */
static inline int pgem_factor_blocks(pgem_t *graph, int b)
{
    pgem_linear_t *linear = &graph->linear;
    const int blocks = linear->block_count;
    cs_di pattern = {linear->block_colptr[blocks], blocks, blocks, linear->block_colptr,
                     linear->block_rows, NULL, -1};
    double diagonal[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    memset(linear->fill_next, 0, (size_t)blocks * sizeof(int));
    for (int k = 0; k < blocks; k++) {
        int top = cs_di_ereach(&pattern, k, linear->block_parent, linear->reach_stack,
                               linear->reach_mark);
        for (int p = top; p < blocks; p++) {
            memset(linear->block_work + (size_t)linear->reach_stack[p] * (size_t)(b * b), 0,
                   (size_t)(b * b) * sizeof(double));
        }
        pgem_scatter_column(linear, b, k, diagonal);
        for (int p = top; p < blocks; p++) {
            int i = linear->reach_stack[p];
            double *y = linear->block_work + (size_t)i * (size_t)(b * b);
            pgem_solve_diagonal(linear, b, i, y);
            pgem_eliminate(linear, b, i, k, y);
            pgem_downdate(b, y, diagonal);
        }
        int bad = pgem_factor_diagonal(linear, k, diagonal);
        if (bad >= 0) {
            return pgem_not_positive_definite(graph, k * b + bad);
        }
    }
    return PGEM_OK;
}

int pgem_linear_factor(pgem_t *graph)
{
    return graph->linear.block == 6 ? pgem_factor_blocks(graph, 6) : pgem_factor_blocks(graph, 3);
}

/* x = L^-1 x, column by column. */
static inline void pgem_lower_solve(const pgem_linear_t *linear, int b, double *x)
{
    for (int column = 0; column < linear->block_count; column++) {
        const int *rows = linear->factor_block_rows + linear->factor_block_colptr[column];
        const int count = linear->factor_block_colptr[column + 1] - linear->factor_block_colptr[column];
        for (int c = 0; c < b; c++) {
            const double *l = linear->factor_values + linear->factor_colptr[column * b + c];
            const double value = x[column * b + c] / l[0];
            x[column * b + c] = value;
            for (int r = c + 1; r < b; r++) {
                x[column * b + r] -= l[r - c] * value;
            }
            const double *off = l + (b - c);
            for (int q = 0; q < count; q++) {
                double *target = x + (size_t)rows[q] * (size_t)b;
                for (int r = 0; r < b; r++) {
                    target[r] -= off[q * b + r] * value;
                }
            }
        }
    }
}

/* x = L^-T x, column by column from the last. */
static inline void pgem_upper_solve(const pgem_linear_t *linear, int b, double *x)
{
    for (int column = linear->block_count - 1; column >= 0; column--) {
        const int *rows = linear->factor_block_rows + linear->factor_block_colptr[column];
        const int count = linear->factor_block_colptr[column + 1] - linear->factor_block_colptr[column];
        for (int c = b - 1; c >= 0; c--) {
            const double *l = linear->factor_values + linear->factor_colptr[column * b + c];
            double sum = x[column * b + c];
            for (int r = c + 1; r < b; r++) {
                sum -= l[r - c] * x[column * b + r];
            }
            const double *off = l + (b - c);
            for (int q = 0; q < count; q++) {
                const double *source = x + (size_t)rows[q] * (size_t)b;
                for (int r = 0; r < b; r++) {
                    sum -= off[q * b + r] * source[r];
                }
            }
            x[column * b + c] = sum / l[0];
        }
    }
}

/* Solves H step = rhs in place (permuted order): L y = rhs, then L^T step = y. */
void pgem_linear_solve(pgem_t *graph, double *step)
{
    const pgem_linear_t *linear = &graph->linear;
    if (linear->block == 6) {
        pgem_lower_solve(linear, 6, step);
        pgem_upper_solve(linear, 6, step);
    } else {
        pgem_lower_solve(linear, 3, step);
        pgem_upper_solve(linear, 3, step);
    }
}
