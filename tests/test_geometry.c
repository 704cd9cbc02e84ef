/* Geometry tests: Jacobians vs central differences, exp/log, group identities, aliasing, wrap. */
#include "test_util.h"

#define PI 3.14159265358979323846
#define JACOBIAN_SAMPLES 5000
#define JACOBIAN_STEP 1e-6
#define JACOBIAN_TOLERANCE 1e-6
/* Configurations this close to a discontinuity of the error are not differentiated. */
#define DISCONTINUITY_MARGIN 1e-3

/* Buffer sizes that fit either group: SE(3) poses have 7 numbers, its tangents 6. */
#define POSE_MAX 7
#define TANGENT_MAX 6
#define JACOBIAN_MAX (TANGENT_MAX * TANGENT_MAX)
#define LABEL_SIZE 64

/* ---- random samples (test_util.h's splitmix64) ----------------------------------------- */

static void random_unit_vector(test_rng_t *rng, double v[3]) {
    const double z = test_uniform_in(rng, -1.0, 1.0);
    const double azimuth = test_uniform_in(rng, -PI, PI);
    const double r = sqrt(1.0 - z * z);
    v[0] = r * cos(azimuth);
    v[1] = r * sin(azimuth);
    v[2] = z;
}

static void random_axis_angle(test_rng_t *rng, double angle, double phi[3]) {
    random_unit_vector(rng, phi);
    for (int k = 0; k < 3; ++k) {
        phi[k] *= angle;
    }
}

/* Uniformly distributed unit quaternion (Shoemake). */
static void random_quaternion(test_rng_t *rng, double q[4]) {
    const double u1 = test_uniform_in(rng, 0.0, 1.0);
    const double a = test_uniform_in(rng, 0.0, 2.0 * PI), b = test_uniform_in(rng, 0.0, 2.0 * PI);
    q[0] = sqrt(1.0 - u1) * sin(a);
    q[1] = sqrt(1.0 - u1) * cos(a);
    q[2] = sqrt(u1) * sin(b);
    q[3] = sqrt(u1) * cos(b);
}

static void random_se2(test_rng_t *rng, double pose[3]) {
    pose[0] = test_uniform_in(rng, -10.0, 10.0);
    pose[1] = test_uniform_in(rng, -10.0, 10.0);
    pose[2] = test_uniform_in(rng, -PI, PI);
}

static void random_se3(test_rng_t *rng, double pose[7]) {
    for (int k = 0; k < 3; ++k) {
        pose[k] = test_uniform_in(rng, -10.0, 10.0);
    }
    random_quaternion(rng, pose + 3);
}

/* Tangents for the exp/log round trips: translation in [-5, 5), rotation by exactly angle. */
static void random_se2_tangent(test_rng_t *rng, double angle, double tangent[3]) {
    tangent[0] = test_uniform_in(rng, -5.0, 5.0);
    tangent[1] = test_uniform_in(rng, -5.0, 5.0);
    tangent[2] = angle;
}

static void random_se3_tangent(test_rng_t *rng, double angle, double tangent[6]) {
    for (int k = 0; k < 3; ++k) {
        tangent[k] = test_uniform_in(rng, -5.0, 5.0);
    }
    random_axis_angle(rng, angle, tangent + 3);
}

/* ---- comparison helpers ---------------------------------------------------------------- */

static void assert_angle_near(double actual, double expected, double tolerance, const char *what) {
    assert_near_labelled(pgem_wrap_angle(actual - expected), 0.0, tolerance, what);
}

static void assert_se2_near(const double a[3], const double b[3], double tolerance,
                            const char *what) {
    assert_near_labelled(a[0], b[0], tolerance, what);
    assert_near_labelled(a[1], b[1], tolerance, what);
    assert_angle_near(a[2], b[2], tolerance, what);
}

static void assert_vec_near(const double *a, const double *b, int n, double tolerance,
                            const char *what) {
    for (int k = 0; k < n; ++k) {
        assert_near_labelled(a[k], b[k], tolerance, what);
    }
}

