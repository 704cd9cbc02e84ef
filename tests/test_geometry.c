/* Geometry tests: Jacobians vs central differences, exp/log, group identities, aliasing, wrap. */
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <setjmp.h>
#include <cmocka.h>

#include <math.h>
#include <string.h>

#include <pgem/geometry.h>

#define PI 3.14159265358979323846
#define JACOBIAN_SAMPLES 5000
#define JACOBIAN_STEP 1e-6
#define JACOBIAN_TOLERANCE 1e-6
/* Configurations this close to a discontinuity of the error are not differentiated. */
#define DISCONTINUITY_MARGIN 1e-3

/* ---- deterministic random numbers (splitmix64) ---------------------------------------- */

typedef struct {
    uint64_t state;
} rng_t;

static uint64_t rng_next(rng_t *rng) {
    uint64_t z = (rng->state += UINT64_C(0x9E3779B97F4A7C15));
    z = (z ^ (z >> 30)) * UINT64_C(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94D049BB133111EB);
    return z ^ (z >> 31);
}

/* Uniform in [lo, hi). */
static double rng_uniform(rng_t *rng, double lo, double hi) {
    const double unit = (double)(rng_next(rng) >> 11) * (1.0 / 9007199254740992.0);
    return lo + (hi - lo) * unit;
}

static void random_unit_vector(rng_t *rng, double v[3]) {
    const double z = rng_uniform(rng, -1.0, 1.0);
    const double azimuth = rng_uniform(rng, -PI, PI);
    const double r = sqrt(1.0 - z * z);
    v[0] = r * cos(azimuth);
    v[1] = r * sin(azimuth);
    v[2] = z;
}

/* Uniformly distributed unit quaternion (Shoemake). */
static void random_quaternion(rng_t *rng, double q[4]) {
    const double u1 = rng_uniform(rng, 0.0, 1.0);
    const double a = rng_uniform(rng, 0.0, 2.0 * PI), b = rng_uniform(rng, 0.0, 2.0 * PI);
    q[0] = sqrt(1.0 - u1) * sin(a);
    q[1] = sqrt(1.0 - u1) * cos(a);
    q[2] = sqrt(u1) * sin(b);
    q[3] = sqrt(u1) * cos(b);
}

static void random_se2(rng_t *rng, double pose[3]) {
    pose[0] = rng_uniform(rng, -10.0, 10.0);
    pose[1] = rng_uniform(rng, -10.0, 10.0);
    pose[2] = rng_uniform(rng, -PI, PI);
}

static void random_se3(rng_t *rng, double pose[7]) {
    for (int k = 0; k < 3; ++k) {
        pose[k] = rng_uniform(rng, -10.0, 10.0);
    }
    random_quaternion(rng, pose + 3);
}

/* ---- comparison helpers ---------------------------------------------------------------- */

static void assert_near(double actual, double expected, double tolerance, const char *what) {
    if (!(fabs(actual - expected) <= tolerance)) {
        fail_msg("%s: got %.17g, expected %.17g (tolerance %g)", what, actual, expected,
                 tolerance);
    }
}

static void assert_angle_near(double actual, double expected, double tolerance, const char *what) {
    assert_near(pgem_wrap_angle(actual - expected), 0.0, tolerance, what);
}

static void assert_se2_near(const double a[3], const double b[3], double tolerance,
                            const char *what) {
    assert_near(a[0], b[0], tolerance, what);
    assert_near(a[1], b[1], tolerance, what);
    assert_angle_near(a[2], b[2], tolerance, what);
}

static void assert_vec_near(const double *a, const double *b, int n, double tolerance,
                            const char *what) {
    for (int k = 0; k < n; ++k) {
        assert_near(a[k], b[k], tolerance, what);
    }
}

/* Quaternions q and -q are the same rotation. */
static void assert_rotation_near(const double a[4], const double b[4], double tolerance,
                                 const char *what) {
    const double sign = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0 ? -1.0 : 1.0;
    for (int k = 0; k < 4; ++k) {
        assert_near(a[k], sign * b[k], tolerance, what);
    }
}

static void assert_se3_near(const double a[7], const double b[7], double tolerance,
                            const char *what) {
    assert_vec_near(a, b, 3, tolerance, what);
    assert_rotation_near(a + 3, b + 3, tolerance, what);
}

static void assert_identical(const double *a, const double *b, int n, const char *what) {
    for (int k = 0; k < n; ++k) {
        if (a[k] != b[k]) {
            fail_msg("%s: element %d differs: %.17g vs %.17g", what, k, a[k], b[k]);
        }
    }
}

/* ---- angle wrapping --------------------------------------------------------------------- */

static void test_wrap_angle_boundaries(void **state) {
    (void)state;
    assert_true(pgem_wrap_angle(0.0) == 0.0);
    assert_true(pgem_wrap_angle(PI) == PI);
    assert_true(pgem_wrap_angle(-PI) == PI);
    assert_true(pgem_wrap_angle(nextafter(-PI, 0.0)) == nextafter(-PI, 0.0));
    assert_true(pgem_wrap_angle(nextafter(PI, 0.0)) == nextafter(PI, 0.0));
    assert_true(pgem_wrap_angle(nextafter(PI, 4.0)) > -PI);
    assert_near(pgem_wrap_angle(nextafter(PI, 4.0)), -PI, 1e-15, "just above pi");
    assert_near(pgem_wrap_angle(3.0 * PI), PI, 1e-15, "3 pi");
    assert_near(fabs(pgem_wrap_angle(-3.0 * PI)), PI, 1e-15, "-3 pi");
    assert_near(pgem_wrap_angle(2.0 * PI), 0.0, 1e-15, "2 pi");
    assert_near(pgem_wrap_angle(-2.0 * PI), 0.0, 1e-15, "-2 pi");
    assert_near(pgem_wrap_angle(1.5 * PI), -0.5 * PI, 1e-15, "1.5 pi");
    assert_near(pgem_wrap_angle(-1.5 * PI), 0.5 * PI, 1e-15, "-1.5 pi");
    assert_near(pgem_wrap_angle(0.3 + 2.0 * PI * 1000.0), 0.3, 1e-11, "1000 turns");
    assert_near(pgem_wrap_angle(-0.3 - 2.0 * PI * 123456.0), -0.3, 1e-9, "-123456 turns");
}

