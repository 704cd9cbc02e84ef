/* The dense kernels' body, compiled once per build of lib/core/linalg/dense.h (dense.c,
 * dense_avx2.c, dense_avx512.c). The includer defines PGEM_DENSE_NAME(name) (the build's
 * function names), PGEM_VW (doubles per vector register, 1 for scalar code), PGEM_MV (vectors
 * per micro-tile column) and PGEM_NR (micro-tile columns).
 *
 * The product C = A A(0:n, :)^T is computed as in BLIS: k blocks of PGEM_DENSE_KC columns,
 * the operands packed into micro-panels (PGEM_MR rows or PGEM_NR rows per sliver, zero-padded)
 * in the worker's workspace, a register-blocked micro-tile of PGEM_MR x PGEM_NR accumulators,
 * and each tile's partial sum subtracted from the target. Every entry of C sums its k block's
 * products in order p = 0, 1, ...; only whether those sums fuse multiply and add differs
 * between builds, so a factorisation gives the same bits on any worker and any tiling. */
#include <math.h>
#include <string.h>

#include "dense.h"

#define PGEM_MR (PGEM_VW * PGEM_MV)
#define PGEM_MC_MAX 144 /* rows of a packed block of A (a multiple of every PGEM_MR) */
#define PGEM_NC_MAX 240 /* rows of a packed block of B (a multiple of every PGEM_NR) */

#if PGEM_VW > 1
typedef double pgem_vec __attribute__((vector_size(PGEM_VW * 8)));
#else
typedef double pgem_vec;
#endif

/* Offset of column c's entry at row r (r >= c) of a trapezoid of height h. */
static inline ptrdiff_t PGEM_DENSE_NAME(at)(int h, int r, int c)
{
    return (ptrdiff_t)c * h - (ptrdiff_t)c * (c - 1) / 2 + (r - c);
}

/* Copies rows first .. first+count-1 of A's columns pc .. pc+kb-1 into slivers of `width`
 * rows (PGEM_MR or PGEM_NR): out[s * width * kb + p * width + t] = A(first + s * width + t,
 * pc + p), zero past count. Whole slivers go by vector registers (a loop the compiler would
 * otherwise turn into a memmove call per sliver). */
static void PGEM_DENSE_NAME(pack)(const pgem_dense_update_t *u, int first, int count, int pc,
                                  int kb, int width, double *restrict out)
{
    for (int p = 0; p < kb; p++) {
        const ptrdiff_t column = pc + p;
        const double *restrict in = u->source + column * u->step - column * (column - 1) / 2 + first;
        double *restrict sliver = out + (ptrdiff_t)p * width;
        int t = 0;
        if (width == PGEM_MR) {
            for (; t + PGEM_MR <= count; t += PGEM_MR) {
                for (int v = 0; v < PGEM_MV; v++) {
                    pgem_vec x;
                    memcpy(&x, in + t + v * PGEM_VW, sizeof x);
                    memcpy(sliver + v * PGEM_VW, &x, sizeof x);
                }
                sliver += (ptrdiff_t)PGEM_MR * kb;
            }
        } else {
            for (; t + width <= count; t += width) {
                for (int r = 0; r < PGEM_NR; r++) {
                    sliver[r] = in[t + r];
                }
                sliver += (ptrdiff_t)width * kb;
            }
        }
        if (t < count) {
            int r = 0;
            for (; r < count - t; r++) {
                sliver[r] = in[t + r];
            }
            for (; r < width; r++) {
                sliver[r] = 0.0;
            }
        }
    }
}

/* The target's local rows of C's rows first .. first+count-1. */
static void PGEM_DENSE_NAME(target_rows)(const pgem_dense_update_t *u, int first, int count,
                                         int *out)
{
    if (u->rows == NULL) {
        for (int i = 0; i < count; i++) {
            out[i] = u->row0 + first + i;
        }
        return;
    }
    const int b = u->block;
    int block = first / b, r = first % b;
    for (int i = 0; i < count; i++) {
        out[i] = u->map[u->rows[block]] * b + r;
        if (++r == b) {
            r = 0;
            block++;
        }
    }
}