/* Quaternions q and -q are the same rotation. */
static void assert_rotation_near(const double a[4], const double b[4], double tolerance,
                                 const char *what) {
    const double sign = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0.0 ? -1.0 : 1.0;
    for (int k = 0; k < 4; ++k) {
        assert_near_labelled(a[k], sign * b[k], tolerance, what);
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

/* ---- the two groups, as the shared checks below see them ------------------------------- */

typedef void (*binary_op)(const double *, const double *, double *);
typedef void (*unary_op)(const double *, double *);
typedef void (*error_op)(const double *, const double *, const double *, double *, double *,
                         double *);

typedef struct {
    const char *name; /* "se2" or "se3": the prefix of every message */
    int pose_size;    /* 3 or 7 */
    int tangent_size; /* 3 or 6; errors and steps have this size, Jacobians its square */
    const double *identity;
    error_op error;
    binary_op boxplus, between, compose;
    unary_op inverse, exp_map, log_map;
    void (*random_pose)(test_rng_t *rng, double *pose);
    void (*random_tangent)(test_rng_t *rng, double angle, double *tangent);
    void (*assert_pose_near)(const double *a, const double *b, double tolerance,
                             const char *what);
    /* Asserts a computed pose is in canonical form; NULL where nothing is asserted. */
    void (*assert_canonical)(const double *pose);
    /* Nonzero for an error too close to a discontinuity to differentiate numerically. */
    int (*near_discontinuity)(const double *e);
} group_t;

static void assert_se2_canonical(const double pose[3]) {
    assert_true(pose[2] > -PI && pose[2] <= PI);
}

/* The wrapped angle error jumps at +-pi. */
static int se2_near_discontinuity(const double e[3]) {
    return PI - fabs(e[2]) < DISCONTINUITY_MARGIN;
}

/* The sign flip that keeps w >= 0 jumps at w = 0. */
static int se3_near_discontinuity(const double e[6]) {
    const double w_squared = 1.0 - (e[3] * e[3] + e[4] * e[4] + e[5] * e[5]);
    return w_squared < DISCONTINUITY_MARGIN * DISCONTINUITY_MARGIN;
}

static const double se2_identity[3] = {0.0, 0.0, 0.0};
static const double se3_identity[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};

static const group_t se2_group = {
    .name = "se2",
    .pose_size = 3,
    .tangent_size = 3,
    .identity = se2_identity,
    .error = pgem_se2_error,
    .boxplus = pgem_se2_boxplus,
    .between = pgem_se2_between,
    .compose = pgem_se2_compose,
    .inverse = pgem_se2_inverse,
    .exp_map = pgem_se2_exp,
    .log_map = pgem_se2_log,
    .random_pose = random_se2,
    .random_tangent = random_se2_tangent,
    .assert_pose_near = assert_se2_near,
    .assert_canonical = assert_se2_canonical,
    .near_discontinuity = se2_near_discontinuity,
};

static const group_t se3_group = {
    .name = "se3",
    .pose_size = 7,
    .tangent_size = 6,
    .identity = se3_identity,
    .error = pgem_se3_error,
    .boxplus = pgem_se3_boxplus,
    .between = pgem_se3_between,
    .compose = pgem_se3_compose,
    .inverse = pgem_se3_inverse,
    .exp_map = pgem_se3_exp,
    .log_map = pgem_se3_log,
    .random_pose = random_se3,
    .random_tangent = random_se3_tangent,
    .assert_pose_near = assert_se3_near,
    .assert_canonical = NULL,
    .near_discontinuity = se3_near_discontinuity,
};

/* Writes the message "<group name><suffix>" into label and returns it. */
static const char *group_label(const group_t *group, const char *suffix,
                               char label[LABEL_SIZE]) {
    snprintf(label, LABEL_SIZE, "%s%s", group->name, suffix);
    return label;
}

/* ---- checks shared by both groups ------------------------------------------------------- */

/* Inverse, between and associativity on random triples. */
static void check_group_identities(const group_t *g, test_rng_t *rng, int samples) {
    for (int n = 0; n < samples; ++n) {
        double a[POSE_MAX], b[POSE_MAX], c[POSE_MAX], inv[POSE_MAX], out[POSE_MAX];
        double ab[POSE_MAX], back[POSE_MAX], bc[POSE_MAX], lhs[POSE_MAX], rhs[POSE_MAX];
        g->random_pose(rng, a);
        g->random_pose(rng, b);
        g->random_pose(rng, c);
        g->inverse(a, inv);
        g->compose(a, inv, out);
        g->assert_pose_near(out, g->identity, 1e-13, "a * a^-1");
        g->compose(inv, a, out);
        g->assert_pose_near(out, g->identity, 1e-13, "a^-1 * a");
        g->compose(a, b, ab);
        g->between(a, ab, back);
        g->assert_pose_near(back, b, 1e-12, "between(a, a * b)");
        g->compose(inv, b, out);
        g->between(a, b, back);
        g->assert_pose_near(back, out, 1e-12, "between = inverse * b");
        g->compose(ab, c, lhs);
        g->compose(b, c, bc);
        g->compose(a, bc, rhs);
        g->assert_pose_near(lhs, rhs, 1e-12, "associativity");
        if (g->assert_canonical != NULL) {
            g->assert_canonical(ab);
            g->assert_canonical(inv);
        }
    }
}

/* per_angle random tangents for each rotation angle: log(exp(t)) = t and exp(log(p)) = p. */
static void check_exp_log_round_trips(const group_t *g, test_rng_t *rng, const double *angles,
                                      size_t angle_count, int per_angle) {
    char log_of_exp[LABEL_SIZE], exp_of_log[LABEL_SIZE];
    group_label(g, " log(exp(t))", log_of_exp);
    group_label(g, " exp(log(p))", exp_of_log);
    for (size_t k = 0; k < angle_count; ++k) {
        for (int n = 0; n < per_angle; ++n) {
            double tangent[TANGENT_MAX], pose[POSE_MAX], back[TANGENT_MAX], again[POSE_MAX];
            g->random_tangent(rng, angles[k], tangent);
            g->exp_map(tangent, pose);
            g->log_map(pose, back);
            assert_vec_near(back, tangent, g->tangent_size, 1e-12, log_of_exp);
            g->exp_map(back, again);
            g->assert_pose_near(again, pose, 1e-12, exp_of_log);
        }
    }
}

/* The series branches agree with the closed forms where they meet: exp and log of tangents
 * just below and just above a threshold, over the first exp_count / log_count numbers. */
static void check_exp_log_continuity(const group_t *g, const double *below, const double *above,
                                     int exp_count, int log_count, double tolerance) {
    double exp_below[POSE_MAX], exp_above[POSE_MAX], log_below[TANGENT_MAX], log_above[TANGENT_MAX];
    char label[LABEL_SIZE];
    g->exp_map(below, exp_below);
    g->exp_map(above, exp_above);
    assert_vec_near(exp_below, exp_above, exp_count, tolerance,
                    group_label(g, " exp continuity", label));
    g->log_map(exp_below, log_below);
    g->log_map(exp_above, log_above);
    assert_vec_near(log_below, below, log_count, tolerance, group_label(g, " log below", label));
    assert_vec_near(log_above, above, log_count, tolerance, group_label(g, " log above", label));
}

/* exp is a one-parameter subgroup: exp(s t) exp(r t) = exp((s + r) t); V = I would fail this. */
static void check_exp_subgroup(const group_t *g, const double *t, double s, double r) {
    double part_a[TANGENT_MAX], part_b[TANGENT_MAX], whole[TANGENT_MAX];
    double exp_a[POSE_MAX], exp_b[POSE_MAX], product[POSE_MAX], exp_whole[POSE_MAX];
    char label[LABEL_SIZE];
    for (int k = 0; k < g->tangent_size; ++k) {
        part_a[k] = s * t[k];
        part_b[k] = r * t[k];
        whole[k] = (s + r) * t[k];
    }
    g->exp_map(part_a, exp_a);
    g->exp_map(part_b, exp_b);
    g->compose(exp_a, exp_b, product);
    g->exp_map(whole, exp_whole);
    g->assert_pose_near(product, exp_whole, 1e-12, group_label(g, " exp subgroup", label));
}

/* The error with both Jacobians is expected; without Jacobians it is the same to the bit. */
static void check_error_value(const group_t *g, const double *xi, const double *xj,
                              const double *z, const double *expected, const char *what) {
    double e[TANGENT_MAX], e_plain[TANGENT_MAX], ji[JACOBIAN_MAX], jj[JACOBIAN_MAX];
    char label[LABEL_SIZE];
    g->error(xi, xj, z, e, ji, jj);
    assert_vec_near(e, expected, g->tangent_size, 1e-15, what);
    g->error(xi, xj, z, e_plain, NULL, NULL);
    assert_identical(e_plain, e, g->tangent_size,
                     group_label(g, " error without Jacobians", label));
}

/* A perfect measurement gives zero error; jacobian_i and jacobian_j (either may be NULL) are
 * passed on to the error. */
static void check_exact_measurements(const group_t *g, test_rng_t *rng, int samples,
                                     double *jacobian_i, double *jacobian_j) {
    const double zero[TANGENT_MAX] = {0.0};
    char label[LABEL_SIZE];
    group_label(g, " error of exact measurement", label);
    for (int n = 0; n < samples; ++n) {
        double p[POSE_MAX], q[POSE_MAX], m[POSE_MAX], e[TANGENT_MAX];
        g->random_pose(rng, p);
        g->random_pose(rng, q);
        g->between(p, q, m);
        g->error(p, q, m, e, jacobian_i, jacobian_j);
        assert_vec_near(e, zero, g->tangent_size, 1e-12, label);
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

/* Central differences of the error wrt the group's perturbation (boxplus) of xi
 * (wrt_xj == 0) or of xj (wrt_xj != 0). */
static void numeric_jacobian(const group_t *g, const double *xi, const double *xj,
                             const double *z, int wrt_xj, double *jacobian) {
    const int dim = g->tangent_size;
    const double *x = wrt_xj ? xj : xi;
    for (int c = 0; c < dim; ++c) {
        double step[TANGENT_MAX] = {0.0}, back[TANGENT_MAX] = {0.0};
        double plus[POSE_MAX], minus[POSE_MAX], e_plus[TANGENT_MAX], e_minus[TANGENT_MAX];
        step[c] = JACOBIAN_STEP;
        back[c] = -JACOBIAN_STEP;
        g->boxplus(x, step, plus);
        g->boxplus(x, back, minus);
        if (wrt_xj) {
            g->error(xi, plus, z, e_plus, NULL, NULL);
            g->error(xi, minus, z, e_minus, NULL, NULL);
        } else {
            g->error(plus, xj, z, e_plus, NULL, NULL);
            g->error(minus, xj, z, e_minus, NULL, NULL);
        }
        for (int r = 0; r < dim; ++r) {
            jacobian[r * dim + c] = (e_plus[r] - e_minus[r]) / (2.0 * JACOBIAN_STEP);
        }
    }
}

/* Half the measurements are near-consistent (small error), half arbitrary. */
static void random_measurement(const group_t *g, test_rng_t *rng, const double *xi,
                               const double *xj, double *z) {
    if (test_next(rng) & 1u) {
        double noise[TANGENT_MAX];
        for (int k = 0; k < g->tangent_size; ++k) {
            noise[k] = test_uniform_in(rng, -0.1, 0.1);
        }
        g->between(xi, xj, z);
        g->boxplus(z, noise, z);
    } else {
        g->random_pose(rng, z);
    }
}

/* Analytic Jacobians against central differences on JACOBIAN_SAMPLES random configurations
 * away from the error's discontinuity; fewer than one in ten may be skipped. */
static void check_jacobians(const group_t *g, test_rng_t *rng) {
    discrepancy_t worst = {0.0, 0.0};
    int checked = 0, skipped = 0;
    char label_i[LABEL_SIZE], label_j[LABEL_SIZE];
    group_label(g, " jacobian_i", label_i);
    group_label(g, " jacobian_j", label_j);
    while (checked < JACOBIAN_SAMPLES) {
        double xi[POSE_MAX], xj[POSE_MAX], z[POSE_MAX], e[TANGENT_MAX];
        double ji[JACOBIAN_MAX], jj[JACOBIAN_MAX], ni[JACOBIAN_MAX], nj[JACOBIAN_MAX];
        g->random_pose(rng, xi);
        g->random_pose(rng, xj);
        random_measurement(g, rng, xi, xj, z);
        g->error(xi, xj, z, e, ji, jj);
        if (g->near_discontinuity(e)) {
            ++skipped;
            continue;
        }
        numeric_jacobian(g, xi, xj, z, 0, ni);
        numeric_jacobian(g, xi, xj, z, 1, nj);
        compare_jacobian(ji, ni, g->tangent_size, &worst, label_i);
        compare_jacobian(jj, nj, g->tangent_size, &worst, label_j);
        ++checked;
    }
    assert_true(skipped < JACOBIAN_SAMPLES / 10);
    print_message("%s: %d configurations, %d skipped, max |diff| %.3g, max rel %.3g\n", g->name,
                  checked, skipped, worst.max_abs, worst.max_rel);
}

/* Runs op(a, b) into a fresh buffer, then with out aliasing a; where a and b are of a kind
 * (n_a == n_b) also with out aliasing b, and both. All must agree. */
static void check_binary_aliasing(binary_op op, const double *a, const double *b, int n_a,
                                  int n_b, int n_out, const char *what) {
    double expected[8], buffer[8], other[8];
    op(a, b, expected);
    memcpy(buffer, a, (size_t)n_a * sizeof(double));
    op(buffer, b, buffer);
    assert_identical(buffer, expected, n_out, what);
    if (n_a == n_b) {
        memcpy(buffer, b, (size_t)n_b * sizeof(double));
        op(a, buffer, buffer);
        assert_identical(buffer, expected, n_out, what);
        op(a, a, expected);
        memcpy(other, a, (size_t)n_a * sizeof(double));
        op(other, other, other);
        assert_identical(other, expected, n_out, what);
    }
}

static void check_unary_aliasing(unary_op op, const double *a, int n, const char *what) {
    double expected[8], buffer[8];
    op(a, expected);
    memcpy(buffer, a, (size_t)n * sizeof(double));
    op(buffer, buffer);
    assert_identical(buffer, expected, n, what);
}

/* compose, between, boxplus (by delta) and inverse of one group with out aliasing inputs. */
static void check_group_aliasing(const group_t *g, const double *a, const double *b,
                                 const double *delta) {
    const int pose = g->pose_size;
    char label[LABEL_SIZE];
    check_binary_aliasing(g->compose, a, b, pose, pose, pose,
                          group_label(g, "_compose aliasing", label));
    check_binary_aliasing(g->between, a, b, pose, pose, pose,
                          group_label(g, "_between aliasing", label));
    check_binary_aliasing(g->boxplus, a, delta, pose, g->tangent_size, pose,
                          group_label(g, "_boxplus aliasing", label));
    check_unary_aliasing(g->inverse, a, pose, group_label(g, "_inverse aliasing", label));
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
    assert_near_labelled(pgem_wrap_angle(nextafter(PI, 4.0)), -PI, 1e-15, "just above pi");
    assert_near_labelled(pgem_wrap_angle(3.0 * PI), PI, 1e-15, "3 pi");
    assert_near_labelled(fabs(pgem_wrap_angle(-3.0 * PI)), PI, 1e-15, "-3 pi");
    assert_near_labelled(pgem_wrap_angle(2.0 * PI), 0.0, 1e-15, "2 pi");
    assert_near_labelled(pgem_wrap_angle(-2.0 * PI), 0.0, 1e-15, "-2 pi");
    assert_near_labelled(pgem_wrap_angle(1.5 * PI), -0.5 * PI, 1e-15, "1.5 pi");
    assert_near_labelled(pgem_wrap_angle(-1.5 * PI), 0.5 * PI, 1e-15, "-1.5 pi");
    assert_near_labelled(pgem_wrap_angle(0.3 + 2.0 * PI * 1000.0), 0.3, 1e-11, "1000 turns");
    assert_near_labelled(pgem_wrap_angle(-0.3 - 2.0 * PI * 123456.0), -0.3, 1e-9, "-123456 turns");
}

static void test_wrap_angle_random(void **state) {
    test_rng_t rng = {11};
    (void)state;
    for (int n = 0; n < 100000; ++n) {
        const double angle = test_uniform_in(&rng, -1e4, 1e4);
        const double wrapped = pgem_wrap_angle(angle);
        assert_true(wrapped > -PI && wrapped <= PI);
        /* Same direction: differs by a whole number of turns. */
        const double turns = (angle - wrapped) / (2.0 * PI);
        assert_near_labelled(turns, round(turns), 1e-9, "whole turns");
        assert_near_labelled(cos(wrapped), cos(angle), 1e-11, "cos");
        assert_near_labelled(sin(wrapped), sin(angle), 1e-11, "sin");
    }
}

/* ---- SE(2) ------------------------------------------------------------------------------ */

static void test_se2_group_identities(void **state) {
    test_rng_t rng = {21};
    (void)state;
    check_group_identities(&se2_group, &rng, 2000);
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
        check_exp_log_continuity(&se2_group, below, above, 2, 2, 1e-15);
    }
}

static void test_se2_exp_log(void **state) {
    test_rng_t rng = {31};
    (void)state;
    const double angles[] = {0.0,  1e-12, -1e-12,      1e-8,         -1e-8,        1e-4, 1e-3,
                             -1e-3, 0.5,  2.0,          -2.5,         PI - 1e-6,    PI - 1e-9,
                             PI,   -PI + 1e-9, -PI + 1e-6, PI - 1e-12};
    check_exp_log_round_trips(&se2_group, &rng, angles, sizeof angles / sizeof angles[0], 50);
}

static void test_se2_exp_subgroup(void **state) {
    test_rng_t rng = {41};
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        double t[3];
        const double s = test_uniform_in(&rng, -1.0, 1.0), r = test_uniform_in(&rng, -1.0, 1.0);
        random_se2(&rng, t);
        t[2] = test_uniform_in(&rng, -1.5, 1.5);
        check_exp_subgroup(&se2_group, t, s, r);
    }
    /* A quarter turn while moving 1 forward ends at (2/pi, 2/pi). */
    const double quarter[3] = {1.0, 0.0, 0.5 * PI};
    double pose[3];
    pgem_se2_exp(quarter, pose);
    const double expected[3] = {2.0 / PI, 2.0 / PI, 0.5 * PI};
    assert_se2_near(pose, expected, 1e-15, "se2 exp quarter turn");
}

static void test_se2_boxplus(void **state) {
    test_rng_t rng = {51};
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
    assert_near_labelled(out[0], 1.5, 0.0, "boxplus x");
    assert_near_labelled(out[1], 1.0, 0.0, "boxplus y");
    assert_near_labelled(out[2], 3.5 - 2.0 * PI, 1e-15, "boxplus wraps");
}

static void test_se2_error_values(void **state) {
    (void)state;
    double e[3], ji[9], jj[9];
    const double xi[3] = {0.0, 0.0, 0.5 * PI}, xj[3] = {0.0, 1.0, 0.5 * PI + 0.1};
    const double z[3] = {1.0, 0.0, 0.5};
    const double expected[3] = {0.0, 0.0, -0.4};
    check_error_value(&se2_group, xi, xj, z, expected, "se2 error value");
    /* The angle error wraps: 3 -> -3 is a small positive turn. */
    const double a[3] = {0.0, 0.0, 3.0}, b[3] = {0.0, 0.0, -3.0};
    pgem_se2_error(a, b, se2_identity, e, NULL, jj);
    assert_near_labelled(e[2], 2.0 * PI - 6.0, 1e-15, "se2 error wraps");
    test_rng_t rng = {61};
    check_exact_measurements(&se2_group, &rng, 1000, ji, NULL);
}

static void test_se2_jacobians(void **state) {
    test_rng_t rng = {71};
    (void)state;
    check_jacobians(&se2_group, &rng);
}

/* ---- quaternions and SO(3) -------------------------------------------------------------- */

static void matrix_vector(const double m[9], const double v[3], double out[3]) {
    for (int r = 0; r < 3; ++r) {
        out[r] = m[r * 3] * v[0] + m[r * 3 + 1] * v[1] + m[r * 3 + 2] * v[2];
    }
}

static void test_quaternion_helpers(void **state) {
    test_rng_t rng = {81};
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
        assert_near_labelled(sqrt(rotated[0] * rotated[0] + rotated[1] * rotated[1] +
                                  rotated[2] * rotated[2]),
                             sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]), 1e-14,
                             "rotation keeps length");
        pgem_quat_multiply(a, b, ab);
        pgem_quat_rotate(b, v, nested);
        pgem_quat_rotate(a, nested, nested);
        pgem_quat_to_matrix(ab, rab);
        matrix_vector(rab, v, via_matrix);
        assert_vec_near(nested, via_matrix, 3, 1e-14, "R(a b) = R(a) R(b)");
        double scaled[4] = {2.5 * a[0], 2.5 * a[1], 2.5 * a[2], 2.5 * a[3]};
        assert_near_labelled(pgem_quat_normalize(scaled), 2.5, 1e-14, "normalize returns norm");
        assert_vec_near(scaled, a, 4, 1e-15, "normalize");
    }
    const double quarter_z[4] = {0.0, 0.0, sqrt(0.5), sqrt(0.5)};
    const double x_axis[3] = {1.0, 0.0, 0.0}, y_axis[3] = {0.0, 1.0, 0.0};
    double out[3];
    pgem_quat_rotate(quarter_z, x_axis, out);
    assert_vec_near(out, y_axis, 3, 1e-15, "quarter turn about z");
}

