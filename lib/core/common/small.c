/* Small dense matrices (n <= 6, row-major): the products, matrix times vector and the inverse
 * the composition of two edges needs. */
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

int pgem_small_inverse(const double *a, double *out, int n)
{
    double work[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    if (n < 1 || n > PGEM_SMALL_MAX) {
        return 0;
    }
    for (int q = 0; q < n * n; q++) {
        work[q] = a[q];
        out[q] = q / n == q % n ? 1.0 : 0.0;
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
