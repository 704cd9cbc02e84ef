/* Assembly: every edge's weighted blocks (graph/linearise.c) added straight into the permuted
 * lower CSC of H through the positions the analysis found, and its gradient into the
 * right-hand side. Pruned edges are left out. A dormant loop closure (EM weight below the
 * dormant threshold) that has no place in the structure adds its gradient and its two
 * diagonal blocks but not the off-diagonal block that couples its poses: the Newton matrix
 * stays positive semi-definite and as sparse as the structure, and the gradient, hence the
 * optimum an M-step converges to, is exact.
 *
 * The block size is passed as a constant (3 or 6) so the loops unroll. */
#include <string.h>

#include "linalg/linear.h"

/* Adds a symmetric n x n block, given by its upper triangle, onto diagonal block `block`
 * (whose lower triangle H stores), and the gradient into the right-hand side. */
static inline void pgem_add_diagonal(pgem_linear_t *linear, int n, int block, const double *values,
                                     const double *gradient)
{
    double *rhs = linear->rhs + (ptrdiff_t)block * n;
    const int off_diagonal = (linear->block_colptr[block + 1] - linear->block_colptr[block]) * n;
    double *column = linear->lower_values + linear->lower_start[block];
    for (int c = 0; c < n; c++) {
        for (int r = 0; r < n; r++) { /* r >= c, as a square loop the compiler unrolls */
            if (r >= c) {
                column[r - c] += values[c * n + r];
            }
        }
        rhs[c] -= gradient[c];
        column += n - c + off_diagonal;
    }
}

/* Adds an edge's off-diagonal block at `offset` in the off-diagonal part of the columns of
 * `column_block`: from_to transposed when the stored block is H_tf (transposed), else as it
 * is. */
static inline void pgem_add_off_diagonal(pgem_linear_t *linear, int n, int column_block,
                                         int offset, int transposed, const double *from_to)
{
    const int off_diagonal =
        (linear->block_colptr[column_block + 1] - linear->block_colptr[column_block]) * n;
    double *top = linear->lower_values + linear->lower_start[column_block] + n + offset;
    for (int c = 0; c < n; c++) {
        if (transposed) {
            for (int r = 0; r < n; r++) {
                top[r] += from_to[c * n + r];
            }
        } else {
            for (int r = 0; r < n; r++) {
                top[r] += from_to[r * n + c];
            }
        }
        top += n - (c + 1) + off_diagonal; /* the next column's diagonal part is one shorter */
    }
}

/* The edge loop for block size n (a constant at each call). */
static inline double pgem_assemble_edges(pgem_linear_t *linear, const pgem_store_t *store, int n)
{
    const int *pose_block = linear->pose_block;
    pgem_edge_blocks_t blocks;
    double chi2 = 0.0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_active[k] == PGEM_EDGE_PRUNED) {
            continue;
        }
        const int from = pose_block[store->edge_from[k]];
        const int to = pose_block[store->edge_to[k]];
        chi2 += pgem_edge_linearise(store, k, &blocks, linear->block);
        if (from >= 0) {
            pgem_add_diagonal(linear, n, from, blocks.from_from, blocks.gradient_from);
        }
        if (to >= 0) {
            pgem_add_diagonal(linear, n, to, blocks.to_to, blocks.gradient_to);
        }
        if (from >= 0 && to >= 0 && linear->edge_offset[k] >= 0) { /* see the header comment */
            const int transposed = linear->edge_transposed[k];
            pgem_add_off_diagonal(linear, n, transposed ? from : to, linear->edge_offset[k],
                                  transposed, blocks.from_to);
        } else if (from >= 0 && to >= 0) {
            linear->left_out++; /* a dormant loop's coupling: the solve adds it back */
        }
    }
    return chi2;
}

double pgem_linear_assemble(pgem_linear_t *linear, const pgem_store_t *store)
{
    linear->covariance = PGEM_COVARIANCE_NONE;
    memset(linear->lower_values, 0, (size_t)linear->lower_start[linear->block_count] * sizeof(double));
    memset(linear->rhs, 0, (size_t)linear->scalar_count * sizeof(double));
    linear->left_out = 0;
    const double chi2 = linear->block == 6 ? pgem_assemble_edges(linear, store, 6)
                                           : pgem_assemble_edges(linear, store, 3);
    for (uint32_t p = 0; p < store->pose_count; p++) { /* the gauges' damping */
        const int block = linear->pose_block[p];
        if (block >= 0 && PGEM_POSE_DAMPED(store->pose_fixed[p])) {
            for (int c = 0; c < linear->block; c++) {
                linear->lower_values[pgem_lower_column(linear, block, c)] += PGEM_GAUGE_DAMPING;
            }
        }
    }
    for (int block = 0; block < linear->block_count; block++) {
        for (int c = 0; c < linear->block; c++) {
            linear->diagonal[block * linear->block + c] =
                linear->lower_values[pgem_lower_column(linear, block, c)];
        }
    }
    return chi2;
}

void pgem_linear_damp(pgem_linear_t *linear, double lambda)
{
    for (int block = 0; block < linear->block_count; block++) {
        for (int c = 0; c < linear->block; c++) {
            linear->lower_values[pgem_lower_column(linear, block, c)] =
                linear->diagonal[block * linear->block + c] + lambda;
        }
    }
}

/* y += D x for D the couplings the assembly left out (dormant loops without a place in the
 * structure), each recomputed from the edge's linearisation. */
static inline void pgem_left_out_edges(const pgem_linear_t *linear, const pgem_store_t *store,
                                       int n, const double *x, double *y)
{
    pgem_edge_blocks_t blocks;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        const int from = linear->pose_block[store->edge_from[k]];
        const int to = linear->pose_block[store->edge_to[k]];
        if (store->edge_active[k] == PGEM_EDGE_PRUNED || from < 0 || to < 0 ||
            linear->edge_offset[k] >= 0) {
            continue;
        }
        (void)pgem_edge_linearise(store, k, &blocks, linear->block);
        const double *xf = x + (ptrdiff_t)from * n, *xt = x + (ptrdiff_t)to * n;
        double *yf = y + (ptrdiff_t)from * n, *yt = y + (ptrdiff_t)to * n;
        for (int r = 0; r < n; r++) {
            for (int c = 0; c < n; c++) {
                yf[r] += blocks.from_to[r * n + c] * xt[c];
                yt[c] += blocks.from_to[r * n + c] * xf[r];
            }
        }
    }
}

void pgem_linear_left_out_multiply(const pgem_linear_t *linear, const pgem_store_t *store,
                                   const double *x, double *y)
{
    if (linear->block == 6) {
        pgem_left_out_edges(linear, store, 6, x, y);
    } else {
        pgem_left_out_edges(linear, store, 3, x, y);
    }
}
