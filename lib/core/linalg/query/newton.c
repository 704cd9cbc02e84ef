/* The Newton step: the factor's solve, then, when the assembly left couplings out of the
 * structure (dormant loop closures), conjugate gradients on the whole matrix H + D with the
 * factor of H as preconditioner, to a relative residual of 1e-6 however sparse the factor was
 * kept. Dormant loops exist only in EM's M-steps, one Gauss-Newton iteration each between
 * E-steps that move the weights far more than that; the polish, which gives the result, has
 * none, so its steps are the factor's own (docs/design/robust-em.md). No allocation: the
 * vectors live in the shared region (linalg/factor/factor.h) and the LM gradient copy. */
#include <math.h>
#include <string.h>

#include "linalg/linear.h"

#define PGEM_NEWTON_TOLERANCE 1e-6
#define PGEM_NEWTON_ITERATIONS 200

static double pgem_dot(const double *a, const double *b, int count)
{
    double sum = 0.0;
    for (int j = 0; j < count; j++) {
        sum += a[j] * b[j];
    }
    return sum;
}

/* out = (H + D) x */
static void pgem_full_multiply(const pgem_linear_t *linear, const pgem_store_t *store,
                               const double *x, double *out)
{
    pgem_linear_multiply(linear, x, out);
    pgem_linear_left_out_multiply(linear, store, x, out);
}

int pgem_solve_newton(pgem_linear_t *linear, const pgem_store_t *store)
{
    const int count = linear->scalar_count;
    if (linear->left_out == 0u) {
        pgem_linear_solve(linear, linear->rhs);
        return PGEM_OK;
    }
    double *x = linear->rhs;
    double *b = linear->gradient; /* LM keeps the same -b there; GN does not use it */
    double *r = linear->factor.shared; /* 3 vectors: b doubles per pose or more */
    double *p = r + count;
    double *q = p + count; /* (H + D) p, then the preconditioned residual */
    memcpy(b, x, (size_t)count * sizeof(double));
    pgem_linear_solve(linear, x);
    pgem_full_multiply(linear, store, x, q);
    for (int j = 0; j < count; j++) {
        r[j] = b[j] - q[j];
    }
    const double limit = PGEM_NEWTON_TOLERANCE * sqrt(pgem_dot(b, b, count));
    memcpy(p, r, (size_t)count * sizeof(double));
    pgem_linear_solve(linear, p);
    double rz = pgem_dot(r, p, count);
    for (int iteration = 0; iteration < PGEM_NEWTON_ITERATIONS; iteration++) {
        if (!(sqrt(pgem_dot(r, r, count)) > limit)) {
            return PGEM_OK;
        }
        pgem_full_multiply(linear, store, p, q);
        const double curvature = pgem_dot(p, q, count);
        if (!(curvature > 0.0)) {
            break;
        }
        const double alpha = rz / curvature;
        for (int j = 0; j < count; j++) {
            x[j] += alpha * p[j];
            r[j] -= alpha * q[j];
        }
        memcpy(q, r, (size_t)count * sizeof(double));
        pgem_linear_solve(linear, q);
        const double next = pgem_dot(r, q, count);
        const double beta = next / rz;
        rz = next;
        for (int j = 0; j < count; j++) {
            p[j] = q[j] + beta * p[j];
        }
    }
    return sqrt(pgem_dot(r, r, count)) <= limit ? PGEM_OK : PGEM_ERR_NUMERIC;
}
