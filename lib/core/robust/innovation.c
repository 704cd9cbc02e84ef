/* A loop closure's innovation: its error measured against what the rest of the graph predicts
 * for its two poses. With whitened error r = U e (U^T U = Omega), whitened Jacobian A = U J and
 * a factor holding the loop at weight w (0: not in it), M = A H^-1 A^T has eigenpairs (mu_i,
 * v_i); the leave-one-out identities (Sherman-Morrison on the loop's own term) give the error
 * the map would predict without the loop, rho0_i = v_i^T (r + A step) / (1 - w mu_i), and the
 * map's covariance without it, mu0_i = mu_i / (1 - w mu_i), in whitened units. Then
 *     d^2 = sum_i rho0_i^2 / (1 + kappa_i mu0_i),
 * the Mahalanobis distance of the loop under the predicted covariance Omega^-1 + kappa J
 * Sigma_-k J^T, kappa the odometry allowance, graded per direction with the map's variance.
 * `step` is the Gauss-Newton step from the current estimate, so the estimate need not be at
 * the optimum of the current weights. One test over either factor (pgem_innovation_test): EM's
 * consistency test gets M from the batch factor here (its sparse inverse or a solve with L),
 * the online gate from its own factor in online/update.c (a solve along the two poses' paths;
 * the loop in no factor, no step). */
#include <math.h>
#include <string.h>

#include "robust/robust.h"

/* The map's variance, in units of the loop's own, at which half the odometry allowance
 * applies. */
#define PGEM_ALLOWANCE_HALF 10.0

/* Upper-triangular U with U^T U = Omega (n x n, row-major); Omega is positive definite
 * (checked when the edge was added). */
static void pgem_information_root(const double *information, int n, double *upper)
{
    memcpy(upper, information, (size_t)(n * n) * sizeof(double));
    (void)pgem_small_cholesky(upper, n, 0.0, 0);
}

/* out = U X for upper-triangular U and X (n x n row-major). */
static void pgem_upper_times(const double *upper, const double *x, int n, double *out)
{
    for (int r = 0; r < n; r++) {
        for (int c = 0; c < n; c++) {
            double sum = 0.0;
            for (int m = r; m < n; m++) {
                sum += upper[r * n + m] * x[m * n + c];
            }
            out[r * n + c] = sum;
        }
    }
}

/* Eigenvalues (values) and eigenvectors (columns of vectors) of the symmetric n x n matrix
 * a, destroyed, by cyclic Jacobi rotations. */
