/* The block's pool for CSparse (CSparse built from source): every symbolic analysis fits the
 * bound pgem_memory_size reserved, whatever the graph's shape at full capacity. With the system
 * CSparse (heap) there is no pool and the tests skip. */
#include "test_util.h"

/* Fills a graph to capacity: a chain of poses, then loops drawn by pick until max_edges. */
typedef void (*pick_fn)(test_rng_t *rng, uint32_t poses, uint32_t k, uint32_t *a, uint32_t *b);

static void pick_random(test_rng_t *rng, uint32_t poses, uint32_t k, uint32_t *a, uint32_t *b)
{
    (void)k;
    *a = (uint32_t)(test_next(rng) % poses);
    *b = (uint32_t)(test_next(rng) % poses);
}

static void pick_star(test_rng_t *rng, uint32_t poses, uint32_t k, uint32_t *a, uint32_t *b)
{
    (void)rng;
    *a = 0;
    *b = 2u + k % (poses - 2u);
}

static void pick_complete(test_rng_t *rng, uint32_t poses, uint32_t k, uint32_t *a, uint32_t *b)
{
    (void)rng;
    /* k-th pair (i, j), j >= i + 2, in row order */
    uint32_t i = 0;
    while (k >= poses - 2u - i) {
        k -= poses - 2u - i;
        i++;
    }
    *a = i;
    *b = i + 2u + k;
}

static int pool_available(void)
{
    pgem_t *graph = test_create(2, 4, 4);
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    pgem_destroy(graph);
    return stats.csparse_pool_bytes > 0;
}

static void check_full(int dimension, uint32_t poses, uint32_t edges, pick_fn pick)
{
    const int b = dimension == 2 ? 3 : 6;
    pgem_config_t config = {dimension, poses, edges,
                            (uint32_t)((poses * (poses + 1u) / 2u) * (uint32_t)(b * b)), 0, 0};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    double pose[7] = {0, 0, 0, 0, 0, 0, 1}, z[7] = {1, 0, 0, 0, 0, 0, 1}, information[36];
    test_diagonal_information(b, 1.0, information);
    for (uint32_t p = 0; p < poses; p++) {
        pose[0] = p;
        assert_int_equal(pgem_add_pose(graph, p, pose), PGEM_OK);
    }
    uint32_t added = 0;
    for (uint32_t p = 1; p < poses && added < edges; p++, added++) {
        assert_int_equal(pgem_add_edge(graph, p - 1, p, z, information, PGEM_EDGE_ODOMETRY, NULL),
                         PGEM_OK);
    }
    test_rng_t rng = {12345u};
    for (uint32_t k = 0; added < edges; k++) {
        uint32_t a, c;
        pick(&rng, poses, k, &a, &c);
        if (a == c) {
            continue;
        }
        assert_int_equal(pgem_add_edge(graph, a, c, z, information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
        added++;
    }
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    assert_true(stats.csparse_pool_peak > 0);
    assert_true(stats.csparse_pool_peak <= stats.csparse_pool_bytes);
    print_message("%dD %u poses %u edges: CSparse pool peak %zu of %zu bytes\n", dimension,
                  (unsigned)poses, (unsigned)edges, stats.csparse_pool_peak,
                  stats.csparse_pool_bytes);
    pgem_destroy(graph);
}

static void test_pool_fits_every_shape(void **state)
{
    (void)state;
    if (!pool_available()) {
        print_message("skipped: CSparse is the system library here and uses the heap; the pool "
                      "exists only when CSparse is built from source (PGEM_CSPARSE_SOURCE_DIR)\n");
        skip();
    }
    for (int dimension = 2; dimension <= 3; dimension++) {
        check_full(dimension, 2, 1, pick_random);
        check_full(dimension, 500, 499, pick_random);        /* odometry only */
        check_full(dimension, 500, 600, pick_random);        /* the firmware example's size */
        check_full(dimension, 300, 3000, pick_random);       /* dense random loops */
        check_full(dimension, 200, 1000, pick_star);         /* one hub seen from everywhere */
        check_full(dimension, 40, 39 + 741, pick_complete);  /* every pair joined */
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_pool_fits_every_shape)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