static void test_so3_exp_log(void **state) {
    test_rng_t rng = {91};
    (void)state;
    const double angles[] = {0.0, 1e-12, 1e-8, 1e-4, 1e-3 * (1.0 - 1e-9), 1e-3 * (1.0 + 1e-9),
                             0.1, 1.0,   3.0,  PI - 1e-6, PI - 1e-9, PI - 1e-12};
    for (size_t k = 0; k < sizeof angles / sizeof angles[0]; ++k) {
        for (int n = 0; n < 100; ++n) {
            double phi[3], q[4], back[3], again[4], minus_q[4];
            random_axis_angle(&rng, angles[k], phi);
            pgem_so3_exp(phi, q);
            assert_near_labelled(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3], 1.0,
                                 1e-15, "so3 exp unit");
            assert_near_labelled(q[3], cos(0.5 * angles[k]), 1e-15, "so3 exp w");
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
        const double angle = test_uniform_in(&rng, PI + 1e-6, 2.0 * PI - 1e-6);
        double phi[3], q[4], back[3];
        random_axis_angle(&rng, angle, phi);
        pgem_so3_exp(phi, q);
        pgem_so3_log(q, back);
        const double norm = sqrt(back[0] * back[0] + back[1] * back[1] + back[2] * back[2]);
        assert_true(norm <= PI);
        for (int i = 0; i < 3; ++i) {
            assert_near_labelled(back[i], phi[i] * (1.0 - 2.0 * PI / angle), 1e-12,
                                 "so3 log wraps");
        }
    }
    /* Exactly pi: the axis may come back either way, but the angle is pi. */
    const double half_turn[4] = {0.0, 1.0, 0.0, 0.0};
    double phi[3];
    pgem_so3_log(half_turn, phi);
    assert_near_labelled(fabs(phi[1]), PI, 1e-15, "so3 log at pi");
}