/* acc = A sliver (PGEM_MR x kb) times B sliver (PGEM_NR x kb) transposed. */
static inline void PGEM_DENSE_NAME(tile)(int kb, const double *restrict a, const double *restrict b,
                                         pgem_vec acc[PGEM_NR][PGEM_MV])
{
    pgem_vec zero;
    memset(&zero, 0, sizeof zero);
    for (int j = 0; j < PGEM_NR; j++) {
        for (int v = 0; v < PGEM_MV; v++) {
            acc[j][v] = zero;
        }
    }
    for (int p = 0; p < kb; p++) {
        pgem_vec av[PGEM_MV];
        for (int v = 0; v < PGEM_MV; v++) {
            memcpy(&av[v], a + (ptrdiff_t)p * PGEM_MR + v * PGEM_VW, sizeof av[v]);
        }
        for (int j = 0; j < PGEM_NR; j++) {
            const double bj = b[(ptrdiff_t)p * PGEM_NR + j];
            for (int v = 0; v < PGEM_MV; v++) {
                acc[j][v] += av[v] * bj;
            }
        }
    }
}

/* Subtracts a tile (C rows i0 .., columns j0 .., mv x nv of it valid) from the target: rows
 * through trow (indexed from the packed block's first row), columns through column (the
 * offset of each column's row 0). Only entries with i >= j are C's. */
static void PGEM_DENSE_NAME(store)(double *target, const ptrdiff_t *column, const int *trow,
                                   int i0, int j0, int mv, int nv, pgem_vec acc[PGEM_NR][PGEM_MV])
{
    const int full = mv == PGEM_MR && nv == PGEM_NR && i0 >= j0 + PGEM_NR - 1 &&
                     trow[PGEM_MR - 1] == trow[0] + PGEM_MR - 1;
    if (full) {
        for (int j = 0; j < PGEM_NR; j++) {
            double *out = target + column[j] + trow[0];
            for (int v = 0; v < PGEM_MV; v++) {
                pgem_vec c;
                memcpy(&c, out + v * PGEM_VW, sizeof c);
                c -= acc[j][v];
                memcpy(out + v * PGEM_VW, &c, sizeof c);
            }
        }
        return;
    }
    double spill[PGEM_NR][PGEM_MR];
    /* cppcheck-suppress bufferAccessOutOfBounds ; acc is PGEM_NR x PGEM_MV vectors of
     * PGEM_VW doubles: the same bytes (cppcheck does not size vector types) */
    memcpy(spill, acc, sizeof spill);
    for (int j = 0; j < nv; j++) {
        double *out = target + column[j];
        for (int i = (j0 + j > i0 ? j0 + j - i0 : 0); i < mv; i++) {
            out[trow[i]] -= spill[j][i];
        }
    }
}

static int PGEM_DENSE_NAME(min)(int a, int b)
{
    return a < b ? a : b;
}

static void PGEM_DENSE_NAME(update)(const pgem_dense_update_t *u, double *work, size_t work_doubles)
{
    const size_t per_k = work_doubles / (size_t)PGEM_DENSE_NAME(min)(PGEM_DENSE_KC, u->k);
    int mc = (int)(per_k / 3u) / PGEM_MR * PGEM_MR;
    mc = mc < PGEM_MR ? PGEM_MR : PGEM_DENSE_NAME(min)(mc, PGEM_MC_MAX);
    int nc = (int)((per_k - (size_t)mc) / PGEM_NR) * PGEM_NR;
    nc = nc < PGEM_NR ? PGEM_NR : PGEM_DENSE_NAME(min)(nc, PGEM_NC_MAX);
    double *bp = work;
    double *ap = work + (ptrdiff_t)PGEM_DENSE_NAME(min)(PGEM_DENSE_KC, u->k) * nc;
    int trow[PGEM_MC_MAX];
    int tcol[PGEM_NC_MAX];
    ptrdiff_t column[PGEM_NC_MAX];
    for (int jc = 0; jc < u->n; jc += nc) {
        const int nb = PGEM_DENSE_NAME(min)(nc, u->n - jc);
        PGEM_DENSE_NAME(target_rows)(u, jc, nb, tcol);
        for (int j = 0; j < nb; j++) {
            column[j] = PGEM_DENSE_NAME(at)(u->target_height, tcol[j], tcol[j]) - tcol[j];
        }
        for (int pc = 0; pc < u->k; pc += PGEM_DENSE_KC) {
            const int kb = PGEM_DENSE_NAME(min)(PGEM_DENSE_KC, u->k - pc);
            PGEM_DENSE_NAME(pack)(u, jc, nb, pc, kb, PGEM_NR, bp);
            for (int ic = jc; ic < u->m; ic += mc) {
                const int mb = PGEM_DENSE_NAME(min)(mc, u->m - ic);
                PGEM_DENSE_NAME(pack)(u, ic, mb, pc, kb, PGEM_MR, ap);
                PGEM_DENSE_NAME(target_rows)(u, ic, mb, trow);
                for (int jr = 0; jr < nb; jr += PGEM_NR) {
                    const int nv = PGEM_DENSE_NAME(min)(PGEM_NR, nb - jr);
                    for (int ir = 0; ir < mb; ir += PGEM_MR) {
                        if (ic + ir + PGEM_MR - 1 < jc + jr) {
                            continue; /* above the diagonal */
                        }
                        pgem_vec acc[PGEM_NR][PGEM_MV];
                        PGEM_DENSE_NAME(tile)(kb, ap + (ptrdiff_t)ir * kb, bp + (ptrdiff_t)jr * kb, acc);
                        PGEM_DENSE_NAME(store)(u->target, column + jr, trow + ir, ic + ir, jc + jr,
                                               PGEM_DENSE_NAME(min)(PGEM_MR, mb - ir), nv, acc);
                    }
                }
            }
        }
    }
}

