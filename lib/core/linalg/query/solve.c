/* Triangular solves with the supernodal factor: L y = x, then L^T z = y, in place and in
 * permuted order, column by column (CSparse's cs_lsolve / cs_ltsolve order), each supernode's
 * columns reading its own rows and then its rows below. */
#include "linalg/linear.h"

/* One supernode as the solves read it. */
typedef struct pgem_solve_node {
    int first;             /* its first scalar row (and column) */
    int width;             /* its scalar columns */
    int height;            /* rows of its first column */
    const int *rows;       /* its block rows below */
    int count;             /* how many */
    const double *values;  /* its trapezoid */
} pgem_solve_node_t;

static inline pgem_solve_node_t pgem_solve_node(const pgem_factor_t *factor, int b, int s)
{
    pgem_solve_node_t node;
    node.first = factor->super_first[s] * b;
    node.width = factor->super_first[s + 1] * b - node.first;
    node.height = pgem_factor_height(factor, s);
    node.rows = factor->rows + factor->row_start[s];
    node.count = factor->row_start[s + 1] - factor->row_start[s];
    node.values = factor->values + factor->value_start[s];
    return node;
}

/* Row blocks below a supernode that the lower solve updates together (PGEM_SOLVE_TILE * b
 * running values). */
#define PGEM_SOLVE_TILE 8

/* x = L^-1 x. Each supernode first solves its own columns, then updates the rows below it a
 * tile of row blocks at a time, every value receiving the columns' terms in column order, as
 * the column-by-column solve does (same bits), but loaded and stored once per supernode. */
static inline void pgem_lower_solve(const pgem_factor_t *factor, int b, double *x)
{
    double tile[PGEM_SOLVE_TILE * PGEM_TANGENT_SIZE_MAX];
    for (int s = 0; s < factor->super_count; s++) {
        const pgem_solve_node_t node = pgem_solve_node(factor, b, s);
        const int width = node.width, height = node.height, count = node.count;
        const int *rows = node.rows;
        const double *values = node.values;
        double *own = x + node.first;
        for (int j = 0; j < width; j++) {
            const double *l = values + pgem_factor_column(height, j) - j; /* l[r]: row r */
            const double value = own[j] / l[j];
            own[j] = value;
            for (int r = j + 1; r < width; r++) {
                own[r] -= l[r] * value;
            }
        }
        for (int q0 = 0; q0 < count; q0 += PGEM_SOLVE_TILE) {
            const int blocks = count - q0 < PGEM_SOLVE_TILE ? count - q0 : PGEM_SOLVE_TILE;
            const int n = blocks * b;
            for (int t = 0; t < blocks; t++) {
                const double *target = x + (size_t)rows[q0 + t] * (size_t)b;
                for (int r = 0; r < b; r++) {
                    tile[t * b + r] = target[r];
                }
            }
            const double *below = values + width + (size_t)q0 * (size_t)b; /* column 0's */
            for (int j = 0; j < width; j++) {
                const double value = own[j];
                for (int i = 0; i < n; i++) {
                    tile[i] -= below[i] * value;
                }
                below += height - j - 1; /* the next column starts one row lower */
            }
            for (int t = 0; t < blocks; t++) {
                double *target = x + (size_t)rows[q0 + t] * (size_t)b;
                for (int r = 0; r < b; r++) {
                    target[r] = tile[t * b + r];
                }
            }
        }
    }
}

/* x = L^-T x. */
static inline void pgem_upper_solve(const pgem_factor_t *factor, int b, double *x)
{
    for (int s = factor->super_count - 1; s >= 0; s--) {
        const pgem_solve_node_t node = pgem_solve_node(factor, b, s);
        const int width = node.width, height = node.height, count = node.count;
        const int *rows = node.rows;
        const double *values = node.values;
        double *own = x + node.first;
        for (int j = width - 1; j >= 0; j--) {
            const double *l = values + pgem_factor_column(height, j) - j;
            double sum = own[j];
            for (int r = j + 1; r < width; r++) {
                sum -= l[r] * own[r];
            }
            const double *below = l + width;
            for (int q = 0; q < count; q++) {
                const double *source = x + (size_t)rows[q] * (size_t)b;
                for (int r = 0; r < b; r++) {
                    sum -= below[q * b + r] * source[r];
                }
            }
            own[j] = sum / l[j];
        }
    }
}

/* Solves H step = rhs in place (permuted order): L y = rhs, then L^T step = y. */
void pgem_linear_solve(const pgem_linear_t *linear, double *step)
{
    const pgem_factor_t *factor = &linear->factor;
    if (linear->block == 6) {
        pgem_lower_solve(factor, 6, step);
        pgem_upper_solve(factor, 6, step);
    } else {
        pgem_lower_solve(factor, 3, step);
        pgem_upper_solve(factor, 3, step);
    }
}