static void test_wrap_angle_random(void **state) {
    rng_t rng = {11};
    (void)state;
    for (int n = 0; n < 100000; ++n) {
        const double angle = rng_uniform(&rng, -1e4, 1e4);
        const double wrapped = pgem_wrap_angle(angle);
        assert_true(wrapped > -PI && wrapped <= PI);
        /* Same direction: differs by a whole number of turns. */
        const double turns = (angle - wrapped) / (2.0 * PI);
        assert_near(turns, round(turns), 1e-9, "whole turns");
        assert_near(cos(wrapped), cos(angle), 1e-11, "cos");
        assert_near(sin(wrapped), sin(angle), 1e-11, "sin");
    }
}

/* ---- SE(2) ------------------------------------------------------------------------------ */

static void test_se2_group_identities(void **state) {
    rng_t rng = {21};
    (void)state;
    const double identity[3] = {0.0, 0.0, 0.0};
    for (int n = 0; n < 2000; ++n) {
        double a[3], b[3], c[3], inv[3], out[3], ab[3], back[3], bc[3], lhs[3], rhs[3];
        random_se2(&rng, a);
        random_se2(&rng, b);
        random_se2(&rng, c);
        pgem_se2_inverse(a, inv);
        pgem_se2_compose(a, inv, out);
        assert_se2_near(out, identity, 1e-13, "a * a^-1");
        pgem_se2_compose(inv, a, out);
        assert_se2_near(out, identity, 1e-13, "a^-1 * a");
        pgem_se2_compose(a, b, ab);
        pgem_se2_between(a, ab, back);
        assert_se2_near(back, b, 1e-12, "between(a, a * b)");
        pgem_se2_compose(inv, b, out);
        pgem_se2_between(a, b, back);
        assert_se2_near(back, out, 1e-12, "between = inverse * b");
        pgem_se2_compose(ab, c, lhs);
        pgem_se2_compose(b, c, bc);
        pgem_se2_compose(a, bc, rhs);
        assert_se2_near(lhs, rhs, 1e-12, "associativity");
        assert_true(ab[2] > -PI && ab[2] <= PI);
        assert_true(inv[2] > -PI && inv[2] <= PI);
    }
}

static void test_se2_known_values(void **state) {
    (void)state;
    const double a[3] = {1.0, 2.0, 0.5 * PI}, b[3] = {3.0, 0.0, 0.75 * PI};
    double out[3];
    pgem_se2_compose(a, b, out);
    const double composed[3] = {1.0, 5.0, -0.75 * PI};
    assert_se2_near(out, composed, 1e-14, "compose value");
    pgem_se2_inverse(a, out);
    const double inverted[3] = {-2.0, 1.0, -0.5 * PI};
    assert_se2_near(out, inverted, 1e-14, "inverse value");
    const double straight[3] = {0.0, 0.0, PI};
    pgem_se2_inverse(straight, out);
    assert_true(out[2] == PI);
}

/* Checks the series branches agree with the closed forms where they meet. */
static void test_se2_exp_log_threshold_continuity(void **state) {
    (void)state;
    const double edges[] = {1e-3, 1e-2, 1e-4};
    for (size_t k = 0; k < sizeof edges / sizeof edges[0]; ++k) {
        const double below[3] = {1.3, -0.7, nextafter(edges[k], 0.0)};
        const double above[3] = {1.3, -0.7, nextafter(edges[k], 1.0)};
        double exp_below[3], exp_above[3], log_below[3], log_above[3];
        pgem_se2_exp(below, exp_below);
        pgem_se2_exp(above, exp_above);
        assert_vec_near(exp_below, exp_above, 2, 1e-15, "se2 exp continuity");
        pgem_se2_log(exp_below, log_below);
        pgem_se2_log(exp_above, log_above);
        assert_vec_near(log_below, below, 2, 1e-15, "se2 log below");
        assert_vec_near(log_above, above, 2, 1e-15, "se2 log above");
    }
}

static void test_se2_exp_log(void **state) {
    rng_t rng = {31};
    (void)state;
    const double angles[] = {0.0,  1e-12, -1e-12,      1e-8,         -1e-8,        1e-4, 1e-3,
                             -1e-3, 0.5,  2.0,          -2.5,         PI - 1e-6,    PI - 1e-9,
                             PI,   -PI + 1e-9, -PI + 1e-6, PI - 1e-12};
    for (size_t k = 0; k < sizeof angles / sizeof angles[0]; ++k) {
        for (int n = 0; n < 50; ++n) {
            const double tangent[3] = {rng_uniform(&rng, -5.0, 5.0), rng_uniform(&rng, -5.0, 5.0),
                                       angles[k]};
            double pose[3], back[3], again[3];
            pgem_se2_exp(tangent, pose);
            pgem_se2_log(pose, back);
            assert_vec_near(back, tangent, 3, 1e-12, "se2 log(exp(t))");
            pgem_se2_exp(back, again);
            assert_se2_near(again, pose, 1e-12, "se2 exp(log(p))");
        }
    }
}

