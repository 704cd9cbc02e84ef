/* Marginal covariance of a linear function of two poses from the current factor:
 * M = A H^-1 A^T for A = [A_from A_to] (n rows, one n-column block per pose), computed as
 * Y^T Y with Y = L^-1 P A^T. Y's nonzeros are on the union of the two poses' paths to the root
 * of the tree the stored pattern follows (pgem_factor_column_parent: the block elimination
 * tree, with a relaxed supernode's columns in a chain), so only those block columns of L are
 * visited; the right-hand sides live in the shared region (one block per pose); no
 * allocation. */
#include <string.h>

#include "linalg/linear.h"

/* The next block column of the union of the paths from a and b to the root (either may be
 * -1), in increasing order: both paths climb (a parent follows its child), so they merge like
 * two sorted lists and join at their common ancestor. */
static int pgem_reach_next(const pgem_linear_t *linear, int *a, int *b)
{
    const int low = *a < 0 ? *b : *b < 0 ? *a : (*a < *b ? *a : *b);
    if (low < 0) {
        return -1;
    }
    const int up = pgem_factor_column_parent(&linear->factor, linear->block_parent, low);
    if (*a == low) {
        *a = up;
    }
    if (*b == low) {
        *b = up;
    }
    return low;
}

/* Right-hand side block of block column J: b x b doubles of the shared region. */
static inline double *pgem_reach_block(const pgem_linear_t *linear, int b, int column)
{
    return linear->factor.shared + (size_t)column * (size_t)(b * b);
}

/* X_c = L_cc^-1 X_c for the b x b block of right-hand sides X_c (row-major: b rows, b
 * columns), then X_r -= L_rc X_c for every off-diagonal block r of column c. b is a constant
 * at each call, so the loops unroll. */
static inline void pgem_forward_column(const pgem_linear_t *linear, int b, int column)
{
    double *x = pgem_reach_block(linear, b, column);
    const pgem_factor_column_t view = pgem_factor_column_view(&linear->factor, column);
    for (int c = 0; c < b; c++) {
        const double *l = view.base[c];
        const double inverse = 1.0 / l[0];
        double xc[PGEM_TANGENT_SIZE_MAX] = {0};
        for (int t = 0; t < b; t++) {
            xc[t] = x[c * b + t] * inverse;
            x[c * b + t] = xc[t];
        }
        for (int r = c + 1; r < b; r++) {
            for (int t = 0; t < b; t++) {
                x[r * b + t] -= l[r - c] * xc[t];
            }
        }
        const double *off = l + (b - c);
        for (int q = 0; q < view.count; q++) {
            double *target = pgem_reach_block(linear, b, pgem_factor_column_row(&view, column, q));
            for (int r = 0; r < b; r++) {
                const double factor = off[q * b + r];
                for (int t = 0; t < b; t++) {
                    target[r * b + t] -= factor * xc[t];
                }
            }
        }
    }
}

/* Places A_pose^T (A: b x b row-major) into the right-hand side block of the pose's column. */
static void pgem_place_rhs(pgem_linear_t *linear, int b, int block, const double *a)
{
    double *x = pgem_reach_block(linear, b, block);
    for (int r = 0; r < b; r++) {
        for (int t = 0; t < b; t++) {
            x[r * b + t] += a[t * b + r];
        }
    }
}

/* The solve along the union of the two paths and the sum M = sum_c X_c^T X_c, for block size
 * b (a constant at each call). */
static inline void pgem_marginal_blocks(pgem_linear_t *linear, int b, int block_from,
                                        int block_to, double *out)
{
    int a = block_from, c = block_to;
    for (int column = pgem_reach_next(linear, &a, &c); column >= 0;
         column = pgem_reach_next(linear, &a, &c)) {
        pgem_forward_column(linear, b, column);
        const double *x = pgem_reach_block(linear, b, column);
        for (int s = 0; s < b; s++) {
            for (int t = s; t < b; t++) {
                double sum = 0.0;
                for (int r = 0; r < b; r++) {
                    sum += x[r * b + s] * x[r * b + t];
                }
                out[s * b + t] += sum;
            }
        }
    }
    for (int s = 0; s < b; s++) {
        for (int t = 0; t < s; t++) {
            out[s * b + t] = out[t * b + s];
        }
    }
}

void pgem_linear_marginal(pgem_linear_t *linear, uint32_t from, uint32_t to, const double *a_from,
                          const double *a_to, double *out)
{
    const int b = linear->block;
    const int block_from = linear->pose_block[from], block_to = linear->pose_block[to];
    memset(out, 0, (size_t)(b * b) * sizeof(double));
    int a = block_from, c = block_to;
    for (int column = pgem_reach_next(linear, &a, &c); column >= 0;
         column = pgem_reach_next(linear, &a, &c)) {
        memset(pgem_reach_block(linear, b, column), 0, (size_t)(b * b) * sizeof(double));
    }
    if (block_from >= 0) {
        pgem_place_rhs(linear, b, block_from, a_from);
    }
    if (block_to >= 0) {
        pgem_place_rhs(linear, b, block_to, a_to);
    }
    if (b == 6) {
        pgem_marginal_blocks(linear, 6, block_from, block_to, out);
    } else {
        pgem_marginal_blocks(linear, 3, block_from, block_to, out);
    }
}