/* exp(phi) rotates a vector perpendicular to phi by |phi| and keeps phi fixed. */
static void test_so3_exp_geometry(void **state) {
    test_rng_t rng = {101};
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        const double angle = test_uniform_in(&rng, 0.0, PI);
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
        assert_near_labelled(atan2(handed, cosine), angle, 1e-12, "rotation angle (right-handed)");
    }
}

/* ---- SE(3) ------------------------------------------------------------------------------ */

static void test_se3_group_identities(void **state) {
    test_rng_t rng = {111};
    (void)state;
    check_group_identities(&se3_group, &rng, 2000);
    /* compose applies b in a's frame: a translation of 1 along x turned a quarter about z. */
    const double a[7] = {1.0, 2.0, 3.0, 0.0, 0.0, sqrt(0.5), sqrt(0.5)};
    const double b[7] = {1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
    const double expected[7] = {1.0, 3.0, 3.0, 0.0, 0.0, sqrt(0.5), sqrt(0.5)};
    double out[7];
    pgem_se3_compose(a, b, out);
    assert_se3_near(out, expected, 1e-15, "se3 compose value");
}

static void test_se3_exp_log(void **state) {
    test_rng_t rng = {121};
    (void)state;
    const double angles[] = {0.0, 1e-12, 1e-8, 1e-4, 1e-3 * (1.0 - 1e-9), 1e-3 * (1.0 + 1e-9),
                             0.1, 1.0,   3.0,  PI - 1e-6, PI - 1e-9};
    check_exp_log_round_trips(&se3_group, &rng, angles, sizeof angles / sizeof angles[0], 100);
    /* A long translation magnifies any mismatch of the V coefficients. */
    const double below[6] = {30.0, -20.0, 5.0, 0.0, 0.0, nextafter(1e-3, 0.0)};
    const double above[6] = {30.0, -20.0, 5.0, 0.0, 0.0, nextafter(1e-3, 1.0)};
    check_exp_log_continuity(&se3_group, below, above, 7, 6, 2e-14);
}

static void test_se3_exp_subgroup_and_planar(void **state) {
    test_rng_t rng = {131};
    (void)state;
    for (int n = 0; n < 2000; ++n) {
        double t[6];
        const double s = test_uniform_in(&rng, -1.0, 1.0), r = test_uniform_in(&rng, -1.0, 1.0);
        for (int i = 0; i < 3; ++i) {
            t[i] = test_uniform_in(&rng, -5.0, 5.0);
        }
        random_axis_angle(&rng, test_uniform_in(&rng, 0.0, 1.5), t + 3);
        check_exp_subgroup(&se3_group, t, s, r);
        /* A planar twist moves exactly like the SE(2) exponential. */
        const double planar[6] = {t[0], t[1], 0.0, 0.0, 0.0, t[5]};
        const double planar2[3] = {t[0], t[1], t[5]};
        double pose3[7], pose2[3];
        pgem_se3_exp(planar, pose3);
        pgem_se2_exp(planar2, pose2);
        assert_near_labelled(pose3[0], pose2[0], 1e-13, "planar x");
        assert_near_labelled(pose3[1], pose2[1], 1e-13, "planar y");
        assert_near_labelled(pose3[2], 0.0, 0.0, "planar z");
        assert_angle_near(2.0 * atan2(pose3[5], pose3[6]), pose2[2], 1e-13, "planar angle");
    }
}

static void test_se3_boxplus(void **state) {
    test_rng_t rng = {141};
    (void)state;
    const double zero[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
    for (int n = 0; n < 1000; ++n) {
        double x[7], out[7], delta[6], step[7], expected[7];
        random_se3(&rng, x);
        pgem_se3_boxplus(x, zero, out);
        assert_vec_near(out, x, 7, 1e-15, "se3 boxplus zero");
        /* Decoupled: translation moves by R rho, rotation by R Exp(phi). */
        for (int i = 0; i < 3; ++i) {
            delta[i] = test_uniform_in(&rng, -1.0, 1.0);
        }
        random_axis_angle(&rng, test_uniform_in(&rng, 0.0, 2.0), delta + 3);
        pgem_se3_boxplus(x, delta, out);
        step[0] = delta[0];
        step[1] = delta[1];
        step[2] = delta[2];
        pgem_so3_exp(delta + 3, step + 3);
        pgem_se3_compose(x, step, expected);
        assert_se3_near(out, expected, 1e-14, "se3 boxplus = x * (rho, Exp(phi))");
        assert_near_labelled(out[3] * out[3] + out[4] * out[4] + out[5] * out[5] +
                                 out[6] * out[6],
                             1.0, 1e-15, "se3 boxplus keeps unit quaternion");
    }
}

static void test_se3_error_values(void **state) {
    (void)state;
    double e[6], jj[36];
    /* 1.5 turns of pi about z has w < 0; the error flips to w >= 0. */
    const double xj[7] = {1.0, 2.0, 3.0, 0.0, 0.0, sin(0.75 * PI), cos(0.75 * PI)};
    const double expected[6] = {1.0, 2.0, 3.0, 0.0, 0.0, -sin(0.75 * PI)};
    check_error_value(&se3_group, se3_identity, xj, se3_identity, expected,
                      "se3 error flips sign");
    /* A rotation error of a about an axis shows as sin(a / 2) axis. */
    double xk[7];
    const double phi[3] = {0.0, 0.3, 0.0};
    for (int k = 0; k < 3; ++k) {
        xk[k] = 0.0;
    }
    pgem_so3_exp(phi, xk + 3);
    pgem_se3_error(se3_identity, xk, se3_identity, e, NULL, NULL);
    const double rotation_error[6] = {0.0, 0.0, 0.0, 0.0, sin(0.15), 0.0};
    assert_vec_near(e, rotation_error, 6, 1e-15, "se3 rotation error");
    test_rng_t rng = {151};
    check_exact_measurements(&se3_group, &rng, 1000, NULL, jj);
}

static void test_se3_jacobians(void **state) {
    test_rng_t rng = {161};
    (void)state;
    check_jacobians(&se3_group, &rng);
}

/* At a zero error the Jacobians have the textbook form [-I 0; 0 -I/2] and [I 0; 0 I/2]. */
static void test_se3_jacobian_at_identity(void **state) {
    (void)state;
    const double pose[7] = {1.0, -2.0, 0.5, 0.0, sqrt(0.5), 0.0, sqrt(0.5)};
    double e[6], ji[36], jj[36];
    pgem_se3_error(pose, pose, se3_identity, e, ji, jj);
    for (int r = 0; r < 6; ++r) {
        assert_near_labelled(e[r], 0.0, 1e-15, "zero error");
        for (int c = 0; c < 6; ++c) {
            const double expected = r != c ? 0.0 : (r < 3 ? 1.0 : 0.5);
            assert_near_labelled(jj[r * 6 + c], expected, 1e-15, "jacobian_j at identity");
            assert_near_labelled(ji[r * 6 + c], -expected, 1e-15, "jacobian_i at identity");
        }
    }
}

/* ---- aliasing ----------------------------------------------------------------------------- */

static void test_aliasing(void **state) {
    test_rng_t rng = {171};
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
            d3[k] = test_uniform_in(&rng, -1.0, 1.0);
        }
        check_group_aliasing(&se2_group, a2, b2, b2);
        check_binary_aliasing(pgem_quat_multiply, qa, qb, 4, 4, 4, "quat_multiply aliasing");
        double expected[3], buffer[3];
        pgem_quat_rotate(qa, v, expected);
        memcpy(buffer, v, sizeof buffer);
        pgem_quat_rotate(qa, buffer, buffer);
        assert_identical(buffer, expected, 3, "quat_rotate aliasing");
        check_group_aliasing(&se3_group, a3, b3, d3);
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
