/* Linearisation: every edge's blocks added straight into the permuted upper CSC of H through
 * the positions the analysis found, and its gradient into the right-hand side. Pruned edges are
 * left out. A dormant loop closure (EM weight below the prune threshold) that has no place in
 * the structure adds its gradient and its two diagonal blocks but not the off-diagonal block
 * that couples its poses: the Newton matrix stays positive semi-definite and as sparse as the
 * structure, and the gradient, hence the optimum an M-step converges to, is exact. */
#include <string.h>

#include "internal.h"

/* The blocks one edge contributes (n x n each, row-major) and its gradient rows. */
typedef struct pgem_edge_blocks {
    double from_from[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX]; /* Jf^T W Jf */
    double to_to[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];     /* Jt^T W Jt */
    double from_to[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];   /* Jf^T W Jt */
    double gradient_from[PGEM_TANGENT_SIZE_MAX];                     /* Jf^T W e */
    double gradient_to[PGEM_TANGENT_SIZE_MAX];                       /* Jt^T W e */
} pgem_edge_blocks_t;

/* out = J^T W (n x n) for weighted information W = weight * Omega. */
static void pgem_jt_w(const double *jacobian, const double *information, double weight, int n,
                      double *out)
{
    for (int r = 0; r < n; r++) {
        for (int c = 0; c < n; c++) {
            double sum = 0.0;
            for (int k = 0; k < n; k++) {
                sum += jacobian[k * n + r] * information[k * n + c];
            }
            out[r * n + c] = weight * sum;
        }
    }
}

/* out = A B for n x n row-major A, B. */
static void pgem_product(const double *a, const double *b, int n, double *out)
{
    for (int r = 0; r < n; r++) {
        for (int c = 0; c < n; c++) {
            double sum = 0.0;
            for (int k = 0; k < n; k++) {
                sum += a[r * n + k] * b[k * n + c];
            }
            out[r * n + c] = sum;
        }
    }
}

/* Linearises edge k; returns its weighted chi2. */
static double pgem_edge_linearise(const pgem_t *graph, uint32_t k, pgem_edge_blocks_t *blocks)
{
    double error[PGEM_TANGENT_SIZE_MAX];
    double jacobian_from[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double jacobian_to[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double jtw_from[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double jtw_to[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    const int n = graph->tangent;
    const double *information = graph->edge_information + (size_t)k * (size_t)(n * n);
    const double weight = graph->edge_weight[k];
    pgem_edge_error(graph, k, error, jacobian_from, jacobian_to);
    pgem_jt_w(jacobian_from, information, weight, n, jtw_from);
    pgem_jt_w(jacobian_to, information, weight, n, jtw_to);
    pgem_product(jtw_from, jacobian_from, n, blocks->from_from);
    pgem_product(jtw_to, jacobian_to, n, blocks->to_to);
    pgem_product(jtw_from, jacobian_to, n, blocks->from_to);
    double chi2 = 0.0;
    for (int r = 0; r < n; r++) {
        double from_sum = 0.0, to_sum = 0.0, info_sum = 0.0;
        for (int c = 0; c < n; c++) {
            from_sum += jtw_from[r * n + c] * error[c];
            to_sum += jtw_to[r * n + c] * error[c];
            info_sum += information[r * n + c] * error[c];
        }
        blocks->gradient_from[r] = from_sum;
        blocks->gradient_to[r] = to_sum;
        chi2 += error[r] * info_sum;
    }
    return weight * chi2;
}

/* Adds a symmetric n x n block onto diagonal block `block` (upper part only). */
static void pgem_add_diagonal(pgem_linear_t *linear, int block, const double *values,
                              const double *gradient)
{
    const int n = linear->block;
    for (int c = 0; c < n; c++) {
        int column = block * n + c;
        double *top = linear->upper_values + linear->upper_colptr[column + 1] - (c + 1);
        for (int r = 0; r <= c; r++) {
            top[r] += values[r * n + c];
        }
        linear->rhs[column] -= gradient[c];
    }
}

/* Adds the off-diagonal block of edge k (stored as H_ft or its transpose). */
static void pgem_add_off_diagonal(pgem_linear_t *linear, const pgem_t *graph, uint32_t k,
                                  const double *from_to)
{
    const int n = linear->block;
    const int transposed = linear->edge_transposed[k];
    const int from = linear->pose_block[graph->edge_from[k]];
    const int to = linear->pose_block[graph->edge_to[k]];
    const int column_block = transposed ? from : to;
    for (int c = 0; c < n; c++) {
        double *top = linear->upper_values + linear->upper_colptr[column_block * n + c] +
                      linear->edge_offset[k];
        for (int r = 0; r < n; r++) {
            top[r] += transposed ? from_to[c * n + r] : from_to[r * n + c];
        }
    }
}

double pgem_linear_assemble(pgem_t *graph)
{
    pgem_linear_t *linear = &graph->linear;
    pgem_edge_blocks_t blocks;
    memset(linear->upper_values, 0, (size_t)linear->upper_colptr[linear->scalar_count] * sizeof(double));
    memset(linear->rhs, 0, (size_t)linear->scalar_count * sizeof(double));
    double chi2 = 0.0;
    for (uint32_t k = 0; k < graph->edge_count; k++) {
        if (graph->edge_active[k] == PGEM_EDGE_PRUNED) {
            continue;
        }
        const int from = linear->pose_block[graph->edge_from[k]];
        const int to = linear->pose_block[graph->edge_to[k]];
        chi2 += pgem_edge_linearise(graph, k, &blocks);
        if (from >= 0) {
            pgem_add_diagonal(linear, from, blocks.from_from, blocks.gradient_from);
        }
        if (to >= 0) {
            pgem_add_diagonal(linear, to, blocks.to_to, blocks.gradient_to);
        }
        if (from >= 0 && to >= 0 && linear->edge_offset[k] >= 0) { /* see the header comment */
            pgem_add_off_diagonal(linear, graph, k, blocks.from_to);
        }
    }
    for (int j = 0; j < linear->scalar_count; j++) {
        linear->diagonal[j] = linear->upper_values[linear->upper_colptr[j + 1] - 1];
    }
    return chi2;
}

void pgem_linear_damp(pgem_t *graph, double lambda)
{
    pgem_linear_t *linear = &graph->linear;
    for (int j = 0; j < linear->scalar_count; j++) {
        linear->upper_values[linear->upper_colptr[j + 1] - 1] = linear->diagonal[j] + lambda;
    }
}
