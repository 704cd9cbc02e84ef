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

/* X_c = L_cc^-1 X_c for the b x n block of right-hand sides X_c (row-major: b rows, n
 * columns), then X_r -= L_rc X_c for every off-diagonal block r of column c. */
static void pgem_forward_column(const pgem_linear_t *linear, int b, int n, int column)
{
    double *x = linear->block_work + (size_t)column * (size_t)(b * b);
    const int *rows = linear->factor_block_rows + linear->factor_block_colptr[column];
    const int count = linear->factor_block_colptr[column + 1] - linear->factor_block_colptr[column];
    for (int c = 0; c < b; c++) {
        const double *l = linear->factor_values + linear->factor_colptr[column * b + c];
        for (int t = 0; t < n; t++) {
            x[c * n + t] /= l[0];
        }
        for (int r = c + 1; r < b; r++) {
            for (int t = 0; t < n; t++) {
                x[r * n + t] -= l[r - c] * x[c * n + t];
            }
        }
        const double *off = l + (b - c);
        for (int q = 0; q < count; q++) {
            double *target = linear->block_work + (size_t)rows[q] * (size_t)(b * b);
            for (int r = 0; r < b; r++) {
                for (int t = 0; t < n; t++) {
                    target[r * n + t] -= off[q * b + r] * x[c * n + t];
                }
            }
        }
    }
}

/* Places A_pose^T (A: n x b row-major) into the right-hand side block of the pose's column. */
static void pgem_place_rhs(pgem_linear_t *linear, int b, int n, int block, const double *a)
{
    double *x = linear->block_work + (size_t)block * (size_t)(b * b);
    for (int r = 0; r < b; r++) {
        for (int t = 0; t < n; t++) {
            x[r * n + t] += a[t * b + r];
        }
    }
}

void pgem_linear_marginal(pgem_t *graph, uint32_t from, uint32_t to, const double *a_from,
                          const double *a_to, double *out)
{
    pgem_linear_t *linear = &graph->linear;
    const int b = linear->block, n = b;
    const int block_from = linear->pose_block[from], block_to = linear->pose_block[to];
    int *stack = linear->reach_stack, *mark = linear->reach_mark;
    memset(out, 0, (size_t)(n * n) * sizeof(double));
    const int count = pgem_reach_union(linear, block_from, block_to, stack, mark);
    for (int p = 0; p < count; p++) {
        memset(linear->block_work + (size_t)stack[p] * (size_t)(b * b), 0,
               (size_t)(b * n) * sizeof(double));
    }
    if (block_from >= 0) {
        pgem_place_rhs(linear, b, n, block_from, a_from);
    }
    if (block_to >= 0) {
        pgem_place_rhs(linear, b, n, block_to, a_to);
    }
    for (int p = 0; p < count; p++) {
        const int column = stack[p];
        pgem_forward_column(linear, b, n, column);
        const double *x = linear->block_work + (size_t)column * (size_t)(b * b);
        for (int s = 0; s < n; s++) {
            for (int t = 0; t < n; t++) {
                double sum = 0.0;
                for (int r = 0; r < b; r++) {
                    sum += x[r * n + s] * x[r * n + t];
                }
                out[s * n + t] += sum;
            }
        }
        mark[column] = -mark[column] - 2;
    }
}