static void pgem_symmetric_eigen(double *a, int n, double *values, double *vectors)
{
    memset(vectors, 0, (size_t)(n * n) * sizeof(double));
    for (int i = 0; i < n; i++) {
        vectors[i * n + i] = 1.0;
    }
    for (int sweep = 0; sweep < 50; sweep++) {
        double off = 0.0, scale = 0.0;
        for (int p = 0; p < n; p++) {
            scale += a[p * n + p] * a[p * n + p];
            for (int q = p + 1; q < n; q++) {
                off += a[p * n + q] * a[p * n + q];
            }
        }
        if (!(off > 1e-30 * scale)) {
            break;
        }
        for (int p = 0; p < n; p++) {
            for (int q = p + 1; q < n; q++) {
                const double apq = a[p * n + q];
                if (apq == 0.0) {
                    continue;
                }
                const double theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                const double t = (theta >= 0.0 ? 1.0 : -1.0) /
                                 (fabs(theta) + sqrt(theta * theta + 1.0));
                const double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < n; k++) {
                    const double akp = a[k * n + p], akq = a[k * n + q];
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for (int k = 0; k < n; k++) {
                    const double apk = a[p * n + k], aqk = a[q * n + k];
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for (int k = 0; k < n; k++) {
                    const double vkp = vectors[k * n + p], vkq = vectors[k * n + q];
                    vectors[k * n + p] = c * vkp - s * vkq;
                    vectors[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    for (int i = 0; i < n; i++) {
        values[i] = a[i * n + i];
    }
}

/* U (e + J step): the whitened error the Gauss-Newton step (pgem_linear_step) predicts. */
static void pgem_predicted_error(const pgem_linear_t *linear, const pgem_store_t *store, int n,
                                 uint32_t k, const double *upper, const double *error,
                                 const double *a_from, const double *a_to, double *predicted)
{
    const double *step = pgem_linear_step(linear);
    const double *step_from = pgem_linear_pose_delta(linear, step, store->edge_from[k]);
    const double *step_to = pgem_linear_pose_delta(linear, step, store->edge_to[k]);
    for (int r = 0; r < n; r++) {
        double sum = 0.0;
        for (int c = r; c < n; c++) {
            sum += upper[r * n + c] * error[c];
        }
        for (int c = 0; c < n; c++) {
            if (step_from != NULL) {
                sum += a_from[r * n + c] * step_from[c];
            }
            if (step_to != NULL) {
                sum += a_to[r * n + c] * step_to[c];
            }
        }
        predicted[r] = sum;
    }
}

/* Standard deviation of the loop's rotation as the map predicts it without the loop: the
 * rotation block's trace of J Sigma_-k J^T = U^-1 M_0 U^-T, M_0 = V diag(mu0) V^T. */
static double pgem_rotation_sd(int n, const double *upper, const double *mu0, const double *vectors)
{
    double variance = 0.0;
    for (int i = 0; i < n; i++) {
        double g[PGEM_TANGENT_SIZE_MAX] = {0}; /* U^-1 v_i */
        for (int r = 0; r < n; r++) {
            g[r] = vectors[r * n + i];
        }
        pgem_small_upper_solve(upper, g, n);
        for (int r = n == 3 ? 2 : 3; r < n; r++) { /* the rotation rows: theta, or 3..5 */
            variance += mu0[i] * g[r] * g[r];
        }
    }
    return sqrt(variance);
}

void pgem_loop_whiten(const pgem_store_t *store, int n, uint32_t k, double *e, double *upper,
                      double *a_from, double *a_to)
{
    double jf[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    double jt[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    pgem_edge_error(store, k, e, jf, jt, n);
    pgem_information_root(store->edge_information + (size_t)k * (size_t)(n * n), n, upper);
    pgem_upper_times(upper, jf, n, a_from);
    pgem_upper_times(upper, jt, n, a_to);
}

/* Loop k whitened (pgem_loop_whiten), and the whitened error the Gauss-Newton step predicts
 * for it: what both the innovation and its screen start from. Zeroed where the analysers
 * cannot see the loops that fill them. */
typedef struct pgem_whitened_loop {
    double e[PGEM_TANGENT_SIZE_MAX];
    double predicted[PGEM_TANGENT_SIZE_MAX];
    double upper[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double a_from[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double a_to[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
} pgem_whitened_loop_t;

static void pgem_loop_predict(const pgem_linear_t *linear, const pgem_store_t *store, int n,
                              uint32_t k, pgem_whitened_loop_t *w)
{
    memset(w, 0, sizeof *w);
    pgem_loop_whiten(store, n, k, w->e, w->upper, w->a_from, w->a_to);
    pgem_predicted_error(linear, store, n, k, w->upper, w->e, w->a_from, w->a_to, w->predicted);
}

/* p^T (I + m)^-1 p for a symmetric positive semi-definite n x n m, by Cholesky of I + m from
 * its lower triangle (its pivots at least 1). */
static double pgem_shifted_form(int n, const double *m, const double *p)
{
    double u[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < n; j++) {
            u[j * n + i] = m[i * n + j] + (i == j ? 1.0 : 0.0);
        }
    }
    (void)pgem_small_cholesky(u, n, 1.0, 0);
    return pgem_small_form(u, p, n);
}

void pgem_innovation_test(int n, const double *upper, const double *predicted, double *m,
                          double weight, double inflation, pgem_innovation_t *out)
{
    double vectors[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    double values[PGEM_TANGENT_SIZE_MAX] = {0}, mu0[PGEM_TANGENT_SIZE_MAX] = {0};
    pgem_symmetric_eigen(m, n, values, vectors);
    out->distance = out->plain = 0.0;
    for (int i = 0; i < n; i++) {
        double rho = 0.0;
        for (int r = 0; r < n; r++) {
            rho += vectors[r * n + i] * predicted[r];
        }
        const double mu = values[i] > 0.0 ? values[i] : 0.0;
        const double shrink = fmax(1.0 - weight * mu, 1e-12); /* > 0 in exact arithmetic */
        const double loo = rho / shrink;
        mu0[i] = mu / shrink;
        /* the allowance grows with the map's variance: none for a prediction about as tight
         * as the loop, all of it for one from a long odometry chain (docs/design/innovation.md) */
        const double allowance = 1.0 + (inflation - 1.0) * mu0[i] / (mu0[i] + PGEM_ALLOWANCE_HALF);
        out->distance += loo * loo / (1.0 + allowance * mu0[i]);
        out->plain += loo * loo / (1.0 + mu0[i]);
    }
    out->rotation_sd = pgem_rotation_sd(n, upper, mu0, vectors);
}

void pgem_loop_innovation(pgem_linear_t *linear, const pgem_store_t *store, int n, uint32_t k,
                          double weight, double inflation, int from_inverse,
                          pgem_innovation_t *out)
{
    pgem_whitened_loop_t w;
    double m[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    pgem_loop_predict(linear, store, n, k, &w);
    if (from_inverse) {
        (void)pgem_linear_marginal_inverse(linear, store->edge_from[k], store->edge_to[k],
                                           w.a_from, w.a_to, m);
    } else {
        pgem_linear_marginal(linear, store->edge_from[k], store->edge_to[k], w.a_from, w.a_to, m);
    }
    pgem_innovation_test(n, w.upper, w.predicted, m, weight, inflation, out);
}

int pgem_loop_screen(pgem_linear_t *linear, const pgem_store_t *store, int n, uint32_t k,
                     double inflation, double gate, double *distance)
{
    pgem_whitened_loop_t w;
    double m[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    pgem_loop_predict(linear, store, n, k, &w);
    const double *predicted = w.predicted;
    const double chi2 = pgem_edge_mahalanobis(store, k, n);
    double norm = 0.0;
    for (int r = 0; r < n; r++) {
        norm += predicted[r] * predicted[r];
    }
    if (chi2 < gate && norm < gate) {
        *distance = chi2 > norm ? chi2 : norm; /* the innovation is at most the norm */
        return 1;
    }
    /* A H^-1 A^T <= 2 (A_f Z_ff A_f^T + A_t Z_tt A_t^T), and the allowance at most kappa */
    pgem_linear_marginal_diagonal(linear, store->edge_from[k], store->edge_to[k], w.a_from, w.a_to,
                                  m);
    for (int q = 0; q < n * n; q++) {
        m[q] *= 2.0 * inflation;
    }
    const double lower = pgem_shifted_form(n, m, predicted);
    if (chi2 >= gate && lower >= gate) {
        *distance = lower;
        return -1;
    }
    return 0;
}