/* exp is a one-parameter subgroup: exp(s t) exp(r t) = exp((s + r) t); V = I would fail this. */
static void test_se2_exp_subgroup(void **state) {
    rng_t rng = {41};
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        double t[3], part_a[3], part_b[3], exp_a[3], exp_b[3], product[3], whole[3];
        const double s = rng_uniform(&rng, -1.0, 1.0), r = rng_uniform(&rng, -1.0, 1.0);
        random_se2(&rng, t);
        t[2] = rng_uniform(&rng, -1.5, 1.5);
        for (int k = 0; k < 3; ++k) {
            part_a[k] = s * t[k];
            part_b[k] = r * t[k];
            whole[k] = (s + r) * t[k];
        }
        pgem_se2_exp(part_a, exp_a);
        pgem_se2_exp(part_b, exp_b);
        pgem_se2_compose(exp_a, exp_b, product);
        pgem_se2_exp(whole, whole);
        assert_se2_near(product, whole, 1e-12, "se2 exp subgroup");
    }
    /* A quarter turn while moving 1 forward ends at (2/pi, 2/pi). */
    const double quarter[3] = {1.0, 0.0, 0.5 * PI};
    double pose[3];
    pgem_se2_exp(quarter, pose);
    const double expected[3] = {2.0 / PI, 2.0 / PI, 0.5 * PI};
    assert_se2_near(pose, expected, 1e-15, "se2 exp quarter turn");
}

static void test_se2_boxplus(void **state) {
    rng_t rng = {51};
    (void)state;
    const double zero[3] = {0.0, 0.0, 0.0};
    for (int n = 0; n < 1000; ++n) {
        double x[3], out[3];
        random_se2(&rng, x);
        pgem_se2_boxplus(x, zero, out);
        assert_identical(out, x, 3, "se2 boxplus zero");
    }
    const double x[3] = {1.0, 2.0, 3.0}, delta[3] = {0.5, -1.0, 0.5};
    double out[3];
    pgem_se2_boxplus(x, delta, out);
    assert_near(out[0], 1.5, 0.0, "boxplus x");
    assert_near(out[1], 1.0, 0.0, "boxplus y");
    assert_near(out[2], 3.5 - 2.0 * PI, 1e-15, "boxplus wraps");
}

static void test_se2_error_values(void **state) {
    (void)state;
    double e[3], ji[9], jj[9], e_plain[3];
    const double xi[3] = {0.0, 0.0, 0.5 * PI}, xj[3] = {0.0, 1.0, 0.5 * PI + 0.1};
    const double z[3] = {1.0, 0.0, 0.5};
    pgem_se2_error(xi, xj, z, e, ji, jj);
    const double expected[3] = {0.0, 0.0, -0.4};
    assert_vec_near(e, expected, 3, 1e-15, "se2 error value");
    pgem_se2_error(xi, xj, z, e_plain, NULL, NULL);
    assert_identical(e_plain, e, 3, "se2 error without Jacobians");
    /* The angle error wraps: 3 -> -3 is a small positive turn. */
    const double a[3] = {0.0, 0.0, 3.0}, b[3] = {0.0, 0.0, -3.0}, none[3] = {0.0, 0.0, 0.0};
    pgem_se2_error(a, b, none, e, NULL, jj);
    assert_near(e[2], 2.0 * PI - 6.0, 1e-15, "se2 error wraps");
    /* A perfect measurement gives zero error. */
    rng_t rng = {61};
    for (int n = 0; n < 1000; ++n) {
        double p[3], q[3], m[3];
        random_se2(&rng, p);
        random_se2(&rng, q);
        pgem_se2_between(p, q, m);
        pgem_se2_error(p, q, m, e, ji, NULL);
        assert_vec_near(e, none, 3, 1e-12, "se2 error of exact measurement");
    }
}

typedef struct {
    double max_abs;
    double max_rel;
} discrepancy_t;

/* Compares two row-major dim x dim Jacobians entry by entry and records the worst gap. */
static void compare_jacobian(const double *analytic, const double *numeric, int dim,
                             discrepancy_t *worst, const char *what) {
    for (int k = 0; k < dim * dim; ++k) {
        const double diff = fabs(analytic[k] - numeric[k]);
        const double scale = fmax(1.0, fabs(analytic[k]));
        worst->max_abs = fmax(worst->max_abs, diff);
        worst->max_rel = fmax(worst->max_rel, diff / scale);
        if (!(diff <= JACOBIAN_TOLERANCE * scale)) {
            fail_msg("%s entry (%d, %d): analytic %.12g numeric %.12g", what, k / dim, k % dim,
                     analytic[k], numeric[k]);
        }
    }
}

