/* Numeric up-looking Cholesky H = L L^T into the preallocated L: row k's pattern comes from
 * CSparse's cs_ereach on the elimination tree; no allocation. Then the two triangular solves. */
#include <math.h>
#include <string.h>

#include "internal.h"

/* Eliminates row k of L against the columns in its pattern; returns the pivot d = L(k,k)^2. */
static double pgem_factor_row(pgem_linear_t *linear, int k)
{
    const cs_di *upper = &linear->upper;
    int *rows = linear->factor_rows;
    double *values = linear->factor_values;
    double *dense = linear->dense;
    int top = cs_di_ereach(upper, k, linear->parent, linear->reach_stack, linear->reach_mark);
    dense[k] = 0.0;
    for (int p = upper->p[k]; p < upper->p[k + 1]; p++) {
        dense[upper->i[p]] = upper->x[p];
    }
    double pivot = dense[k];
    dense[k] = 0.0;
    for (; top < linear->scalar_count; top++) {
        int i = linear->reach_stack[top];
        int first = linear->factor_colptr[i];
        double lki = dense[i] / values[first];
        dense[i] = 0.0;
        for (int p = first + 1; p < linear->fill_next[i]; p++) {
            dense[rows[p]] -= values[p] * lki;
        }
        pivot -= lki * lki;
        int slot = linear->fill_next[i]++;
        rows[slot] = k;
        values[slot] = lki;
    }
    return pivot;
}

int pgem_linear_factor(pgem_t *graph)
{
    pgem_linear_t *linear = &graph->linear;
    const int n = linear->scalar_count;
    memset(linear->dense, 0, (size_t)n * sizeof(double));
    for (int k = 0; k < n; k++) {
        linear->fill_next[k] = linear->factor_colptr[k];
    }
    for (int k = 0; k < n; k++) {
        double pivot = pgem_factor_row(linear, k);
        if (!(pivot > 0.0) || !isfinite(pivot)) {
            pgem_message_clear(graph);
            pgem_message_text(graph, "normal equations not positive definite at unknown ");
            pgem_message_i64(graph, k);
            pgem_message_text(graph, " (is every connected part of the graph held by a fixed pose?)");
            return PGEM_ERR_NOT_POSITIVE_DEFINITE;
        }
        int slot = linear->fill_next[k]++;
        linear->factor_rows[slot] = k;
        linear->factor_values[slot] = sqrt(pivot);
    }
    return PGEM_OK;
}

/* Solves H step = rhs in place (permuted order): L y = rhs, then L^T step = y. */
void pgem_linear_solve(pgem_t *graph, double *step)
{
    pgem_linear_t *linear = &graph->linear;
    cs_di_lsolve(&linear->factor, step);
    cs_di_ltsolve(&linear->factor, step);
}
