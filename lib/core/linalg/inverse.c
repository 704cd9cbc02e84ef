/* The inverse of H on the factor's pattern (the sparse-inverse recursion of Takahashi et al.),
 * written over L in place, and the marginal covariance of two poses read from it. For block
 * column J with off-diagonal block rows R (a clique of the filled graph, so every block of
 * H^-1 between two of them is on the pattern):
 *     Y = L_RJ L_JJ^-1,   Z_RJ = -Z_RR Y,   Z_JJ = (L_JJ L_JJ^T)^-1 - Y^T Z_RJ,
 * from the last column to the first. After it, L is gone: the next solve factors again. */
#include <string.h>

#include "internal.h"

/* Element (r, c) of off-diagonal block q of block column J (the factor's layout, see
 * linalg/cholesky.c). */
static inline double *pgem_off(pgem_linear_t *linear, int b, int column, int q, int r, int c)
{
    return linear->factor_values + linear->factor_colptr[column * b + c] + (b - c) +
           (ptrdiff_t)q * b + r;
}

/* Element (r, c), r >= c, of the diagonal block of block column J. */
static inline double *pgem_diag(pgem_linear_t *linear, int b, int column, int r, int c)
{
    return linear->factor_values + linear->factor_colptr[column * b + c] + (r - c);
}

/* Where each scalar column of a block column starts in the factor's values, so that its
 * off-diagonal block q holds element (r, c) at base[c] + (b - c) + q * b + r and its diagonal
 * block element (r, c), r >= c, at base[c] + r - c. */
typedef struct pgem_column_base {
    double *base[PGEM_TANGENT_SIZE_MAX];
} pgem_column_base_t;

static inline pgem_column_base_t pgem_column_base(pgem_linear_t *linear, int b, int column)
{
    pgem_column_base_t out = {{NULL}};
    for (int c = 0; c < b; c++) {
        out.base[c] = linear->factor_values + linear->factor_colptr[column * b + c];
    }
    return out;
}

/* Off-diagonal block q of a column into a row-major b x b array. */
static inline void pgem_load_block(const pgem_column_base_t *column, int b, int q, double *out)
{
    for (int c = 0; c < b; c++) {
        const double *values = column->base[c] + (b - c) + (ptrdiff_t)q * b;
        for (int r = 0; r < b; r++) {
            out[r * b + c] = values[r];
        }
    }
}

/* The symmetric diagonal block of a column, whole, into a row-major b x b array. */
static inline void pgem_load_diagonal(const pgem_column_base_t *column, int b, double *out)
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
                                 const pgem_column_base_t *column, int q)
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
 * b x b per block row) goes to the factorisation's workspace (one block per pose), Z_RJ is
 * accumulated over L_RJ once Y is taken from it. */
static inline void pgem_invert_column(pgem_linear_t *linear, int b, int column)
{
    const int bb = b * b;
    const int first = linear->factor_block_colptr[column];
    const int count = linear->factor_block_colptr[column + 1] - first;
    const int *rows = linear->factor_block_rows + first;
    const pgem_column_base_t self = pgem_column_base(linear, b, column);
    double *y = linear->block_work; /* [count] blocks */
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
        const int row = rows[q];
        const pgem_column_base_t inner = pgem_column_base(linear, b, row);
        double block[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
        pgem_load_diagonal(&inner, b, block);
        pgem_subtract(b, block, 0, y + (size_t)q * (size_t)bb, &self, q);
        const int inner_first = linear->factor_block_colptr[row];
        const int inner_count = linear->factor_block_colptr[row + 1] - inner_first;
        const int *inner_rows = linear->factor_block_rows + inner_first;
        int s = 0;
        for (int p = q + 1; p < count; p++) {
            while (s < inner_count && inner_rows[s] < rows[p]) {
                s++;
            }
            if (s == inner_count) {
                break;
            }
            if (inner_rows[s] != rows[p]) {
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

void pgem_linear_invert(pgem_t *graph)
{
    pgem_linear_t *linear = &graph->linear;
    for (int column = linear->block_count - 1; column >= 0; column--) {
        if (linear->block == 6) {
            pgem_invert_column(linear, 6, column);
        } else {
            pgem_invert_column(linear, 3, column);
        }
    }
}

/* Position of block row `row` among column's off-diagonal blocks, or -1. */
static int pgem_inverse_position(const pgem_linear_t *linear, int column, int row)
{
    int low = linear->factor_block_colptr[column];
    int high = linear->factor_block_colptr[column + 1] - 1;
    const int first = low;
    while (low <= high) {
        const int middle = low + (high - low) / 2;
        const int value = linear->factor_block_rows[middle];
        if (value < row) {
            low = middle + 1;
        } else if (value > row) {
            high = middle - 1;
        } else {
            return middle - first;
        }
    }
    return -1;
}

/* out += A Z_diag A^T for the symmetric diagonal block of column D (A: b x b row-major). */
static void pgem_add_diagonal_form(pgem_linear_t *linear, int b, int column, const double *a,
                                   double *out)
{
    double az[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    for (int r = 0; r < b; r++) {
        for (int c = 0; c < b; c++) {
            double sum = 0.0;
            for (int m = 0; m < b; m++) {
                const double z = m >= c ? *pgem_diag(linear, b, column, m, c)
                                        : *pgem_diag(linear, b, column, c, m);
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

int pgem_linear_marginal_inverse(pgem_t *graph, uint32_t from, uint32_t to, const double *a_from,
                                 const double *a_to, double *out)
{
    pgem_linear_t *linear = &graph->linear;
    const int b = linear->block;
    const int block_from = linear->pose_block[from], block_to = linear->pose_block[to];
    memset(out, 0, (size_t)(b * b) * sizeof(double));
    if (block_from >= 0) {
        pgem_add_diagonal_form(linear, b, block_from, a_from, out);
    }
    if (block_to >= 0) {
        pgem_add_diagonal_form(linear, b, block_to, a_to, out);
    }
    if (block_from < 0 || block_to < 0) {
        return PGEM_OK;
    }
    /* the cross term A_f Z_ft A_t^T and its transpose; Z_ft is stored under the lower block */
    const int low = block_from < block_to ? block_from : block_to;
    const int high = block_from < block_to ? block_to : block_from;
    const int q = pgem_inverse_position(linear, low, high);
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
                sum += a_high[r * b + m] * *pgem_off(linear, b, low, q, m, c);
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

void pgem_linear_marginal_diagonal(pgem_t *graph, uint32_t from, uint32_t to, const double *a_from,
                                   const double *a_to, double *out)
{
    pgem_linear_t *linear = &graph->linear;
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
