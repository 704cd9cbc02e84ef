/* Marginal covariance of a linear function of two poses from the current factor:
 * M = A H^-1 A^T for A = [A_from A_to] (n rows, one n-column block per pose), computed as
 * Y^T Y with Y = L^-1 P A^T. Y's nonzeros are the union of the two poses' paths to the root of
 * the block elimination tree, so only those block columns of L are visited; no allocation. */
#include <string.h>

#include "internal.h"

/* Collects the union of the elimination-tree paths from blocks a and b (either may be -1)
 * into stack, in increasing block order, marking each in mark; returns its length. A path
 * only climbs (parent > child), so each path is increasing and the two merge. */
static int pgem_reach_union(const pgem_linear_t *linear, int a, int b, int *stack, int *mark)
{
    int count = 0;
    for (int node = a; node >= 0 && mark[node] >= 0; node = linear->block_parent[node]) {
        mark[node] = -mark[node] - 2; /* CSparse's marking, which cs_ereach expects undone */
        stack[count++] = node;
    }
    const int first = count;
    for (int node = b; node >= 0 && mark[node] >= 0; node = linear->block_parent[node]) {
        mark[node] = -mark[node] - 2;
        stack[count++] = node;
    }
    /* merge stack[0, first) and stack[first, count), both increasing, in place by insertion:
     * the second path is short where it joins the first early, and both are O(tree height) */
    for (int i = first; i < count; i++) {
        int value = stack[i], j = i;
        while (j > 0 && stack[j - 1] > value) {
            stack[j] = stack[j - 1];
            j--;
        }
        stack[j] = value;
    }
    return count;
}

/* X_c = L_cc^-1 X_c for the b x b block of right-hand sides X_c (row-major: b rows, b
 * columns), then X_r -= L_rc X_c for every off-diagonal block r of column c. b is a constant
 * at each call, so the loops unroll. */
static inline void pgem_forward_column(const pgem_linear_t *linear, int b, int column)
{
    double *x = linear->block_work + (size_t)column * (size_t)(b * b);
    const int *rows = linear->factor_block_rows + linear->factor_block_colptr[column];
    const int count = linear->factor_block_colptr[column + 1] - linear->factor_block_colptr[column];
    for (int c = 0; c < b; c++) {
        const double *l = linear->factor_values + linear->factor_colptr[column * b + c];
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
        for (int q = 0; q < count; q++) {
            double *target = linear->block_work + (size_t)rows[q] * (size_t)(b * b);
            for (int r = 0; r < b; r++) {
                const double factor = off[q * b + r];
                for (int t = 0; t < b; t++) {
                    target[r * b + t] -= factor * xc[t];
                }
            }
        }
    }
}

/* Places A_pose^T (A: n x b row-major) into the right-hand side block of the pose's column. */
static void pgem_place_rhs(pgem_linear_t *linear, int b, int block, const double *a)
{
    double *x = linear->block_work + (size_t)block * (size_t)(b * b);
    for (int r = 0; r < b; r++) {
        for (int t = 0; t < b; t++) {
            x[r * b + t] += a[t * b + r];
        }
    }
}

/* The solve and the sum M = sum_c X_c^T X_c for block size b (a constant at each call). */
static inline void pgem_marginal_blocks(pgem_linear_t *linear, int b, int count, const int *stack,
                                        int *mark, double *out)
{
    for (int p = 0; p < count; p++) {
        const int column = stack[p];
        pgem_forward_column(linear, b, column);
        const double *x = linear->block_work + (size_t)column * (size_t)(b * b);
        for (int s = 0; s < b; s++) {
            for (int t = s; t < b; t++) {
                double sum = 0.0;
                for (int r = 0; r < b; r++) {
                    sum += x[r * b + s] * x[r * b + t];
                }
                out[s * b + t] += sum;
            }
        }
        mark[column] = -mark[column] - 2;
    }
    for (int s = 0; s < b; s++) {
        for (int t = 0; t < s; t++) {
            out[s * b + t] = out[t * b + s];
        }
    }
}

void pgem_linear_marginal(pgem_t *graph, uint32_t from, uint32_t to, const double *a_from,
                          const double *a_to, double *out)
{
    pgem_linear_t *linear = &graph->linear;
    const int b = linear->block;
    const int block_from = linear->pose_block[from], block_to = linear->pose_block[to];
    int *stack = linear->reach_stack, *mark = linear->reach_mark;
    memset(out, 0, (size_t)(b * b) * sizeof(double));
    const int count = pgem_reach_union(linear, block_from, block_to, stack, mark);
    for (int p = 0; p < count; p++) {
        memset(linear->block_work + (size_t)stack[p] * (size_t)(b * b), 0,
               (size_t)(b * b) * sizeof(double));
    }
    if (block_from >= 0) {
        pgem_place_rhs(linear, b, block_from, a_from);
    }
    if (block_to >= 0) {
        pgem_place_rhs(linear, b, block_to, a_to);
    }
    if (b == 6) {
        pgem_marginal_blocks(linear, 6, count, stack, mark, out);
    } else {
        pgem_marginal_blocks(linear, 3, count, stack, mark, out);
    }
}
