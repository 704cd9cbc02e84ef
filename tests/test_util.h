/* Small helpers shared by the core tests: cmocka includes, instances, synthetic graphs. */
#ifndef PGEM_TEST_UTIL_H
#define PGEM_TEST_UTIL_H

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "pgem/pgem.h"

/* Fails with both values when |actual - expected| > tolerance (NaN fails). */
#define assert_near(actual, expected, tolerance)                                                   \
    do {                                                                                           \
        double assert_near_a = (actual), assert_near_e = (expected);                               \
        if (!(fabs(assert_near_a - assert_near_e) <= (tolerance))) {                               \
            fail_msg("%s = %.17g, expected %.17g (tolerance %g)", #actual, assert_near_a,          \
                     assert_near_e, (double)(tolerance));                                          \
        }                                                                                          \
    } while (0)

/* Deterministic generator (splitmix64) so every run sees the same numbers. */
typedef struct test_rng {
    uint64_t state;  /* advances by the golden-ratio increment */
} test_rng_t;

static inline double test_uniform(test_rng_t *rng)
{
    uint64_t z = (rng->state += UINT64_C(0x9e3779b97f4a7c15));
    z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

static inline double test_gaussian(test_rng_t *rng)
{
    double u = test_uniform(rng), v = test_uniform(rng);
    return sqrt(-2.0 * log(u + 1e-300)) * cos(6.283185307179586 * v);
}

/* Diagonal information matrix n x n. */
static inline void test_diagonal_information(int n, double value, double *information)
{
    for (int k = 0; k < n * n; k++) {
        information[k] = k % (n + 1) == 0 ? value : 0.0;
    }
}

/* Creates an instance or fails the test. */
static inline pgem_t *test_create(int dimension, uint32_t poses, uint32_t edges)
{
    pgem_config_t config = {dimension, poses, edges, 0};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    return graph;
}

/* A 2D ring of n poses (radius 10) with odometry and loop closures every `stride` poses;
 * ground truth into truth[3 n]; odometry with Gaussian noise of `sigma` (x, y) and
 * `heading_sigma` (theta), loop closures exact; information matches the noise; initial
 * estimate = odometry composition. */
static inline void test_ring_2d(pgem_t *graph, int n, int stride, double sigma,
                                double heading_sigma, uint64_t seed, double *truth)
{
    test_rng_t rng = {seed};
    double information[9];
    test_diagonal_information(3, 1.0 / (sigma * sigma + 1e-12), information);
    information[8] = 1.0 / (heading_sigma * heading_sigma + 1e-12);
    for (int k = 0; k < n; k++) {
        double angle = 6.283185307179586 * k / n;
        truth[3 * k] = 10.0 * cos(angle);
        truth[3 * k + 1] = 10.0 * sin(angle);
        truth[3 * k + 2] = pgem_wrap_angle(angle + 1.5707963267948966);
    }
    double estimate[3] = {truth[0], truth[1], truth[2]};
    assert_int_equal(pgem_add_pose(graph, 0, estimate), PGEM_OK);
    for (int k = 1; k < n; k++) {
        double z[3];
        pgem_se2_between(truth + 3 * (k - 1), truth + 3 * k, z);
        for (int d = 0; d < 3; d++) {
            z[d] += (d < 2 ? sigma : heading_sigma) * test_gaussian(&rng);
        }
        pgem_se2_compose(estimate, z, estimate);
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)k, estimate), PGEM_OK);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 1), (pgem_id_t)k, z, information,
                                       PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    }
    for (int k = stride; k < n; k += stride) {
        double z[3];
        int other = k - stride;
        pgem_se2_between(truth + 3 * k, truth + 3 * other, z);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)k, (pgem_id_t)other, z, information,
                                       PGEM_EDGE_LOOP, NULL), PGEM_OK);
    }
}

#endif /* PGEM_TEST_UTIL_H */
