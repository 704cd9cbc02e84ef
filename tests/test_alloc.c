/* Proves the core allocates nothing while optimizing: malloc, calloc, realloc and free are
 * interposed and counted; after the symbolic analysis an optimize call (and the covariance
 * calls) must count zero. With
 * the system CSparse the analysis itself frees everything CSparse took; with CSparse built
 * from source (PGEM_CSPARSE_SOURCE_DIR) the analysis too counts zero, its workspace coming
 * from the block. */
#include "test_util.h"

#include "test_alloc_counters.h"

#if !TEST_UNDER_SANITIZER
static void build(pgem_t *graph, double *truth, int dimension)
{
    if (dimension == 2) {
        test_ring_2d(graph, 200, 7, 0.02, 0.02, 3, truth);
        return;
    }
    double information[36];
    test_diagonal_information(6, 50.0, information);
    for (int k = 0; k < 50; k++) {
        double tangent[6] = {0.1 * k, 0.3 * sin(k), 0.2, 0.01 * k, 0.02, 0.03 * cos(k)};
        pgem_se3_exp(tangent, truth + 7 * k);
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)k, truth + 7 * k), PGEM_OK);
        if (k > 0) {
            double z[7], noise[6] = {0.01, 0, -0.01, 0.002, 0, 0.001};
            pgem_se3_between(truth + 7 * (k - 1), truth + 7 * k, z);
            pgem_se3_boxplus(z, noise, z);
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 1), (pgem_id_t)k, z, information,
                                           PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
        }
        if (k >= 10 && k % 5 == 0) {
            double z[7];
            pgem_se3_between(truth + 7 * (k - 10), truth + 7 * k, z);
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 10), (pgem_id_t)k, z, information,
                                           PGEM_EDGE_LOOP, NULL), PGEM_OK);
        }
    }
}

/* After analyses that began with the counters at (before, released): with the system CSparse
 * some allocations, all freed; with the source-built CSparse none, and its pool was used. */
static void check_analysis_allocations(const pgem_t *graph, long before, long released)
{
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    if (stats.csparse_pool_bytes == 0) {
        assert_true(allocations > before); /* the counters see CSparse's calls */
        assert_int_equal(allocations - before, releases - released);
        assert_int_equal(stats.csparse_pool_peak, 0);
    } else {
        assert_int_equal(allocations, before);
        assert_int_equal(releases, released);
        assert_true(stats.csparse_pool_peak > 0);
        assert_true(stats.csparse_pool_peak <= stats.csparse_pool_bytes);
    }
}