/* Central differences of the SE(2) error wrt the additive perturbation of xi or xj. */
static void se2_numeric_jacobians(const double xi[3], const double xj[3], const double z[3],
                                  double ji[9], double jj[9]) {
    for (int c = 0; c < 3; ++c) {
        double step[3] = {0.0, 0.0, 0.0}, back[3] = {0.0, 0.0, 0.0};
        double plus[3], minus[3], e_plus[3], e_minus[3];
        step[c] = JACOBIAN_STEP;
        back[c] = -JACOBIAN_STEP;
        pgem_se2_boxplus(xi, step, plus);
        pgem_se2_boxplus(xi, back, minus);
        pgem_se2_error(plus, xj, z, e_plus, NULL, NULL);
        pgem_se2_error(minus, xj, z, e_minus, NULL, NULL);
        for (int r = 0; r < 3; ++r) {
            ji[r * 3 + c] = (e_plus[r] - e_minus[r]) / (2.0 * JACOBIAN_STEP);
        }
        pgem_se2_boxplus(xj, step, plus);
        pgem_se2_boxplus(xj, back, minus);
        pgem_se2_error(xi, plus, z, e_plus, NULL, NULL);
        pgem_se2_error(xi, minus, z, e_minus, NULL, NULL);
        for (int r = 0; r < 3; ++r) {
            jj[r * 3 + c] = (e_plus[r] - e_minus[r]) / (2.0 * JACOBIAN_STEP);
        }
    }
}

/* Half the measurements are near-consistent (small error), half arbitrary. */
static void se2_random_measurement(rng_t *rng, const double xi[3], const double xj[3],
                                   double z[3]) {
    if (rng_next(rng) & 1u) {
        const double noise[3] = {rng_uniform(rng, -0.1, 0.1), rng_uniform(rng, -0.1, 0.1),
                                 rng_uniform(rng, -0.1, 0.1)};
        pgem_se2_between(xi, xj, z);
        pgem_se2_boxplus(z, noise, z);
    } else {
        random_se2(rng, z);
    }
}

static void test_se2_jacobians(void **state) {
    rng_t rng = {71};
    discrepancy_t worst = {0.0, 0.0};
    int checked = 0, skipped = 0;
    (void)state;
    while (checked < JACOBIAN_SAMPLES) {
        double xi[3], xj[3], z[3], e[3], ji[9], jj[9], ni[9], nj[9];
        random_se2(&rng, xi);
        random_se2(&rng, xj);
        se2_random_measurement(&rng, xi, xj, z);
        pgem_se2_error(xi, xj, z, e, ji, jj);
        if (PI - fabs(e[2]) < DISCONTINUITY_MARGIN) {
            ++skipped;
            continue;
        }
        se2_numeric_jacobians(xi, xj, z, ni, nj);
        compare_jacobian(ji, ni, 3, &worst, "se2 jacobian_i");
        compare_jacobian(jj, nj, 3, &worst, "se2 jacobian_j");
        ++checked;
    }
    assert_true(skipped < JACOBIAN_SAMPLES / 10);
    print_message("se2: %d configurations, %d skipped, max |diff| %.3g, max rel %.3g\n", checked,
                  skipped, worst.max_abs, worst.max_rel);
}

/* ---- quaternions and SO(3) -------------------------------------------------------------- */

static void matrix_vector(const double m[9], const double v[3], double out[3]) {
    for (int r = 0; r < 3; ++r) {
        out[r] = m[r * 3] * v[0] + m[r * 3 + 1] * v[1] + m[r * 3 + 2] * v[2];
    }
}

static void test_quaternion_helpers(void **state) {
    rng_t rng = {81};
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        double a[4], b[4], ab[4], v[3], rotated[3], via_matrix[3], nested[3], ra[9], rab[9];
        random_quaternion(&rng, a);
        random_quaternion(&rng, b);
        random_unit_vector(&rng, v);
        v[0] *= 3.0;
        pgem_quat_rotate(a, v, rotated);
        pgem_quat_to_matrix(a, ra);
        matrix_vector(ra, v, via_matrix);
        assert_vec_near(rotated, via_matrix, 3, 1e-14, "rotate vs matrix");
        assert_near(sqrt(rotated[0] * rotated[0] + rotated[1] * rotated[1] +
                         rotated[2] * rotated[2]),
                    sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]), 1e-14, "rotation keeps length");
        pgem_quat_multiply(a, b, ab);
        pgem_quat_rotate(b, v, nested);
        pgem_quat_rotate(a, nested, nested);
        pgem_quat_to_matrix(ab, rab);
        matrix_vector(rab, v, via_matrix);
        assert_vec_near(nested, via_matrix, 3, 1e-14, "R(a b) = R(a) R(b)");
        double scaled[4] = {2.5 * a[0], 2.5 * a[1], 2.5 * a[2], 2.5 * a[3]};
        assert_near(pgem_quat_normalize(scaled), 2.5, 1e-14, "normalize returns norm");
        assert_vec_near(scaled, a, 4, 1e-15, "normalize");
    }
    const double quarter_z[4] = {0.0, 0.0, sqrt(0.5), sqrt(0.5)};
    const double x_axis[3] = {1.0, 0.0, 0.0}, y_axis[3] = {0.0, 1.0, 0.0};
    double out[3];
    pgem_quat_rotate(quarter_z, x_axis, out);
    assert_vec_near(out, y_axis, 3, 1e-15, "quarter turn about z");
}

static void random_axis_angle(rng_t *rng, double angle, double phi[3]) {
    random_unit_vector(rng, phi);
    for (int k = 0; k < 3; ++k) {
        phi[k] *= angle;
    }
}

