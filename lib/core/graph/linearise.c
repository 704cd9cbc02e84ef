/* Linearisation of one edge beside the geometry: its error and Jacobians (geometry/) turned
 * into the weighted blocks of the normal equations, edge in, blocks out; linalg only scatters
 * them into H (linalg/assemble.c).
 *
 * Each dimension has its own edge linearisation that skips the structural zeros of its
 * Jacobians. Every entry is the same sum, in the same order, as the dense products J^T W J and
 * J^T W e would form: only terms that are exactly zero are left out, so for finite values the
 * normal equations are bit for bit those of the dense computation (up to the sign of entries
 * that are zero). */
#include <stddef.h>

#include "graph/graph.h"


/* SE(2) edge k. pgem_se2_error's Jacobians have the form
 *   Jt = [ c -s  0 ]      Jf = [ -c  s  d0 ]
 *        [ s  c  0 ]           [ -s -c  d1 ]
 *        [ 0  0  1 ]           [  0  0  -1 ]
 * (c, s: cosine and sine of the edge's rotation, d: derivative of the translation error by
 * the first pose's angle), so rows 0 and 1 of Jf^T W are those of Jt^T W negated, and most
 * products reduce to two terms. Returns the edge's weighted chi2. */
static double pgem_linearise_se2(const pgem_store_t *store, uint32_t k, pgem_edge_blocks_t *out)
{
    double e[3], jf[9], jt[9];
    const double *from = store->pose + (size_t)store->edge_from[k] * 3u;
    const double *to = store->pose + (size_t)store->edge_to[k] * 3u;
    const double *o = store->edge_information + (size_t)k * 9u;
    const double w = store->edge_weight[k];
    pgem_se2_error(from, to, store->edge_measurement + (size_t)k * 3u, e, jf, jt);
    const double c = jt[0], s = jt[3], d0 = jf[2], d1 = jf[5];
    double a[9];  /* Jt^T W */
    double f2[3]; /* row 2 of Jf^T W (rows 0 and 1 are -a's) */
    for (int j = 0; j < 3; j++) {
        a[j] = w * (c * o[j] + s * o[3 + j]);
        a[3 + j] = w * (-s * o[j] + c * o[3 + j]);
        a[6 + j] = w * o[6 + j];
        f2[j] = w * (d0 * o[j] + d1 * o[3 + j] - o[6 + j]);
    }
    double *tt = out->to_to, *ff = out->from_from, *ft = out->from_to;
    tt[0] = a[0] * c + a[1] * s;
    tt[1] = a[0] * -s + a[1] * c;
    tt[2] = a[2];
    tt[4] = a[3] * -s + a[4] * c;
    tt[5] = a[5];
    tt[8] = a[8];
    ff[0] = tt[0];
    ff[1] = tt[1];
    ff[2] = -a[0] * d0 + -a[1] * d1 + a[2];
    ff[4] = tt[4];
    ff[5] = -a[3] * d0 + -a[4] * d1 + a[5];
    ff[8] = f2[0] * d0 + f2[1] * d1 - f2[2];
    ft[0] = -tt[0];
    ft[1] = -tt[1];
    ft[2] = -a[2];
    ft[3] = -(a[3] * c + a[4] * s);
    ft[4] = -tt[4];
    ft[5] = -a[5];
    ft[6] = f2[0] * c + f2[1] * s;
    ft[7] = f2[0] * -s + f2[1] * c;
    ft[8] = f2[2];
    for (int r = 0; r < 2; r++) {
        const double *row = a + (ptrdiff_t)r * 3;
        out->gradient_to[r] = row[0] * e[0] + row[1] * e[1] + row[2] * e[2];
        out->gradient_from[r] = -out->gradient_to[r];
    }
    out->gradient_to[2] = a[6] * e[0] + a[7] * e[1] + a[8] * e[2];
    out->gradient_from[2] = f2[0] * e[0] + f2[1] * e[1] + f2[2] * e[2];
    return w * pgem_quadratic_form(o, e, 3);
}

/* 3 x 3 blocks inside 6 x 6 row-major matrices (row stride 6). The sums run over m in order
 * and may continue an earlier one (add = 1), so a product over six terms is two calls. */