/* y -= a x over count entries. */
static inline void PGEM_DENSE_NAME(axpy)(int count, double a, const double *restrict x,
                                         double *restrict y)
{
    for (int r = 0; r < count; r++) {
        y[r] -= a * x[r];
    }
}

static inline void PGEM_DENSE_NAME(divide)(int count, double d, double *restrict y)
{
    for (int r = 0; r < count; r++) {
        y[r] /= d;
    }
}

/* The rows below a panel's diagonal block solved against it, X = A L11^-T: entry (r, j) is
 * (a - sum over m < j, in order, of L(j, m) X(r, m)) / L(j, j). Tiles of PGEM_MR rows by
 * PGEM_NR columns are kept in vector registers: the panel's earlier columns are subtracted
 * as in a product (each X(., m) loaded once per tile), then the tile's own triangle is solved
 * column by column; rows past the last full tile go one by one. */
static void PGEM_DENSE_NAME(panel_solve)(double *values, int h, int c0, int w)
{
    double *col[PGEM_DENSE_PANEL]; /* col[j - c0][row]: entry (row, j) */
    for (int j = 0; j < w; j++) {
        col[j] = values + PGEM_DENSE_NAME(at)(h, c0 + j, c0 + j) - (c0 + j);
    }
    int r = c0 + w;
    for (; r + PGEM_MR <= h; r += PGEM_MR) {
        for (int jb = 0; jb < w; jb += PGEM_NR) {
            const int nv = PGEM_DENSE_NAME(min)(PGEM_NR, w - jb);
            pgem_vec acc[PGEM_NR][PGEM_MV];
            for (int j = 0; j < nv; j++) {
                for (int v = 0; v < PGEM_MV; v++) {
                    memcpy(&acc[j][v], col[jb + j] + r + v * PGEM_VW, sizeof acc[j][v]);
                }
            }
            for (int m = 0; m < jb; m++) {
                const double *left = col[m];
                pgem_vec x[PGEM_MV];
                for (int v = 0; v < PGEM_MV; v++) {
                    memcpy(&x[v], left + r + v * PGEM_VW, sizeof x[v]);
                }
                for (int j = 0; j < nv; j++) {
                    const double l = left[c0 + jb + j];
                    for (int v = 0; v < PGEM_MV; v++) {
                        acc[j][v] -= l * x[v];
                    }
                }
            }
            for (int j = 0; j < nv; j++) {
                for (int m = 0; m < j; m++) {
                    const double l = col[jb + m][c0 + jb + j];
                    for (int v = 0; v < PGEM_MV; v++) {
                        acc[j][v] -= l * acc[m][v];
                    }
                }
                const double d = col[jb + j][c0 + jb + j];
                for (int v = 0; v < PGEM_MV; v++) {
                    acc[j][v] /= d;
                    memcpy(col[jb + j] + r + v * PGEM_VW, &acc[j][v], sizeof acc[j][v]);
                }
            }
        }
    }
    for (; r < h; r++) {
        for (int j = 0; j < w; j++) {
            double sum = col[j][r];
            for (int m = 0; m < j; m++) {
                sum -= col[m][c0 + j] * col[m][r];
            }
            col[j][r] = sum / col[j][c0 + j];
        }
    }
}