static void test_so3_exp_log(void **state) {
    rng_t rng = {91};
    (void)state;
    const double angles[] = {0.0, 1e-12, 1e-8, 1e-4, 1e-3 * (1.0 - 1e-9), 1e-3 * (1.0 + 1e-9),
                             0.1, 1.0,   3.0,  PI - 1e-6, PI - 1e-9, PI - 1e-12};
    for (size_t k = 0; k < sizeof angles / sizeof angles[0]; ++k) {
        for (int n = 0; n < 100; ++n) {
            double phi[3], q[4], back[3], again[4], minus_q[4];
            random_axis_angle(&rng, angles[k], phi);
            pgem_so3_exp(phi, q);
            assert_near(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0, 1e-15,
                        "so3 exp unit");
            assert_near(q[3], cos(0.5 * angles[k]), 1e-15, "so3 exp w");
            pgem_so3_log(q, back);
            assert_vec_near(back, phi, 3, 1e-13 * fmax(1.0, angles[k]), "so3 log(exp(phi))");
            pgem_so3_exp(back, again);
            assert_rotation_near(again, q, 1e-15, "so3 exp(log(q))");
            for (int i = 0; i < 4; ++i) {
                minus_q[i] = -q[i];
            }
            pgem_so3_log(minus_q, back);
            assert_vec_near(back, phi, 3, 1e-13 * fmax(1.0, angles[k]), "so3 log(-q)");
        }
    }
    /* Angles beyond pi come back as the shorter rotation about the opposite axis. */
    for (int n = 0; n < 1000; ++n) {
        const double angle = rng_uniform(&rng, PI + 1e-6, 2.0 * PI - 1e-6);
        double phi[3], q[4], back[3];
        random_axis_angle(&rng, angle, phi);
        pgem_so3_exp(phi, q);
        pgem_so3_log(q, back);
        const double norm = sqrt(back[0] * back[0] + back[1] * back[1] + back[2] * back[2]);
        assert_true(norm <= PI);
        for (int i = 0; i < 3; ++i) {
            assert_near(back[i], phi[i] * (1.0 - 2.0 * PI / angle), 1e-12, "so3 log wraps");
        }
    }
    /* Exactly pi: the axis may come back either way, but the angle is pi. */
    const double half_turn[4] = {0.0, 1.0, 0.0, 0.0};
    double phi[3];
    pgem_so3_log(half_turn, phi);
    assert_near(fabs(phi[1]), PI, 1e-15, "so3 log at pi");
}

/* exp(phi) rotates a vector perpendicular to phi by |phi| and keeps phi fixed. */
static void test_so3_exp_geometry(void **state) {
    rng_t rng = {101};
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        const double angle = rng_uniform(&rng, 0.0, PI);
        double axis[3], phi[3], q[4], fixed[3], perp[3], turned[3], helper[3] = {1.0, 0.0, 0.0};
        random_unit_vector(&rng, axis);
        for (int k = 0; k < 3; ++k) {
            phi[k] = angle * axis[k];
        }
        if (fabs(axis[0]) > 0.9) {
            helper[0] = 0.0;
            helper[1] = 1.0;
        }
        perp[0] = axis[1] * helper[2] - axis[2] * helper[1];
        perp[1] = axis[2] * helper[0] - axis[0] * helper[2];
        perp[2] = axis[0] * helper[1] - axis[1] * helper[0];
        pgem_so3_exp(phi, q);
        pgem_quat_rotate(q, axis, fixed);
        assert_vec_near(fixed, axis, 3, 1e-14, "axis is fixed");
        pgem_quat_rotate(q, perp, turned);
        const double perp_sq = perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2];
        const double cosine =
            (turned[0] * perp[0] + turned[1] * perp[1] + turned[2] * perp[2]) / perp_sq;
        const double handed = (axis[0] * (perp[1] * turned[2] - perp[2] * turned[1]) +
                               axis[1] * (perp[2] * turned[0] - perp[0] * turned[2]) +
                               axis[2] * (perp[0] * turned[1] - perp[1] * turned[0])) /
                              perp_sq;
        assert_near(atan2(handed, cosine), angle, 1e-12, "rotation angle (right-handed)");
    }
}

/* ---- SE(3) ------------------------------------------------------------------------------ */