/* out (+)= a^T b: out_ij = sum_m a_mi b_mj */
static inline void pgem_block_at_b(const double *a, const double *b, double *out, int add)
{
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            double sum = add ? out[i * 6 + j] : 0.0;
            for (int m = 0; m < 3; m++) {
                sum += a[m * 6 + i] * b[m * 6 + j];
            }
            out[i * 6 + j] = sum;
        }
    }
}

/* out (+)= a b: out_ij = sum_m a_im b_mj */
static inline void pgem_block_a_b(const double *a, const double *b, double *out, int add)
{
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            double sum = add ? out[i * 6 + j] : 0.0;
            for (int m = 0; m < 3; m++) {
                sum += a[i * 6 + m] * b[m * 6 + j];
            }
            out[i * 6 + j] = sum;
        }
    }
}

/* SE(3) edge k. pgem_se3_error's Jacobians are block upper triangular in 3 x 3 blocks,
 *   Jt = [ P 0 ]      Jf = [ A B ]      Omega = [ O00 O01 ]
 *        [ 0 S ]           [ 0 C ]              [ O10 O11 ]
 * so each block of the products is one or two 3 x 3 products. Of the diagonal blocks only the
 * upper triangle is read: their lower left 3 x 3 block is not computed, the lower triangles of
 * their two 3 x 3 blocks on the diagonal are. Returns the edge's weighted chi2. */
static double pgem_linearise_se3(const pgem_store_t *store, uint32_t k, pgem_edge_blocks_t *out)
{
    double e[6], jf[36], jt[36];
    double tw[36], fw[36]; /* Jt^T W, Jf^T W */
    const double *from = store->pose + (size_t)store->edge_from[k] * 7u;
    const double *to = store->pose + (size_t)store->edge_to[k] * 7u;
    const double *o = store->edge_information + (size_t)k * 36u;
    const double w = store->edge_weight[k];
    pgem_se3_error(from, to, store->edge_measurement + (size_t)k * 7u, e, jf, jt);
    const double *p = jt, *s = jt + 21, *a = jf, *b = jf + 3, *c = jf + 21;
    const double *o00 = o, *o01 = o + 3, *o10 = o + 18, *o11 = o + 21;
    pgem_block_at_b(p, o00, tw, 0);
    pgem_block_at_b(p, o01, tw + 3, 0);
    pgem_block_at_b(s, o10, tw + 18, 0);
    pgem_block_at_b(s, o11, tw + 21, 0);
    pgem_block_at_b(a, o00, fw, 0);
    pgem_block_at_b(a, o01, fw + 3, 0);
    pgem_block_at_b(b, o00, fw + 18, 0);
    pgem_block_at_b(c, o10, fw + 18, 1);
    pgem_block_at_b(b, o01, fw + 21, 0);
    pgem_block_at_b(c, o11, fw + 21, 1);
    for (int i = 0; i < 36; i++) {
        tw[i] *= w;
        fw[i] *= w;
    }
    double *tt = out->to_to, *ff = out->from_from, *ft = out->from_to;
    pgem_block_a_b(tw, p, tt, 0);
    pgem_block_a_b(tw + 3, s, tt + 3, 0);
    pgem_block_a_b(tw + 21, s, tt + 21, 0);
    pgem_block_a_b(fw, a, ff, 0);
    pgem_block_a_b(fw, b, ff + 3, 0);
    pgem_block_a_b(fw + 3, c, ff + 3, 1);
    pgem_block_a_b(fw + 18, b, ff + 21, 0);
    pgem_block_a_b(fw + 21, c, ff + 21, 1);
    pgem_block_a_b(fw, p, ft, 0);
    pgem_block_a_b(fw + 3, s, ft + 3, 0);
    pgem_block_a_b(fw + 18, p, ft + 18, 0);
    pgem_block_a_b(fw + 21, s, ft + 21, 0);
    for (int i = 0; i < 6; i++) {
        double to_sum = 0.0, from_sum = 0.0;
        for (int j = 0; j < 6; j++) {
            to_sum += tw[i * 6 + j] * e[j];
            from_sum += fw[i * 6 + j] * e[j];
        }
        out->gradient_to[i] = to_sum;
        out->gradient_from[i] = from_sum;
    }
    return w * pgem_quadratic_form(o, e, 6);
}

double pgem_edge_linearise(const pgem_store_t *store, uint32_t k, pgem_edge_blocks_t *out,
                           int tangent)
{
    return tangent == 6 ? pgem_linearise_se3(store, k, out) : pgem_linearise_se2(store, k, out);
}