static void check_no_allocation(int dimension, pgem_method_t method)
{
    static unsigned char buffer[8 << 20];
    static double truth[7 * 200];
    pgem_config_t config = {dimension, 200, 400, 0, 0, 0};
    assert_true(pgem_memory_size(&config) <= sizeof buffer);
    long before = allocations;
    pgem_t *graph = NULL;
    assert_int_equal(pgem_init(&graph, &config, buffer, sizeof buffer), PGEM_OK);
    build(graph, truth, dimension);
    assert_int_equal(allocations, before); /* init and adding: nothing */

    long analysis_allocations = allocations, analysis_releases = releases;
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    check_analysis_allocations(graph, analysis_allocations, analysis_releases);

    pgem_solve_options_t options = {0};
    options.method = method;
    pgem_summary_t summary;
    long solve_allocations = allocations, solve_releases = releases;
    assert_int_equal(pgem_optimize(graph, &options, &summary), PGEM_OK);
    assert_true(summary.iterations >= 1);
    assert_int_equal(allocations, solve_allocations);
    assert_int_equal(releases, solve_releases);
    /* and again (weights, estimates changed; topology not) */
    assert_int_equal(pgem_optimize(graph, &options, &summary), PGEM_OK);
    assert_int_equal(allocations, solve_allocations);
    /* the EM robust solve: E-steps, M-steps, pruning, re-admission, polish */
    pgem_robust_options_t robust = {0};
    robust.kernel = PGEM_KERNEL_EM;
    pgem_robust_summary_t robust_summary;
    assert_int_equal(pgem_robust_optimize(graph, &robust, &options, &robust_summary), PGEM_OK);
    assert_true(robust_summary.em_iterations >= 1);
    assert_int_equal(robust_summary.pruned, 0);
    assert_int_equal(allocations, solve_allocations);
    assert_int_equal(releases, solve_releases);
    /* the covariance calls: the factor, one pose, two poses, every pose (pgem/covariance.h) */
    static double covariances[200 * 36];
    double joint[144];
    assert_int_equal(pgem_covariance_prepare(graph), PGEM_OK);
    assert_int_equal(pgem_covariance(graph, 7, joint), PGEM_OK);
    assert_int_equal(pgem_joint_covariance(graph, 7, 30, joint), PGEM_OK);
    assert_int_equal(pgem_covariances(graph, covariances), PGEM_OK);
    assert_int_equal(pgem_joint_covariance(graph, 7, 30, joint), PGEM_OK);
    assert_int_equal(allocations, solve_allocations);
    assert_int_equal(releases, solve_releases);

    /* a false loop: the robust solve analyses the grown graph and EM prunes the loop. CSparse's
     * symbolic routines allocate there (and only there): from the heap, freeing all they take,
     * or from the block. */
    const double far[7] = {5.0, -4.0, 3.0, 0.0, 0.0, 0.0, 1.0};
    double information[36];
    test_diagonal_information(dimension == 2 ? 3 : 6, 100.0, information);
    assert_int_equal(pgem_add_edge(graph, 3, 40, far, information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    const uint32_t analyses = stats.analyses;
    long robust_allocations = allocations, robust_releases = releases;
    assert_int_equal(pgem_robust_optimize(graph, &robust, &options, &robust_summary), PGEM_OK);
    assert_int_equal(robust_summary.pruned, 1);
    pgem_memory_use(graph, &stats);
    assert_true(stats.analyses > analyses);
    check_analysis_allocations(graph, robust_allocations, robust_releases);
}

static void test_optimize_allocates_nothing_2d_gn(void **state)
{
    (void)state;
    check_no_allocation(2, PGEM_GAUSS_NEWTON);
}

static void test_optimize_allocates_nothing_2d_lm(void **state)
{
    (void)state;
    check_no_allocation(2, PGEM_LEVENBERG_MARQUARDT);
}

static void test_optimize_allocates_nothing_3d(void **state)
{
    (void)state;
    check_no_allocation(3, PGEM_GAUSS_NEWTON);
}

/* The incremental factor's covariance (pgem_update_covariance): nothing allocated, for the
 * newest pose (one block) and an old one (a long path). */
static void test_update_covariance_allocates_nothing(void **state)
{
    (void)state;
    static unsigned char buffer[8 << 20];
    static double truth[3 * 200];
    pgem_config_t config = {2, 200, 400, 0, 0, 64u * 9u * 200u};
    assert_true(pgem_memory_size(&config) <= sizeof buffer);
    pgem_t *graph = NULL;
    assert_int_equal(pgem_init(&graph, &config, buffer, sizeof buffer), PGEM_OK);
    build(graph, truth, 2);
    assert_int_equal(pgem_update(graph, NULL, NULL), PGEM_OK); /* the rebuild's AMD may */
    double covariance[9];
    long before = allocations, released = releases;
    assert_int_equal(pgem_update_covariance(graph, 199, covariance), PGEM_OK);
    assert_int_equal(pgem_update_covariance(graph, 3, covariance), PGEM_OK);
    assert_int_equal(allocations, before);
    assert_int_equal(releases, released);
}

/* The counters themselves work (so the tests above can fail). */
static void test_counter_sees_malloc(void **state)
{
    (void)state;
    long before = allocations;
    void *volatile pointer = malloc(32);
    assert_int_equal(allocations, before + 1);
    free(pointer);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_counter_sees_malloc),
        cmocka_unit_test(test_optimize_allocates_nothing_2d_gn),
        cmocka_unit_test(test_optimize_allocates_nothing_2d_lm),
        cmocka_unit_test(test_optimize_allocates_nothing_3d),
        cmocka_unit_test(test_update_covariance_allocates_nothing),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
#else
static void test_skipped_under_sanitizer(void **state)
{
    (void)state;
    print_message("skipped: AddressSanitizer owns malloc, so this build cannot count allocations; "
                  "the plain build runs this test\n");
    skip();
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_skipped_under_sanitizer)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
#endif