static void test_se3_group_identities(void **state) {
    rng_t rng = {111};
    (void)state;
    const double identity[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
    for (int n = 0; n < 2000; ++n) {
        double a[7], b[7], c[7], inv[7], out[7], ab[7], back[7], bc[7], lhs[7], rhs[7];
        random_se3(&rng, a);
        random_se3(&rng, b);
        random_se3(&rng, c);
        pgem_se3_inverse(a, inv);
        pgem_se3_compose(a, inv, out);
        assert_se3_near(out, identity, 1e-13, "a * a^-1");
        pgem_se3_compose(inv, a, out);
        assert_se3_near(out, identity, 1e-13, "a^-1 * a");
        pgem_se3_compose(a, b, ab);
        pgem_se3_between(a, ab, back);
        assert_se3_near(back, b, 1e-12, "between(a, a * b)");
        pgem_se3_compose(inv, b, out);
        pgem_se3_between(a, b, back);
        assert_se3_near(back, out, 1e-12, "between = inverse * b");
        pgem_se3_compose(ab, c, lhs);
        pgem_se3_compose(b, c, bc);
        pgem_se3_compose(a, bc, rhs);
        assert_se3_near(lhs, rhs, 1e-12, "associativity");
    }
    /* compose applies b in a's frame: a translation of 1 along x turned a quarter about z. */
    const double a[7] = {1.0, 2.0, 3.0, 0.0, 0.0, sqrt(0.5), sqrt(0.5)};
    const double b[7] = {1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
    const double expected[7] = {1.0, 3.0, 3.0, 0.0, 0.0, sqrt(0.5), sqrt(0.5)};
    double out[7];
    pgem_se3_compose(a, b, out);
    assert_se3_near(out, expected, 1e-15, "se3 compose value");
}

static void test_se3_exp_log(void **state) {
    rng_t rng = {121};
    (void)state;
    const double angles[] = {0.0, 1e-12, 1e-8, 1e-4, 1e-3 * (1.0 - 1e-9), 1e-3 * (1.0 + 1e-9),
                             0.1, 1.0,   3.0,  PI - 1e-6, PI - 1e-9};
    for (size_t k = 0; k < sizeof angles / sizeof angles[0]; ++k) {
        for (int n = 0; n < 100; ++n) {
            double tangent[6], pose[7], back[6], again[7];
            for (int i = 0; i < 3; ++i) {
                tangent[i] = rng_uniform(&rng, -5.0, 5.0);
            }
            random_axis_angle(&rng, angles[k], tangent + 3);
            pgem_se3_exp(tangent, pose);
            pgem_se3_log(pose, back);
            assert_vec_near(back, tangent, 6, 1e-12, "se3 log(exp(t))");
            pgem_se3_exp(back, again);
            assert_se3_near(again, pose, 1e-12, "se3 exp(log(p))");
        }
    }
    /* The series branches agree with the closed forms where they meet. */
    /* A long translation magnifies any mismatch of the V coefficients. */
    const double below[6] = {30.0, -20.0, 5.0, 0.0, 0.0, nextafter(1e-3, 0.0)};
    const double above[6] = {30.0, -20.0, 5.0, 0.0, 0.0, nextafter(1e-3, 1.0)};
    double exp_below[7], exp_above[7], log_below[6], log_above[6];
    pgem_se3_exp(below, exp_below);
    pgem_se3_exp(above, exp_above);
    assert_vec_near(exp_below, exp_above, 7, 2e-14, "se3 exp continuity");
    pgem_se3_log(exp_below, log_below);
    pgem_se3_log(exp_above, log_above);
    assert_vec_near(log_below, below, 6, 2e-14, "se3 log below");
    assert_vec_near(log_above, above, 6, 2e-14, "se3 log above");
}

static void test_se3_exp_subgroup_and_planar(void **state) {
    rng_t rng = {131};
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        double t[6], part_a[6], part_b[6], whole[6], exp_a[7], exp_b[7], product[7], exp_whole[7];
        const double s = rng_uniform(&rng, -1.0, 1.0), r = rng_uniform(&rng, -1.0, 1.0);
        for (int i = 0; i < 3; ++i) {
            t[i] = rng_uniform(&rng, -5.0, 5.0);
        }
        random_axis_angle(&rng, rng_uniform(&rng, 0.0, 1.5), t + 3);
        for (int i = 0; i < 6; ++i) {
            part_a[i] = s * t[i];
            part_b[i] = r * t[i];
            whole[i] = (s + r) * t[i];
        }
        pgem_se3_exp(part_a, exp_a);
        pgem_se3_exp(part_b, exp_b);
        pgem_se3_compose(exp_a, exp_b, product);
        pgem_se3_exp(whole, exp_whole);
        assert_se3_near(product, exp_whole, 1e-12, "se3 exp subgroup");
        /* A planar twist moves exactly like the SE(2) exponential. */
        const double planar[6] = {t[0], t[1], 0.0, 0.0, 0.0, t[5]};
        const double planar2[3] = {t[0], t[1], t[5]};
        double pose3[7], pose2[3];
        pgem_se3_exp(planar, pose3);
        pgem_se2_exp(planar2, pose2);
        assert_near(pose3[0], pose2[0], 1e-13, "planar x");
        assert_near(pose3[1], pose2[1], 1e-13, "planar y");
        assert_near(pose3[2], 0.0, 0.0, "planar z");
        assert_angle_near(2.0 * atan2(pose3[5], pose3[6]), pose2[2], 1e-13, "planar angle");
    }
}

static void test_se3_boxplus(void **state) {
    rng_t rng = {141};
    (void)state;
    const double zero[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (int n = 0; n < 1000; ++n) {
        double x[7], out[7], delta[6], step[7], expected[7];
        random_se3(&rng, x);
        pgem_se3_boxplus(x, zero, out);
        assert_vec_near(out, x, 7, 1e-15, "se3 boxplus zero");
        /* Decoupled: translation moves by R rho, rotation by R Exp(phi). */
        for (int i = 0; i < 3; ++i) {
            delta[i] = rng_uniform(&rng, -1.0, 1.0);
        }
        random_axis_angle(&rng, rng_uniform(&rng, 0.0, 2.0), delta + 3);
        pgem_se3_boxplus(x, delta, out);
        step[0] = delta[0];
        step[1] = delta[1];
        step[2] = delta[2];
        pgem_so3_exp(delta + 3, step + 3);
        pgem_se3_compose(x, step, expected);
        assert_se3_near(out, expected, 1e-14, "se3 boxplus = x * (rho, Exp(phi))");
        assert_near(out[3] * out[3] + out[4] * out[4] + out[5] * out[5] + out[6] * out[6], 1.0,
                    1e-15, "se3 boxplus keeps unit quaternion");
    }
}

static void test_se3_error_values(void **state) {
    (void)state;
    double e[6], e_plain[6], ji[36], jj[36];
    const double identity[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
    /* 1.5 turns of pi about z has w < 0; the error flips to w >= 0. */
    const double xj[7] = {1.0, 2.0, 3.0, 0.0, 0.0, sin(0.75 * PI), cos(0.75 * PI)};
    pgem_se3_error(identity, xj, identity, e, ji, jj);
    const double expected[6] = {1.0, 2.0, 3.0, 0.0, 0.0, -sin(0.75 * PI)};
    assert_vec_near(e, expected, 6, 1e-15, "se3 error flips sign");
    pgem_se3_error(identity, xj, identity, e_plain, NULL, NULL);
    assert_identical(e_plain, e, 6, "se3 error without Jacobians");
    /* A rotation error of a about an axis shows as sin(a / 2) axis. */
    const double z[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
    double xk[7];
    const double phi[3] = {0.0, 0.3, 0.0};
    for (int k = 0; k < 3; ++k) {
        xk[k] = 0.0;
    }
    pgem_so3_exp(phi, xk + 3);
    pgem_se3_error(identity, xk, z, e, NULL, NULL);
    const double rotation_error[6] = {0.0, 0.0, 0.0, 0.0, sin(0.15), 0.0};
    assert_vec_near(e, rotation_error, 6, 1e-15, "se3 rotation error");
    /* A perfect measurement gives zero error. */
    rng_t rng = {151};
    for (int n = 0; n < 1000; ++n) {
        double p[7], q[7], m[7];
        random_se3(&rng, p);
        random_se3(&rng, q);
        pgem_se3_between(p, q, m);
        pgem_se3_error(p, q, m, e, NULL, jj);
        assert_vec_near(e, z, 6, 1e-12, "se3 error of exact measurement");
    }
}

/* Central differences of the SE(3) error wrt the right decoupled perturbation of xi or xj. */
static void se3_numeric_jacobians(const double xi[7], const double xj[7], const double z[7],
                                  double ji[36], double jj[36]) {
    for (int c = 0; c < 6; ++c) {
        double step[6] = {0.0}, back[6] = {0.0};
        double plus[7], minus[7], e_plus[6], e_minus[6];
        step[c] = JACOBIAN_STEP;
        back[c] = -JACOBIAN_STEP;
        pgem_se3_boxplus(xi, step, plus);
        pgem_se3_boxplus(xi, back, minus);
        pgem_se3_error(plus, xj, z, e_plus, NULL, NULL);
        pgem_se3_error(minus, xj, z, e_minus, NULL, NULL);
        for (int r = 0; r < 6; ++r) {
            ji[r * 6 + c] = (e_plus[r] - e_minus[r]) / (2.0 * JACOBIAN_STEP);
        }
        pgem_se3_boxplus(xj, step, plus);
        pgem_se3_boxplus(xj, back, minus);
        pgem_se3_error(xi, plus, z, e_plus, NULL, NULL);
        pgem_se3_error(xi, minus, z, e_minus, NULL, NULL);
        for (int r = 0; r < 6; ++r) {
            jj[r * 6 + c] = (e_plus[r] - e_minus[r]) / (2.0 * JACOBIAN_STEP);
        }
    }
}

/* Half the measurements are near-consistent (small error), half arbitrary. */
static void se3_random_measurement(rng_t *rng, const double xi[7], const double xj[7],
                                   double z[7]) {
    if (rng_next(rng) & 1u) {
        double noise[6];
        for (int k = 0; k < 6; ++k) {
            noise[k] = rng_uniform(rng, -0.1, 0.1);
        }
        pgem_se3_between(xi, xj, z);
        pgem_se3_boxplus(z, noise, z);
    } else {
        random_se3(rng, z);
    }
}

static void test_se3_jacobians(void **state) {
    rng_t rng = {161};
    discrepancy_t worst = {0.0, 0.0};
    int checked = 0, skipped = 0;
    (void)state;
    while (checked < JACOBIAN_SAMPLES) {
        double xi[7], xj[7], z[7], e[6], ji[36], jj[36], ni[36], nj[36];
        random_se3(&rng, xi);
        random_se3(&rng, xj);
        se3_random_measurement(&rng, xi, xj, z);
        pgem_se3_error(xi, xj, z, e, ji, jj);
        const double w_squared = 1.0 - (e[3] * e[3] + e[4] * e[4] + e[5] * e[5]);
        if (w_squared < DISCONTINUITY_MARGIN * DISCONTINUITY_MARGIN) {
            ++skipped;
            continue;
        }
        se3_numeric_jacobians(xi, xj, z, ni, nj);
        compare_jacobian(ji, ni, 6, &worst, "se3 jacobian_i");
        compare_jacobian(jj, nj, 6, &worst, "se3 jacobian_j");
        ++checked;
    }
    assert_true(skipped < JACOBIAN_SAMPLES / 10);
    print_message("se3: %d configurations, %d skipped, max |diff| %.3g, max rel %.3g\n", checked,
                  skipped, worst.max_abs, worst.max_rel);
}

/* At a zero error the Jacobians have the textbook form [-I 0; 0 -I/2] and [I 0; 0 I/2]. */
static void test_se3_jacobian_at_identity(void **state) {
    (void)state;
    const double pose[7] = {1.0, -2.0, 0.5, 0.0, sqrt(0.5), 0.0, sqrt(0.5)};
    const double identity[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
    double e[6], ji[36], jj[36];
    pgem_se3_error(pose, pose, identity, e, ji, jj);
    for (int r = 0; r < 6; ++r) {
        assert_near(e[r], 0.0, 1e-15, "zero error");
        for (int c = 0; c < 6; ++c) {
            const double expected = r != c ? 0.0 : (r < 3 ? 1.0 : 0.5);
            assert_near(jj[r * 6 + c], expected, 1e-15, "jacobian_j at identity");
            assert_near(ji[r * 6 + c], -expected, 1e-15, "jacobian_i at identity");
        }
    }
}

/* ---- aliasing ----------------------------------------------------------------------------- */

typedef void (*binary_op)(const double *, const double *, double *);

/* Runs op(a, b) into a fresh buffer, then with out aliasing a, b, and both; all must agree. */
static void check_binary_aliasing(binary_op op, const double *a, const double *b, int n_a,
                                  int n_b, int n_out, const char *what) {
    double expected[8], buffer[8], other[8];
    op(a, b, expected);
    memcpy(buffer, a, (size_t)n_a * sizeof(double));
    op(buffer, b, buffer);
    assert_identical(buffer, expected, n_out, what);
    memcpy(buffer, b, (size_t)n_b * sizeof(double));
    op(a, buffer, buffer);
    assert_identical(buffer, expected, n_out, what);
    if (n_a == n_b) {
        op(a, a, expected);
        memcpy(other, a, (size_t)n_a * sizeof(double));
        op(other, other, other);
        assert_identical(other, expected, n_out, what);
    }
}

typedef void (*unary_op)(const double *, double *);

static void check_unary_aliasing(unary_op op, const double *a, int n, const char *what) {
    double expected[8], buffer[8];
    op(a, expected);
    memcpy(buffer, a, (size_t)n * sizeof(double));
    op(buffer, buffer);
    assert_identical(buffer, expected, n, what);
}

static void se2_compose_op(const double *a, const double *b, double *out) {
    pgem_se2_compose(a, b, out);
}
static void se2_between_op(const double *a, const double *b, double *out) {
    pgem_se2_between(a, b, out);
}
static void se2_boxplus_op(const double *a, const double *b, double *out) {
    pgem_se2_boxplus(a, b, out);
}
static void quat_multiply_op(const double *a, const double *b, double *out) {
    pgem_quat_multiply(a, b, out);
}
static void quat_rotate_op(const double *q, const double *v, double *out) {
    pgem_quat_rotate(q, v, out);
}
static void se3_compose_op(const double *a, const double *b, double *out) {
    pgem_se3_compose(a, b, out);
}
static void se3_between_op(const double *a, const double *b, double *out) {
    pgem_se3_between(a, b, out);
}
static void se3_boxplus_op(const double *a, const double *b, double *out) {
    pgem_se3_boxplus(a, b, out);
}
static void se2_inverse_op(const double *a, double *out) {
    pgem_se2_inverse(a, out);
}
static void se3_inverse_op(const double *a, double *out) {
    pgem_se3_inverse(a, out);
}

static void test_aliasing(void **state) {
    rng_t rng = {171};
    (void)state;
    for (int n = 0; n < 200; ++n) {
        double a2[3], b2[3], qa[4], qb[4], v[3], a3[7], b3[7], d3[6];
        random_se2(&rng, a2);
        random_se2(&rng, b2);
        random_quaternion(&rng, qa);
        random_quaternion(&rng, qb);
        random_unit_vector(&rng, v);
        random_se3(&rng, a3);
        random_se3(&rng, b3);
        for (int k = 0; k < 6; ++k) {
            d3[k] = rng_uniform(&rng, -1.0, 1.0);
        }
        check_binary_aliasing(se2_compose_op, a2, b2, 3, 3, 3, "se2_compose aliasing");
        check_binary_aliasing(se2_between_op, a2, b2, 3, 3, 3, "se2_between aliasing");
        check_binary_aliasing(se2_boxplus_op, a2, b2, 3, 3, 3, "se2_boxplus aliasing");
        check_unary_aliasing(se2_inverse_op, a2, 3, "se2_inverse aliasing");
        check_binary_aliasing(quat_multiply_op, qa, qb, 4, 4, 4, "quat_multiply aliasing");
        double expected[3], buffer[3];
        quat_rotate_op(qa, v, expected);
        memcpy(buffer, v, sizeof buffer);
        pgem_quat_rotate(qa, buffer, buffer);
        assert_identical(buffer, expected, 3, "quat_rotate aliasing");
        check_binary_aliasing(se3_compose_op, a3, b3, 7, 7, 7, "se3_compose aliasing");
        check_binary_aliasing(se3_between_op, a3, b3, 7, 7, 7, "se3_between aliasing");
        check_unary_aliasing(se3_inverse_op, a3, 7, "se3_inverse aliasing");
        double boxed[7], alias[7];
        se3_boxplus_op(a3, d3, boxed);
        memcpy(alias, a3, sizeof alias);
        pgem_se3_boxplus(alias, d3, alias);
        assert_identical(alias, boxed, 7, "se3_boxplus aliasing");
    }
}

int main(void) {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_wrap_angle_boundaries),
        cmocka_unit_test(test_wrap_angle_random),
        cmocka_unit_test(test_se2_group_identities),
        cmocka_unit_test(test_se2_known_values),
        cmocka_unit_test(test_se2_exp_log_threshold_continuity),
        cmocka_unit_test(test_se2_exp_log),
        cmocka_unit_test(test_se2_exp_subgroup),
        cmocka_unit_test(test_se2_boxplus),
        cmocka_unit_test(test_se2_error_values),
        cmocka_unit_test(test_se2_jacobians),
        cmocka_unit_test(test_quaternion_helpers),
        cmocka_unit_test(test_so3_exp_log),
        cmocka_unit_test(test_so3_exp_geometry),
        cmocka_unit_test(test_se3_group_identities),
        cmocka_unit_test(test_se3_exp_log),
        cmocka_unit_test(test_se3_exp_subgroup_and_planar),
        cmocka_unit_test(test_se3_boxplus),
        cmocka_unit_test(test_se3_error_values),
        cmocka_unit_test(test_se3_jacobians),
        cmocka_unit_test(test_se3_jacobian_at_identity),
        cmocka_unit_test(test_aliasing),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
