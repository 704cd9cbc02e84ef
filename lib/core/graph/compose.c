/* Two edges that meet at a pose composed into one edge between their other ends: the pose
 * removed from the graph (robust/compact.c). The measurement is the composition, exact; the
 * information is the removed pose marginalised out of the two edges' quadratic form,
 * linearised where the two measurements hold exactly. */
#include <string.h>

#include "graph/graph.h"
#include "instance.h"

/* The error of an edge from xi to xj with measurement z, and its Jacobians. */
static void pgem_compose_error(int three, const double *xi, const double *xj, const double *z,
                               double *jacobian_i, double *jacobian_j)
{
    double error[PGEM_TANGENT_SIZE_MAX];
    if (three) {
        pgem_se3_error(xi, xj, z, error, jacobian_i, jacobian_j);
    } else {
        pgem_se2_error(xi, xj, z, error, jacobian_i, jacobian_j);
    }
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
static int pgem_compose_edge(int three, const double *x1, const double *x2, const double *h,
                             int n, size_t size, double *measurement, double *information)
{
    memcpy(measurement, x2, size * sizeof(double));
    double b[PGEM_SMALL_MAX * PGEM_SMALL_MAX], b_inverse[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    double unused[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    double t[PGEM_SMALL_MAX * PGEM_SMALL_MAX], u[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    pgem_compose_error(three, x1, x2, measurement, unused, b);
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

int pgem_edge_compose(const pgem_t *graph, uint32_t ka, double share_a, uint32_t kb,
                      double share_b, uint32_t p, uint32_t *from, uint32_t *to,
                      double *measurement, double *information)
{
    const pgem_store_t *store = &graph->store;
    const int three = graph->config.dimension == 3, n = graph->tangent;
    const size_t size = (size_t)graph->pose_size, nn = (size_t)n * (size_t)n;
    const int a_ends_at_p = store->edge_to[ka] == p;  /* ka: other -> p */
    const int b_starts_at_p = store->edge_from[kb] == p; /* kb: p -> other */
    *from = a_ends_at_p ? store->edge_from[ka] : store->edge_to[ka];
    *to = b_starts_at_p ? store->edge_to[kb] : store->edge_from[kb];
    const double *za = store->edge_measurement + (size_t)ka * size;
    const double *zb = store->edge_measurement + (size_t)kb * size;
    /* the three poses where both measurements hold: the first at the identity */
    double x1[PGEM_POSE_SIZE_MAX] = {0.0}, xp[PGEM_POSE_SIZE_MAX], x2[PGEM_POSE_SIZE_MAX];
    x1[three ? 6 : 2] = three ? 1.0 : 0.0;
    pgem_compose_step(three, x1, za, a_ends_at_p, xp);
    pgem_compose_step(three, xp, zb, b_starts_at_p, x2);
    /* their Jacobians on p and on the second pose (the first stays: it holds the gauge) */
    double ja[PGEM_SMALL_MAX * PGEM_SMALL_MAX], jb_p[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    double jb_2[PGEM_SMALL_MAX * PGEM_SMALL_MAX], unused[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    if (a_ends_at_p) {
        pgem_compose_error(three, x1, xp, za, unused, ja);
    } else {
        pgem_compose_error(three, xp, x1, za, ja, unused);
    }
    if (b_starts_at_p) {
        pgem_compose_error(three, xp, x2, zb, jb_p, jb_2);
    } else {
        pgem_compose_error(three, x2, xp, zb, jb_2, jb_p);
    }
    double oa[PGEM_SMALL_MAX * PGEM_SMALL_MAX], ob[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    for (size_t q = 0; q < nn; q++) { /* the share of each edge's information this edge takes */
        oa[q] = share_a * store->edge_information[(size_t)ka * nn + q];
        ob[q] = share_b * store->edge_information[(size_t)kb * nn + q];
    }
    double t[PGEM_SMALL_MAX * PGEM_SMALL_MAX], u[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    double hpp[PGEM_SMALL_MAX * PGEM_SMALL_MAX], hp2[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    double h22[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    pgem_compose_sum(oa, ja, ob, jb_p, hpp, n); /* Hpp = Ja' Oa Ja + Jbp' Ob Jbp */
    pgem_small_product(ob, 0, jb_2, 0, t, n); /* Hp2 = Jbp' Ob Jb2, H22 = Jb2' Ob Jb2 */
    pgem_small_product(jb_p, 1, t, 0, hp2, n);
    pgem_small_product(jb_2, 1, t, 0, h22, n);
    double hpp_inverse[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    if (!pgem_small_inverse(hpp, hpp_inverse, n)) {
        return 0;
    }
    pgem_small_product(hpp_inverse, 0, hp2, 0, t, n); /* L = H22 - Hp2' Hpp^-1 Hp2 */
    pgem_small_product(hp2, 1, t, 0, u, n);
    for (size_t q = 0; q < nn; q++) {
        h22[q] -= u[q];
    }
    /* the composed edge from x1 to x2: its measurement x2, its Jacobian B on x2; the
     * information O with B' O B = L */
    return pgem_compose_edge(three, x1, x2, h22, n, size, measurement, information);
}

int pgem_edge_fuse(const pgem_t *graph, uint32_t ka, double weight_a, uint32_t kb,
                   double weight_b, double *measurement, double *information)
{
    const pgem_store_t *store = &graph->store;
    const int three = graph->config.dimension == 3, n = graph->tangent;
    const size_t size = (size_t)graph->pose_size, nn = (size_t)n * (size_t)n;
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
    return pgem_compose_edge(three, x1, x2, h, n, size, measurement, information);
}
