/* Two edges that meet at a pose composed into one edge between their other ends: the pose
 * removed from the graph (online/compact.c). The removed pose is marginalised out of the two
 * edges' quadratic form about the current estimate, and the composed edge keeps that form
 * whole: its information gives the curvature, its measurement (the composition of the two,
 * moved by the pull the pair's residual exerts on the far pose) the gradient. On a solved map
 * the kept poses' optimum is then unchanged (M3500's chain poses removed: 2e-9 m); on a
 * dead-reckoned one the measurement is the composition itself. */
#include <math.h>
#include <string.h>

#include "graph/graph.h"

/* The error of an edge from xi to xj with measurement z (into error unless NULL), and its
 * Jacobians. */
static void pgem_compose_error(int three, const double *xi, const double *xj, const double *z,
                               double *error, double *jacobian_i, double *jacobian_j)
{
    double unused[PGEM_TANGENT_SIZE_MAX];
    double *e = error != NULL ? error : unused;
    if (three) {
        pgem_se3_error(xi, xj, z, e, jacobian_i, jacobian_j);
    } else {
        pgem_se2_error(xi, xj, z, e, jacobian_i, jacobian_j);
    }
}

/* The measurement z with t2v(z^-1 x) = e (the edge error's own chart: x, y, theta in 2D;
 * translation and quaternion vector in 3D): z = x * v2t(e)^-1. Returns 0 when e is not a
 * small finite step (then the caller keeps its measurement). */
static int pgem_compose_shifted(int three, const double *x, const double *e, double *z)
{
    double step[PGEM_POSE_SIZE_MAX], inverse[PGEM_POSE_SIZE_MAX];
    const int n = three ? 6 : 3;
    for (int r = 0; r < n; r++) {
        if (!(e[r] == e[r]) || e[r] > 1.0 || e[r] < -1.0) {
            return 0;
        }
    }
    if (three) {
        const double v2 = e[3] * e[3] + e[4] * e[4] + e[5] * e[5];
        memcpy(step, e, 6 * sizeof(double));
        step[6] = sqrt(1.0 - v2);
        pgem_se3_inverse(step, inverse);
        pgem_se3_compose(x, inverse, z);
    } else {
        memcpy(step, e, 3 * sizeof(double));
        pgem_se2_inverse(step, inverse);
        pgem_se2_compose(x, inverse, z);
    }
    return 1;
}

/* x = base * z (forward) or base * z^-1: where an edge's measurement puts its far pose. */
static void pgem_compose_step(int three, const double *base, const double *z, int forward,
                              double *x)
{
    double step[PGEM_POSE_SIZE_MAX];
    if (three) {
        if (forward) {
            memcpy(step, z, 7 * sizeof(double));
        } else {
            pgem_se3_inverse(z, step);
        }
        pgem_se3_compose(base, step, x);
    } else {
        if (forward) {
            memcpy(step, z, 3 * sizeof(double));
        } else {
            pgem_se2_inverse(z, step);
        }
        pgem_se2_compose(base, step, x);
    }
}