/* Unblocked left-looking Cholesky of columns c0 .. c0+w-1, their earlier columns' updates
 * already applied: first the diagonal block, then the rows below (pgem_dense_panel_solve;
 * each entry sees the same operations in the same order either way). Returns the failing
 * column or -1. */
static int PGEM_DENSE_NAME(panel)(double *values, int h, int c0, int w)
{
    for (int j = c0; j < c0 + w; j++) {
        double *col = values + PGEM_DENSE_NAME(at)(h, j, j) - j; /* col[r]: entry (r, j) */
        for (int m = c0; m < j; m++) {
            const double *left = values + PGEM_DENSE_NAME(at)(h, m, m) - m;
            PGEM_DENSE_NAME(axpy)(c0 + w - j, left[j], left + j, col + j);
        }
        const double pivot = col[j];
        if (!(pivot > 0.0) || !isfinite(pivot)) {
            return j;
        }
        col[j] = sqrt(pivot);
        PGEM_DENSE_NAME(divide)(c0 + w - j - 1, col[j], col + j + 1);
    }
    PGEM_DENSE_NAME(panel_solve)(values, h, c0, w);
    return -1;
}

/* Columns c0 .. c0 + w - 1 of a trapezoid (rows c0 on) take the product update of every column
 * left of c0: the step before a panel of them is factorised. */
static void PGEM_DENSE_NAME(left_update)(double *values, int height, int c0, int w, double *work,
                                         size_t work_doubles)
{
    pgem_dense_update_t u;
    memset(&u, 0, sizeof u);
    u.source = values + c0; /* entry (c0, 0) */
    u.step = height - 1;
    u.m = height - c0;
    u.n = w;
    u.k = c0;
    u.target = values;
    u.target_height = height;
    u.row0 = c0;
    PGEM_DENSE_NAME(update)(&u, work, work_doubles);
}

/* Blocked left-looking Cholesky of a trapezoid's first `width` columns in panels of
 * PGEM_DENSE_PANEL: each panel first takes the product update of every column left of it. */
static int PGEM_DENSE_NAME(factor_panels)(double *values, int height, int width, double *work,
                                          size_t work_doubles)
{
    for (int c0 = 0; c0 < width; c0 += PGEM_DENSE_PANEL) {
        const int w = PGEM_DENSE_NAME(min)(PGEM_DENSE_PANEL, width - c0);
        if (c0 > 0) {
            PGEM_DENSE_NAME(left_update)(values, height, c0, w, work, work_doubles);
        }
        const int bad = PGEM_DENSE_NAME(panel)(values, height, c0, w);
        if (bad >= 0) {
            return bad;
        }
    }
    return -1;
}

/* Wide trapezoids in two levels: outer panels of PGEM_DENSE_OUTER columns take the update of
 * everything left of them in one product (each packed operand then serves four times as many
 * columns as a 64-column panel would), and are factorised as trapezoids of their own (the
 * trapezoid from entry (c0, c0) on is one, of height - c0 rows) in 64-column panels. */
static int PGEM_DENSE_NAME(factor)(double *values, int height, int width, double *work,
                                   size_t work_doubles)
{
    if (width <= PGEM_DENSE_OUTER) {
        return PGEM_DENSE_NAME(factor_panels)(values, height, width, work, work_doubles);
    }
    for (int c0 = 0; c0 < width; c0 += PGEM_DENSE_OUTER) {
        const int w = PGEM_DENSE_NAME(min)(PGEM_DENSE_OUTER, width - c0);
        if (c0 > 0) {
            PGEM_DENSE_NAME(left_update)(values, height, c0, w, work, work_doubles);
        }
        const ptrdiff_t corner = PGEM_DENSE_NAME(at)(height, c0, c0);
        const int bad = PGEM_DENSE_NAME(factor_panels)(values + corner, height - c0, w, work,
                                                       work_doubles);
        if (bad >= 0) {
            return c0 + bad;
        }
    }
    return -1;
}
