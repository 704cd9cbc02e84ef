/* Small helpers shared by the tests, C and C++: cmocka includes, assertions, a deterministic
 * generator, instances, synthetic graphs, the datasets folder. A C++ test includes this header
 * last: cmocka's fail() macro would clash with names in the C++ headers. */
#ifndef PGEM_TEST_UTIL_H
#define PGEM_TEST_UTIL_H

#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* cmocka 1.1 has no C++ guards of its own. */
#ifdef __cplusplus
extern "C" {
#endif
#include <cmocka.h>

#include "random.h"
#ifdef __cplusplus
}
#endif

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

/* assert_near for helpers that check many values: the message carries the caller's label. */
#define assert_near_labelled(actual, expected, tolerance, label)                                   \
    do {                                                                                           \
        double assert_near_a = (actual), assert_near_e = (expected);                               \
        if (!(fabs(assert_near_a - assert_near_e) <= (tolerance))) {                               \
            fail_msg("%s: got %.17g, expected %.17g (tolerance %g)", (label), assert_near_a,       \
                     assert_near_e, (double)(tolerance));                                          \
        }                                                                                          \
    } while (0)

/* Fails unless the text holds the fragment. */
#define assert_contains(text, fragment)                                                            \
    do {                                                                                           \
        const char *assert_contains_t = (text), *assert_contains_f = (fragment);                   \
        if (strstr(assert_contains_t, assert_contains_f) == NULL) {                                \
            fail_msg("\"%s\" does not contain \"%s\"", assert_contains_t, assert_contains_f);      \
        }                                                                                          \
    } while (0)

/* Deterministic generator (lib/support/random.h's splitmix64) so every run sees the same
 * numbers. */
typedef struct test_rng {
    uint64_t state;  /* advances by the golden-ratio increment */
} test_rng_t;

/* The next 64 random bits. */
static inline uint64_t test_next(test_rng_t *rng)
{
    return pgem_random_next(&rng->state);
}

/* Uniform in [0, 1): the top 53 bits. */
static inline double test_uniform(test_rng_t *rng)
{
    return pgem_random_uniform(&rng->state);
}

/* Uniform in [lo, hi). */
static inline double test_uniform_in(test_rng_t *rng, double lo, double hi)
{
    return lo + (hi - lo) * test_uniform(rng);
}

static inline double test_gaussian(test_rng_t *rng)
{
    return pgem_random_gaussian(&rng->state);
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
    pgem_config_t config = {dimension, poses, edges, 0, 0, 0};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    return graph;
}

/* Every pose's estimate, in insertion order, into poses (pose count x pose size doubles). */
static inline void test_snapshot(const pgem_t *graph, double *poses)
{
    int size = PGEM_POSE_SIZE(pgem_dimension(graph));
    for (uint32_t k = 0; k < pgem_pose_count(graph); k++) {
        double *pose = poses + (size_t)k * (size_t)size;
        assert_int_equal(pgem_pose_at(graph, k, NULL, pose, NULL), PGEM_OK);
    }
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

/* The shared datasets folder (PGEM_DATASETS) when it holds probe (a file below it), else NULL
 * after saying why: the dataset tests then skip. */
static inline const char *test_datasets_dir(const char *probe)
{
    const char *dir = getenv("PGEM_DATASETS");
    if (dir == NULL || dir[0] == '\0') {
        print_message("PGEM_DATASETS is not set: dataset tests skipped\n");
        return NULL;
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, probe);
    FILE *file = fopen(path, "rb");
    if (file == NULL) {
        print_message("PGEM_DATASETS=%s has no %s: dataset tests skipped\n", dir, probe);
        return NULL;
    }
    fclose(file);
    return dir;
}

#endif /* PGEM_TEST_UTIL_H */