/* out = A' Oa A + B' Ob B (n x n): the information two edges give the pose they share. */
static void pgem_compose_sum(const double *oa, const double *a, const double *ob, const double *b,
                             double *out, int n)
{
    double t[PGEM_SMALL_MAX * PGEM_SMALL_MAX], u[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    pgem_small_product(oa, 0, a, 0, t, n);
    pgem_small_product(a, 1, t, 0, out, n);
    pgem_small_product(ob, 0, b, 0, t, n);
    pgem_small_product(b, 1, t, 0, u, n);
    for (int q = 0; q < n * n; q++) {
        out[q] += u[q];
    }
}

/* The edge from x1 to x2 whose information on x2 is h: measurement x2 (relative to x1, the
 * identity), information O with B' O B = h for its Jacobian B on x2, O = B^-T h B^-1. Returns
 * 0 when that information is not a usable one. */
static int pgem_compose_edge(int three, const double *x1, const double *x2, const double *z,
                             const double *h, int n, size_t size, double *measurement,
                             double *information)
{
    memcpy(measurement, z, size * sizeof(double));
    double b[PGEM_SMALL_MAX * PGEM_SMALL_MAX], b_inverse[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    double unused[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    double t[PGEM_SMALL_MAX * PGEM_SMALL_MAX], u[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    pgem_compose_error(three, x1, x2, measurement, NULL, unused, b);
    if (!pgem_small_inverse(b, b_inverse, n)) {
        return 0;
    }
    pgem_small_product(h, 0, b_inverse, 0, t, n);
    pgem_small_product(b_inverse, 1, t, 0, u, n);
    for (int r = 0; r < n; r++) { /* symmetric to the last bit */
        for (int c = 0; c < n; c++) {
            information[r * n + c] = 0.5 * (u[r * n + c] + u[c * n + r]);
        }
    }
    return pgem_information_check(information, n, NULL) == PGEM_OK;
}

int pgem_edge_compose(const pgem_store_t *store, uint32_t ka, double share_a, uint32_t kb,
                      double share_b, uint32_t p, uint32_t *from, uint32_t *to,
                      double *measurement, double *information, int tangent)
{
    const int three = tangent == 6, n = tangent;
    const size_t size = pgem_pose_doubles(tangent), nn = (size_t)n * (size_t)n;
    const int a_ends_at_p = store->edge_to[ka] == p;  /* ka: other -> p */
    const int b_starts_at_p = store->edge_from[kb] == p; /* kb: p -> other */
    *from = a_ends_at_p ? store->edge_from[ka] : store->edge_to[ka];
    *to = b_starts_at_p ? store->edge_to[kb] : store->edge_from[kb];
    const double *za = store->edge_measurement + (size_t)ka * size;
    const double *zb = store->edge_measurement + (size_t)kb * size;
    /* the composed measurement: where the two measurements put the far pose, the first at
     * the identity */
    double x1[PGEM_POSE_SIZE_MAX] = {0.0}, xp[PGEM_POSE_SIZE_MAX], x2[PGEM_POSE_SIZE_MAX];
    double z[PGEM_POSE_SIZE_MAX] = {0.0};
    x1[three ? 6 : 2] = three ? 1.0 : 0.0;
    pgem_compose_step(three, x1, za, a_ends_at_p, xp);
    pgem_compose_step(three, xp, zb, b_starts_at_p, z);
    /* the linearisation point: the three poses' estimates, relative to the first */
    {
        const double *e1 = store->pose + (size_t)*from * size;
        const double *ep = store->pose + (size_t)p * size;
        const double *e2 = store->pose + (size_t)*to * size;
        if (three) {
            pgem_se3_between(e1, ep, xp);
            pgem_se3_between(e1, e2, x2);
        } else {
            pgem_se2_between(e1, ep, xp);
            pgem_se2_between(e1, e2, x2);
        }
    }
    /* their errors at the estimate, and their Jacobians on p and on the second pose (the first
     * stays: it holds the gauge) */
    double ea[PGEM_TANGENT_SIZE_MAX] = {0.0}, eb[PGEM_TANGENT_SIZE_MAX] = {0.0};
    double ja[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0}, jb_p[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    double jb_2[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0}, unused[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    if (a_ends_at_p) {
        pgem_compose_error(three, x1, xp, za, ea, unused, ja);
    } else {
        pgem_compose_error(three, xp, x1, za, ea, ja, unused);
    }
    if (b_starts_at_p) {
        pgem_compose_error(three, xp, x2, zb, eb, jb_p, jb_2);
    } else {
        pgem_compose_error(three, x2, xp, zb, eb, jb_2, jb_p);
    }
    double oa[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0}, ob[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    for (size_t q = 0; q < nn; q++) { /* the share of each edge's information this edge takes */
        oa[q] = share_a * store->edge_information[(size_t)ka * nn + q];
        ob[q] = share_b * store->edge_information[(size_t)kb * nn + q];
    }
    double t[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0}, u[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    double hpp[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0}, hp2[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    double h22[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    pgem_compose_sum(oa, ja, ob, jb_p, hpp, n); /* Hpp = Ja' Oa Ja + Jbp' Ob Jbp */
    pgem_small_product(ob, 0, jb_2, 0, t, n); /* Hp2 = Jbp' Ob Jb2, H22 = Jb2' Ob Jb2 */
    pgem_small_product(jb_p, 1, t, 0, hp2, n);
    pgem_small_product(jb_2, 1, t, 0, h22, n);
    double hpp_inverse[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    if (!pgem_small_inverse(hpp, hpp_inverse, n)) {
        return 0;
    }
    pgem_small_product(hpp_inverse, 0, hp2, 0, t, n); /* L = H22 - Hp2' Hpp^-1 Hp2 */
    pgem_small_product(hp2, 1, t, 0, u, n);
    for (size_t q = 0; q < nn; q++) {
        h22[q] -= u[q];
    }
    /* the gradient the pair gives the second pose once p is marginalised out,
     * g = g2 - Hp2' Hpp^-1 gp, from the two errors at the estimate */
    double oe_a[PGEM_SMALL_MAX] = {0.0}, oe_b[PGEM_SMALL_MAX] = {0.0}, gp[PGEM_SMALL_MAX] = {0.0};
    double g[PGEM_SMALL_MAX] = {0.0}, w[PGEM_SMALL_MAX] = {0.0};
    pgem_small_apply(oa, 0, ea, oe_a, n);
    pgem_small_apply(ob, 0, eb, oe_b, n);
    pgem_small_apply(ja, 1, oe_a, gp, n);
    pgem_small_apply(jb_p, 1, oe_b, w, n);
    for (int r = 0; r < n; r++) {
        gp[r] += w[r];
    }
    pgem_small_apply(jb_2, 1, oe_b, g, n);
    pgem_small_apply(hpp_inverse, 0, gp, w, n);
    pgem_small_apply(hp2, 1, w, oe_a, n);
    for (int r = 0; r < n; r++) {
        g[r] -= oe_a[r];
    }
    /* the composed edge from x1 to x2 with the information O, B' O B = L for its Jacobian B
     * on x2, and the measurement whose error at the estimate, e0 = B L^-1 g, gives the same
     * gradient B' O e0 = g: the pair's quadratic form about the estimate, kept whole (at a
     * solved map g is the pull the pair's residual exerts; at a dead-reckoned one it is 0
     * and the measurement is the composition itself) */
    double l_inverse[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    double b[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0}, zg[PGEM_POSE_SIZE_MAX] = {0.0};
    if (pgem_small_inverse(h22, l_inverse, n)) {
        pgem_compose_error(three, x1, x2, z, NULL, unused, b);
        pgem_small_apply(l_inverse, 0, g, w, n);
        pgem_small_apply(b, 0, w, oe_b, n);
        if (pgem_compose_shifted(three, x2, oe_b, zg)) {
            memcpy(z, zg, size * sizeof(double));
        }
    }
    return pgem_compose_edge(three, x1, x2, z, h22, n, size, measurement, information);
}

int pgem_edge_fuse(const pgem_store_t *store, uint32_t ka, double weight_a, uint32_t kb,
                   double weight_b, double *measurement, double *information, int tangent)
{
    const int three = tangent == 6, n = tangent;
    const size_t size = pgem_pose_doubles(tangent), nn = (size_t)n * (size_t)n;
    const int reversed = store->edge_from[kb] != store->edge_from[ka]; /* kb: to -> from */
    const double *za = store->edge_measurement + (size_t)ka * size;
    const double *zb = store->edge_measurement + (size_t)kb * size;
    double x1[PGEM_POSE_SIZE_MAX] = {0.0}, x2[PGEM_POSE_SIZE_MAX];
    x1[three ? 6 : 2] = three ? 1.0 : 0.0;
    memcpy(x2, za, size * sizeof(double));
    double h[PGEM_SMALL_MAX * PGEM_SMALL_MAX], inverse[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    double oa[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0}, ob[PGEM_SMALL_MAX * PGEM_SMALL_MAX] = {0.0};
    for (size_t q = 0; q < nn; q++) {
        oa[q] = weight_a * store->edge_information[(size_t)ka * nn + q];
        ob[q] = weight_b * store->edge_information[(size_t)kb * nn + q];
    }
    /* the second pose where both measurements agree best: Gauss-Newton from ka's, the first
     * pose at the identity (a few steps: the two are accepted loops, close to each other) */
    for (int iteration = 0; iteration < 4; iteration++) {
        double ea[PGEM_TANGENT_SIZE_MAX], eb[PGEM_TANGENT_SIZE_MAX], g[PGEM_SMALL_MAX] = {0.0};
        double ja[PGEM_SMALL_MAX * PGEM_SMALL_MAX], jb[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
        double unused[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
        if (three) {
            pgem_se3_error(x1, x2, za, ea, unused, ja);
        } else {
            pgem_se2_error(x1, x2, za, ea, unused, ja);
        }
        if (three) {
            if (reversed) {
                pgem_se3_error(x2, x1, zb, eb, jb, unused);
            } else {
                pgem_se3_error(x1, x2, zb, eb, unused, jb);
            }
        } else if (reversed) {
            pgem_se2_error(x2, x1, zb, eb, jb, unused);
        } else {
            pgem_se2_error(x1, x2, zb, eb, unused, jb);
        }
        pgem_compose_sum(oa, ja, ob, jb, h, n); /* H = Ja' Oa Ja + Jb' Ob Jb */
        for (int r = 0; r < n; r++) { /* g = Ja' Oa ea + Jb' Ob eb */
            for (int m = 0; m < n; m++) {
                double oe_a = 0.0, oe_b = 0.0;
                for (int c = 0; c < n; c++) {
                    oe_a += oa[m * n + c] * ea[c];
                    oe_b += ob[m * n + c] * eb[c];
                }
                g[r] += ja[m * n + r] * oe_a + jb[m * n + r] * oe_b;
            }
        }
        if (!pgem_small_inverse(h, inverse, n)) {
            return 0;
        }
        double step[PGEM_SMALL_MAX];
        for (int r = 0; r < n; r++) {
            step[r] = 0.0;
            for (int c = 0; c < n; c++) {
                step[r] -= inverse[r * n + c] * g[c];
            }
        }
        if (three) {
            pgem_se3_boxplus(x2, step, x2);
        } else {
            pgem_se2_boxplus(x2, step, x2);
        }
    }
    /* the fused edge from the first pose to x2, its information on x2 the two's together */
    return pgem_compose_edge(three, x1, x2, x2, h, n, size, measurement, information);
}
