/* Small dense matrices (n <= 6, row-major): products, matrix times vector, the inverse (the
 * composition of two edges), Cholesky, triangular solves and a quadratic form (information
 * checks, whitening, the innovation tests, the online factor's blocks). */
#include <math.h>

#include "common/common.h"

void pgem_small_product(const double *a, int transpose_a, const double *b, int transpose_b,
                        double *out, int n)
{
    for (int r = 0; r < n; r++) {
        for (int c = 0; c < n; c++) {
            double sum = 0.0;
            for (int m = 0; m < n; m++) {
                sum += (transpose_a ? a[m * n + r] : a[r * n + m]) *
                       (transpose_b ? b[c * n + m] : b[m * n + c]);
            }
            out[r * n + c] = sum;
        }
    }
}

void pgem_small_apply(const double *a, int transpose, const double *v, double *out, int n)
{
    for (int r = 0; r < n; r++) {
        double sum = 0.0;
        for (int c = 0; c < n; c++) {
            sum += (transpose ? a[c * n + r] : a[r * n + c]) * v[c];
        }
        out[r] = sum;
    }
}

/* The start of an elimination on [a | I]: a into work, the identity into out; 0 if n is out of
 * range. */
static int pgem_small_inverse_start(const double *a, double *work, double *out, int n)
{
    if (n < 1 || n > PGEM_SMALL_MAX) {
        return 0;
    }
    for (int q = 0; q < n * n; q++) {
        work[q] = a[q];
        out[q] = q / n == q % n ? 1.0 : 0.0;
    }
    return 1;
}

int pgem_small_inverse(const double *a, double *out, int n)
{
    double work[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    if (!pgem_small_inverse_start(a, work, out, n)) {
        return 0;
    }
    for (int c = 0; c < n; c++) { /* Gauss-Jordan, the largest pivot of the column */
        int pivot = c;
        for (int r = c + 1; r < n; r++) {
            pivot = fabs(work[r * n + c]) > fabs(work[pivot * n + c]) ? r : pivot;
        }
        if (!(fabs(work[pivot * n + c]) > 0.0)) {
            return 0;
        }
        for (int m = 0; m < n && pivot != c; m++) {
            const double w = work[c * n + m], o = out[c * n + m];
            work[c * n + m] = work[pivot * n + m];
            out[c * n + m] = out[pivot * n + m];
            work[pivot * n + m] = w;
            out[pivot * n + m] = o;
        }
        const double scale = 1.0 / work[c * n + c];
        for (int m = 0; m < n; m++) {
            work[c * n + m] *= scale;
            out[c * n + m] *= scale;
        }
        for (int r = 0; r < n; r++) {
            const double f = work[r * n + c];
            if (r == c || f == 0.0) {
                continue;
            }
            for (int m = 0; m < n; m++) {
                work[r * n + m] -= f * work[c * n + m];
                out[r * n + m] -= f * out[c * n + m];
            }
        }
    }
    for (int q = 0; q < n * n; q++) {
        if (!isfinite(out[q])) {
            return 0;
        }
    }
    return 1;
}

int pgem_small_cholesky(double *a, int n, double least, int strict)
{
    for (int j = 0; j < n; j++) {
        double pivot = a[j * n + j];
        for (int k = 0; k < j; k++) {
            pivot -= a[k * n + j] * a[k * n + j];
        }
        if (strict && (!(pivot > least) || !isfinite(pivot))) {
            return j;
        }
        const double root = sqrt(pivot > least ? pivot : least);
        a[j * n + j] = root;
        for (int i = j + 1; i < n; i++) {
            double value = a[j * n + i];
            for (int k = 0; k < j; k++) {
                value -= a[k * n + j] * a[k * n + i];
            }
            a[j * n + i] = root > 0.0 ? value / root : 0.0;
        }
    }
    for (int i = 1; i < n; i++) {
        for (int j = 0; j < i; j++) {
            a[i * n + j] = 0.0;
        }
    }
    return -1;
}

void pgem_small_upper_solve(const double *u, double *x, int n)
{
    for (int r = n - 1; r >= 0; r--) {
        double sum = x[r];
        for (int c = r + 1; c < n; c++) {
            sum -= u[r * n + c] * x[c];
        }
        x[r] = sum / u[r * n + r];
    }
}

double pgem_small_form(const double *u, const double *e, int n)
{
    double y[PGEM_SMALL_MAX], form = 0.0;
    for (int r = 0; r < n; r++) { /* y = U^-T e, then |y|^2 */
        double sum = e[r];
        for (int m = 0; m < r; m++) {
            sum -= u[m * n + r] * y[m];
        }
        y[r] = sum / u[r * n + r];
        form += y[r] * y[r];
    }
    return form;
}
