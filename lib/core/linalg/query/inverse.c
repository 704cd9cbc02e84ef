/* The inverse of H on the factor's pattern (the sparse-inverse recursion of Takahashi et al.),
 * written over L in place, and the marginal covariance of two poses read from it. For block
 * column J with off-diagonal block rows R (a clique of the stored pattern, relaxed
 * amalgamation's zeros included, so every block of H^-1 between two of them is on it; the
 * columns are read through pgem_factor_column_view, whatever their supernode):
 *     Y = L_RJ L_JJ^-1,   Z_RJ = -Z_RR Y,   Z_JJ = (L_JJ L_JJ^T)^-1 - Y^T Z_RJ,
 * from the last column to the first. After it, L is gone: the next solve factors again. */
#include <string.h>

#include "linalg/linear.h"

/* Off-diagonal block q of a column into a row-major b x b array. */
static inline void pgem_load_block(const pgem_factor_column_t *column, int b, int q, double *out)
{
    for (int c = 0; c < b; c++) {
        const double *values = column->base[c] + (b - c) + (ptrdiff_t)q * b;
        for (int r = 0; r < b; r++) {
            out[r * b + c] = values[r];
        }
    }
}

/* The symmetric diagonal block of a column, whole, into a row-major b x b array. */
static inline void pgem_load_diagonal(const pgem_factor_column_t *column, int b, double *out)
{
    for (int c = 0; c < b; c++) {
        for (int r = c; r < b; r++) {
            out[r * b + c] = out[c * b + r] = column->base[c][r - c];
        }
    }
}

/* Off-diagonal block q of the column -= Z X (transpose 0) or Z^T X (transpose 1), Z and X
 * row-major b x b. */
static inline void pgem_subtract(int b, const double *z, int transpose, const double *x,
                                 const pgem_factor_column_t *column, int q)
{
    double product[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    for (int r = 0; r < b; r++) {
        double row[PGEM_TANGENT_SIZE_MAX] = {0};
        for (int m = 0; m < b; m++) {
            const double factor = transpose ? z[m * b + r] : z[r * b + m];
            for (int c = 0; c < b; c++) {
                row[c] += factor * x[m * b + c];
            }
        }
        for (int c = 0; c < b; c++) {
            product[r * b + c] = row[c];
        }
    }
    for (int c = 0; c < b; c++) {
        double *values = column->base[c] + (b - c) + (ptrdiff_t)q * b;
        for (int r = 0; r < b; r++) {
            values[r] -= product[r * b + c];
        }
    }
}

/* One block column of the recursion for block size b (a constant at each call). Y (row-major
 * b x b per block row) goes to the shared region (one block per pose), Z_RJ is
 * accumulated over L_RJ once Y is taken from it. */
static inline void pgem_invert_column(pgem_linear_t *linear, int b, int column)
{
    const int bb = b * b;
    const pgem_factor_column_t self = pgem_factor_column_view(&linear->factor, column);
    const int count = self.count;
    double *y = linear->factor.shared; /* [count] blocks: fewer than one per pose */
    double inverse[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    /* L_JJ^-1, lower triangular */
    for (int c = 0; c < b; c++) {
        inverse[c * b + c] = 1.0 / self.base[c][0];
        for (int r = c + 1; r < b; r++) {
            double sum = 0.0;
            for (int m = c; m < r; m++) {
                sum += self.base[m][r - m] * inverse[m * b + c];
            }
            inverse[r * b + c] = -sum / self.base[r][0];
        }
    }
    for (int q = 0; q < count; q++) {
        double l[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
        pgem_load_block(&self, b, q, l);
        double *yq = y + (size_t)q * (size_t)bb;
        for (int r = 0; r < b; r++) {
            for (int c = 0; c < b; c++) {
                double sum = 0.0;
                for (int m = c; m < b; m++) {
                    sum += l[r * b + m] * inverse[m * b + c];
                }
                yq[r * b + c] = sum;
            }
        }
    }
    for (int q = 0; q < count; q++) {
        for (int c = 0; c < b; c++) {
            memset(self.base[c] + (b - c) + (ptrdiff_t)q * b, 0, (size_t)b * sizeof(double));
        }
    }
    for (int q = 0; q < count; q++) {
        const int row = pgem_factor_column_row(&self, column, q);
        const pgem_factor_column_t inner = pgem_factor_column_view(&linear->factor, row);
        double block[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
        pgem_load_diagonal(&inner, b, block);
        pgem_subtract(b, block, 0, y + (size_t)q * (size_t)bb, &self, q);
        const int inner_count = inner.count;
        int s = 0;
        for (int p = q + 1; p < count; p++) {
            const int row_p = pgem_factor_column_row(&self, column, p);
            while (s < inner_count && pgem_factor_column_row(&inner, row, s) < row_p) {
                s++;
            }
            if (s == inner_count) {
                break;
            }
            if (pgem_factor_column_row(&inner, row, s) != row_p) {
                continue; /* unreachable: the rows of a column of the filled pattern form a clique */
            }
            pgem_load_block(&inner, b, s, block); /* Z_{R_p, R_q} */
            pgem_subtract(b, block, 1, y + (size_t)p * (size_t)bb, &self, q);
            pgem_subtract(b, block, 0, y + (size_t)q * (size_t)bb, &self, p);
        }
    }
    /* Z_JJ = L^-T L^-1 - Y^T Z_RJ, lower triangle */
    double diagonal[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    for (int r = 0; r < b; r++) {
        for (int c = 0; c <= r; c++) {
            double sum = 0.0;
            for (int m = r; m < b; m++) {
                sum += inverse[m * b + r] * inverse[m * b + c];
            }
            diagonal[r * b + c] = sum;
        }
    }
    for (int q = 0; q < count; q++) {
        double zq[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
        pgem_load_block(&self, b, q, zq);
        const double *yq = y + (size_t)q * (size_t)bb;
        for (int r = 0; r < b; r++) {
            for (int c = 0; c <= r; c++) {
                double sum = 0.0;
                for (int m = 0; m < b; m++) {
                    sum += yq[m * b + r] * zq[m * b + c];
                }
                diagonal[r * b + c] -= sum;
            }
        }
    }
    for (int c = 0; c < b; c++) {
        for (int r = c; r < b; r++) {
            self.base[c][r - c] = diagonal[r * b + c];
        }
    }
}

void pgem_linear_invert(pgem_linear_t *linear)
{
    linear->covariance = PGEM_COVARIANCE_NONE;
    for (int column = linear->block_count - 1; column >= 0; column--) {
        if (linear->block == 6) {
            pgem_invert_column(linear, 6, column);
        } else {
            pgem_invert_column(linear, 3, column);
        }
    }
}

/* Position of block row `row` among column's off-diagonal blocks, or -1. */
static int pgem_inverse_position(const pgem_factor_column_t *view, int column, int row)
{
    if (row <= column) {
        return -1;
    }
    if (row <= column + view->inside) {
        return row - column - 1;
    }
    int low = 0;
    int high = view->count - view->inside - 1;
    while (low <= high) {
        const int middle = low + (high - low) / 2;
        const int value = view->below[middle];
        if (value < row) {
            low = middle + 1;
        } else if (value > row) {
            high = middle - 1;
        } else {
            return view->inside + middle;
        }
    }
    return -1;
}

/* out += A Z_diag A^T for the symmetric diagonal block of column D (A: b x b row-major). */
static void pgem_add_diagonal_form(pgem_linear_t *linear, int b, int column, const double *a,
                                   double *out)
{
    const pgem_factor_column_t view = pgem_factor_column_view(&linear->factor, column);
    double az[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    for (int r = 0; r < b; r++) {
        for (int c = 0; c < b; c++) {
            double sum = 0.0;
            for (int m = 0; m < b; m++) {
                const double z = m >= c ? view.base[c][m - c] : view.base[m][c - m];
                sum += a[r * b + m] * z;
            }
            az[r * b + c] = sum;
        }
    }
    for (int r = 0; r < b; r++) {
        for (int c = 0; c < b; c++) {
            double sum = 0.0;
            for (int m = 0; m < b; m++) {
                sum += az[r * b + m] * a[c * b + m];
            }
            out[r * b + c] += sum;
        }
    }
}

void pgem_linear_marginal_diagonal(pgem_linear_t *linear, uint32_t from, uint32_t to,
                                   const double *a_from, const double *a_to, double *out)
{
    const int b = linear->block;
    const int block_from = linear->pose_block[from], block_to = linear->pose_block[to];
    memset(out, 0, (size_t)(b * b) * sizeof(double));
    if (block_from >= 0) {
        pgem_add_diagonal_form(linear, b, block_from, a_from, out);
    }
    if (block_to >= 0) {
        pgem_add_diagonal_form(linear, b, block_to, a_to, out);
    }
}

int pgem_linear_marginal_inverse(pgem_linear_t *linear, uint32_t from, uint32_t to,
                                 const double *a_from, const double *a_to, double *out)
{
    const int b = linear->block;
    const int block_from = linear->pose_block[from], block_to = linear->pose_block[to];
    pgem_linear_marginal_diagonal(linear, from, to, a_from, a_to, out); /* the two own terms */
    if (block_from < 0 || block_to < 0) {
        return PGEM_OK;
    }
    /* the cross term A_f Z_ft A_t^T and its transpose; Z_ft is stored under the lower block */
    const int low = block_from < block_to ? block_from : block_to;
    const int high = block_from < block_to ? block_to : block_from;
    const pgem_factor_column_t view = pgem_factor_column_view(&linear->factor, low);
    const int q = pgem_inverse_position(&view, low, high);
    if (q < 0) {
        return PGEM_ERR_INVALID_ARGUMENT; /* not on the pattern: the caller solves instead */
    }
    const double *a_low = block_from < block_to ? a_from : a_to;
    const double *a_high = block_from < block_to ? a_to : a_from;
    double az[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0}; /* A_high Z_{high,low} */
    for (int r = 0; r < b; r++) {
        for (int c = 0; c < b; c++) {
            double sum = 0.0;
            for (int m = 0; m < b; m++) {
                sum += a_high[r * b + m] * view.base[c][(b - c) + q * b + m];
            }
            az[r * b + c] = sum;
        }
    }
    for (int r = 0; r < b; r++) {
        for (int c = 0; c < b; c++) {
            double sum = 0.0;
            for (int m = 0; m < b; m++) {
                sum += az[r * b + m] * a_low[c * b + m];
            }
            out[r * b + c] += sum; /* A_high Z_hl A_low^T */
            out[c * b + r] += sum; /* its transpose */
        }
    }
    return PGEM_OK;
}

