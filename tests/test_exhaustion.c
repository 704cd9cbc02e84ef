/* Memory exhaustion, and a broken downdate of the incremental factor (at the end). A block one
 * byte short, a NULL or empty block, every carve from the block
 * failed in turn at init, and every allocation of CSparse's symbolic analysis failed in turn
 * inside pgem_optimize and pgem_robust_optimize: each gives the documented error and a message
 * saying what was short, changes nothing the caller can see (the poses bit for bit, the edges
 * with their weights and states, the fixed flags) and leaks nothing; the same call without the
 * fault then gives bit for bit what an instance that never failed gives.
 *
 * The program links pgem_core_faults, the core's sources compiled with PGEM_FAULT_INJECTION
 * (the released pgem_core never has it): pgem_fault_arm(k) makes the k-th carve from the block,
 * or the k-th allocation from CSparse's pool (CSparse built from source), fail. With the system
 * CSparse the analysis takes its workspace from the heap, and the k-th malloc, calloc or
 * realloc fails instead (interposed, test_alloc_counters.h). AddressSanitizer owns malloc, so
 * the sanitizer build with the system CSparse sweeps init only and says why. */
#define TEST_ALLOC_FAULTS
#include "test_util.h"

#include "test_alloc_counters.h"

#include "instance.h" /* the instance's linear system (graph->linear) */
#include "linalg/linear.h"

#define BLOCK_PATTERN 0xA5
#define MESSAGE_BYTES 256

/* Fails with the sweep's context: which case, which fault. */
#define sweep_expect(condition, name, fault)                                                       \
    do {                                                                                           \
        if (!(condition)) {                                                                        \
            fail_msg("%s, fault %ld: %s", (name), (long)(fault), #condition);                      \
        }                                                                                          \
    } while (0)

/* Capacities for the init checks: 2D and 3D, small and mid-size, default and explicit fill
 * budgets, and the all-defaults config. */
static const pgem_config_t init_configs[] = {
    {2, 10, 20, 0, 0, 0},      {2, 500, 2000, 0, 0, 0}, {2, 100, 300, 5000, 0, 0}, {3, 8, 16, 0, 0, 0},
    {3, 300, 900, 20000, 0, 0}, {0, 0, 0, 0, 0, 0},
};
#define INIT_CONFIGS (sizeof init_configs / sizeof init_configs[0])

/* 1 if every byte of [from, to) still holds the pattern. */
static int untouched(const unsigned char *from, const unsigned char *to)
{
    for (; from < to; from++) {
        if (*from != BLOCK_PATTERN) {
            return 0;
        }
    }
    return 1;
}

/* The message says "<given> bytes given" and "needs <needed>". */
static void check_sizes_named(const char *message, size_t given, size_t needed)
{
    char expected[64];
    snprintf(expected, sizeof expected, "%zu bytes given", given);
    assert_contains(message, expected);
    snprintf(expected, sizeof expected, "needs %zu", needed);
    assert_contains(message, expected);
}

/* A fresh instance works: two poses, an edge, a solve. */
static void check_usable(pgem_t *graph)
{
    const double pose[7] = {0, 0, 0, 0, 0, 0, 1}, z[7] = {1, 0, 0, 0, 0, 0, 1};
    double information[36];
    const int dimension = pgem_dimension(graph);
    test_diagonal_information(dimension == 3 ? 6 : 3, 1.0, information);
    assert_int_equal(pgem_add_pose(graph, 1, pose), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 2, pose), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 1, 2, z, information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    double solved[7];
    assert_int_equal(pgem_pose(graph, 2, solved), PGEM_OK);
    assert_near(solved[0], 1.0, 1e-9);
}

/* One byte short fails before writing anything; the exact size works at every alignment of the
 * block's start, and writes only inside the block. */
static void test_block_one_byte_short(void **state)
{
    (void)state;
    for (size_t c = 0; c < INIT_CONFIGS; c++) {
        const pgem_config_t *config = &init_configs[c];
        const size_t need = pgem_memory_size(config);
        assert_true(need > 0);
        unsigned char *buffer = malloc(need + 32u);
        assert_non_null(buffer);
        for (size_t offset = 0; offset < 16u; offset++) {
            unsigned char *block = buffer + offset;
            char message[MESSAGE_BYTES];
            pgem_t *graph = NULL;
            memset(buffer, BLOCK_PATTERN, need + 32u);
            assert_int_equal(pgem_init_message(&graph, config, block, need - 1u, message,
                                               sizeof message),
                             PGEM_ERR_BUFFER_TOO_SMALL);
            assert_null(graph);
            assert_contains(message, "the memory block is too small");
            check_sizes_named(message, need - 1u, need);
            assert_true(untouched(buffer, buffer + need + 32u));
            assert_int_equal(pgem_init(&graph, config, block, need - 1u), PGEM_ERR_BUFFER_TOO_SMALL);

            assert_int_equal(pgem_init_message(&graph, config, block, need, message, sizeof message),
                             PGEM_OK);
            assert_string_equal(message, "");
            assert_true((unsigned char *)graph >= block && (unsigned char *)graph < block + need);
            pgem_memory_stats_t stats;
            pgem_memory_use(graph, &stats);
            assert_true(stats.used_bytes <= need);
            assert_true(untouched(buffer, block));
            assert_true(untouched(block + need, buffer + need + 32u));
            check_usable(graph);
            assert_true(untouched(block + need, buffer + need + 32u));
        }
        free(buffer);
    }
}

/* Decided: a block may start at any address (checked above for 16 offsets); a NULL block, an
 * empty one, a NULL instance or config and a bad config are refused, saying which. */
static void test_null_and_empty_block(void **state)
{
    (void)state;
    const pgem_config_t config = {2, 50, 100, 0, 0, 0};
    const size_t need = pgem_memory_size(&config);
    unsigned char block[64];
    char message[MESSAGE_BYTES];
    pgem_t *graph = NULL;

    assert_int_equal(pgem_init_message(&graph, &config, NULL, need, message, sizeof message),
                     PGEM_ERR_INVALID_ARGUMENT);
    assert_contains(message, "the memory block is NULL");
    check_sizes_named(message, 0, need);
    assert_int_equal(pgem_init(&graph, &config, NULL, need), PGEM_ERR_INVALID_ARGUMENT);

    memset(block, BLOCK_PATTERN, sizeof block);
    assert_int_equal(pgem_init_message(&graph, &config, block, 0, message, sizeof message),
                     PGEM_ERR_BUFFER_TOO_SMALL);
    check_sizes_named(message, 0, need);
    assert_int_equal(pgem_init_message(&graph, &config, block, sizeof block, message,
                                       sizeof message),
                     PGEM_ERR_BUFFER_TOO_SMALL);
    check_sizes_named(message, sizeof block, need);
    assert_true(untouched(block, block + sizeof block));
    assert_null(graph);

    assert_int_equal(pgem_init_message(NULL, &config, block, need, message, sizeof message),
                     PGEM_ERR_INVALID_ARGUMENT);
    assert_string_equal(message, "instance is NULL");
    assert_int_equal(pgem_init_message(&graph, NULL, block, need, message, sizeof message),
                     PGEM_ERR_INVALID_ARGUMENT);
    assert_string_equal(message, "config is NULL");

    pgem_config_t bad = config;
    bad.dimension = 4;
    assert_int_equal(pgem_init_message(&graph, &bad, block, sizeof block, message, sizeof message),
                     PGEM_ERR_CONFIG);
    assert_contains(message, "config.dimension");
    bad = config;
    bad.max_edges = PGEM_MAX_EDGES_LIMIT + 1u;
    assert_int_equal(pgem_init_message(&graph, &bad, block, sizeof block, message, sizeof message),
                     PGEM_ERR_CONFIG);
    assert_contains(message, "config.max_edges");
    assert_null(graph);

    /* the message is cut to fit, never overrun; NULL means none */
    char small[12];
    memset(small, 'x', sizeof small);
    assert_int_equal(pgem_init_message(&graph, &config, block, 0, small, 8), PGEM_ERR_BUFFER_TOO_SMALL);
    assert_int_equal(strlen(small), 7);
    assert_int_equal(small[8], 'x');
    assert_int_equal(pgem_init_message(&graph, &config, block, 0, NULL, 0), PGEM_ERR_BUFFER_TOO_SMALL);
}

/* Every carve of init failed in turn (k = 0, 1, ... until an init reaches no fault): a clear
 * error, *instance untouched, nothing written outside the block, and an init of the same block
 * without the fault then succeeds. */
static void test_every_carve_fails(void **state)
{
    (void)state;
    long total = 0;
    for (size_t c = 0; c < INIT_CONFIGS; c++) {
        const pgem_config_t *config = &init_configs[c];
        const size_t need = pgem_memory_size(config);
        unsigned char *buffer = malloc(need + 32u);
        assert_non_null(buffer);
        unsigned char *block = buffer + 16u + c % 16u; /* aligned and not */
        long points = 0;
        for (long k = 0;; k++) {
            char message[MESSAGE_BYTES], expected[64];
            pgem_t *graph = NULL;
            memset(buffer, BLOCK_PATTERN, need + 32u);
            pgem_fault_arm(k);
            const int status = pgem_init_message(&graph, config, block, need, message, sizeof message);
            const long seen = pgem_fault_seen();
            pgem_fault_arm(-1);
            if (seen <= k) { /* no carve left to fail */
                sweep_expect(status == PGEM_OK, "init", k);
                break;
            }
            points++;
            sweep_expect(status == PGEM_ERR_BUFFER_TOO_SMALL, "init", k);
            sweep_expect(graph == NULL, "init", k);
            snprintf(expected, sizeof expected, "could not hold slice %ld (", k + 1);
            assert_contains(message, expected);
            assert_contains(message, "bytes) of the instance: ");
            check_sizes_named(message, need, need);
            sweep_expect(untouched(buffer, block), "init", k);
            sweep_expect(untouched(block + need, buffer + need + 32u), "init", k);
            assert_int_equal(pgem_init(&graph, config, block, need), PGEM_OK);
            check_usable(graph);
        }
        assert_true(points > 0);
        print_message("init, config %zu: %ld carves failed in turn\n", c, points);
        total += points;
        free(buffer);
    }
    print_message("init: %ld fault points over %zu configs\n", total, INIT_CONFIGS);
}

/* A solve scenario: a graph, its first solve (the last good estimate), more edges (a new
 * analysis is due), then the call swept. */
typedef struct scenario {
    const char *name;
    pgem_config_t config;
    int first_robust;           /* the first solve: 1 = EM, 0 = pgem_optimize */
    int false_loops;            /* false loop closures among the new edges */
    int robust;                 /* the swept call: 1 = pgem_robust_optimize, 0 = pgem_optimize */
    pgem_kernel_t kernel;       /* its kernel (robust) */
    int literal;                /* EM as published (robust) */
    pgem_method_t method;       /* Gauss-Newton or LM (the M-steps of EM are Gauss-Newton) */
} scenario_t;

#define MAX_POSES 120

/* Poses along a helix (3D) or a ring (2D) with odometry and every 7th loop; truth kept. */
static void build_graph(pgem_t *graph, int dimension, int poses, double *truth)
{
    if (dimension == 2) {
        test_ring_2d(graph, poses, 7, 0.02, 0.02, 11, truth);
        return;
    }
    test_rng_t rng = {29};
    double information[36];
    test_diagonal_information(6, 400.0, information);
    for (int k = 0; k < poses; k++) {
        const double angle = 0.3 * k;
        const double tangent[6] = {4.0 * cos(angle), 4.0 * sin(angle), 0.05 * k, 0.0, 0.0, angle};
        pgem_se3_exp(tangent, truth + 7 * k);
        double z[7], noise[6];
        if (k > 0) {
            pgem_se3_between(truth + 7 * (k - 1), truth + 7 * k, z);
            for (int d = 0; d < 6; d++) {
                noise[d] = 0.01 * test_gaussian(&rng);
            }
            pgem_se3_boxplus(z, noise, z);
        }
        double estimate[7];
        if (k == 0) {
            memcpy(estimate, truth, sizeof estimate);
        } else {
            assert_int_equal(pgem_pose(graph, (pgem_id_t)(k - 1), estimate), PGEM_OK);
            pgem_se3_compose(estimate, z, estimate);
        }
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)k, estimate), PGEM_OK);
        if (k > 0) {
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 1), (pgem_id_t)k, z, information,
                                           PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
        }
        if (k >= 7 && k % 7 == 0) {
            pgem_se3_between(truth + 7 * (k - 7), truth + 7 * k, z);
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 7), (pgem_id_t)k, z, information,
                                           PGEM_EDGE_LOOP, NULL), PGEM_OK);
        }
    }
}

/* New edges after the first solve: true loops across the graph, then false ones. */
static void grow_graph(pgem_t *graph, int dimension, int poses, const double *truth, int false_loops)
{
    const int size = PGEM_POSE_SIZE(dimension), tangent = PGEM_TANGENT_SIZE(dimension);
    double information[36], z[7];
    test_diagonal_information(tangent, 100.0, information);
    for (int k = 12; k < poses; k += 9) {
        const int other = k - 12 + k % 5;
        if (dimension == 2) {
            pgem_se2_between(truth + size * other, truth + size * k, z);
        } else {
            pgem_se3_between(truth + size * other, truth + size * k, z);
        }
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)other, (pgem_id_t)k, z, information,
                                       PGEM_EDGE_LOOP, NULL), PGEM_OK);
    }
    test_rng_t rng = {43};
    for (int added = 0; added < false_loops;) {
        const int a = (int)(test_next(&rng) % (uint64_t)poses);
        const int b = (int)(test_next(&rng) % (uint64_t)poses);
        if (a - b < 10 && b - a < 10) {
            continue;
        }
        const double far[7] = {test_uniform_in(&rng, -8, 8), test_uniform_in(&rng, -8, 8),
                               dimension == 2 ? test_uniform_in(&rng, -3, 3) : 1.0, 0, 0, 0, 1};
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)a, (pgem_id_t)b, far, information,
                                       PGEM_EDGE_LOOP, NULL), PGEM_OK);
        added++;
    }
}

static int first_solve(pgem_t *graph, const scenario_t *s)
{
    if (s->first_robust) {
        pgem_robust_options_t robust = {0};
        robust.kernel = PGEM_KERNEL_EM;
        return pgem_robust_optimize(graph, &robust, NULL, NULL);
    }
    return pgem_optimize(graph, NULL, NULL);
}

static int swept_call(pgem_t *graph, const scenario_t *s)
{
    pgem_solve_options_t solve = {0};
    solve.method = s->method;
    if (!s->robust) {
        return pgem_optimize(graph, &solve, NULL);
    }
    pgem_robust_options_t robust = {0};
    robust.kernel = s->kernel;
    robust.literal = s->literal;
    return pgem_robust_optimize(graph, &robust, &solve, NULL);
}

/* The scenario's instance in block, up to the call that is swept. */
static pgem_t *prepare(const scenario_t *s, unsigned char *block, size_t size)
{
    static double truth[7 * MAX_POSES];
    pgem_t *graph = NULL;
    assert_int_equal(pgem_init(&graph, &s->config, block, size), PGEM_OK);
    const int poses = (int)s->config.max_poses;
    build_graph(graph, s->config.dimension, poses, truth);
    assert_int_equal(first_solve(graph, s), PGEM_OK);
    grow_graph(graph, s->config.dimension, poses, truth, s->false_loops);
    return graph;
}

/* What the caller can see of a graph: poses, fixed flags, edges with weights and states. */
typedef struct visible {
    uint32_t pose_count, edge_count;
    double poses[7 * MAX_POSES];
    int fixed[MAX_POSES];
    pgem_edge_view_t edges[4 * MAX_POSES];
} visible_t;

static void look(const pgem_t *graph, visible_t *out)
{
    memset(out, 0, sizeof *out);
    out->pose_count = pgem_pose_count(graph);
    out->edge_count = pgem_edge_count(graph);
    assert_true(out->pose_count <= MAX_POSES && out->edge_count <= 4u * MAX_POSES);
    const int size = PGEM_POSE_SIZE(pgem_dimension(graph));
    for (uint32_t k = 0; k < out->pose_count; k++) {
        assert_int_equal(pgem_pose_at(graph, k, NULL, out->poses + (size_t)size * k, &out->fixed[k]),
                         PGEM_OK);
    }
    for (uint32_t k = 0; k < out->edge_count; k++) {
        assert_int_equal(pgem_edge_at(graph, k, &out->edges[k]), PGEM_OK);
    }
}

/* 1 if the two are the same bit for bit. */
static int same(const visible_t *a, const visible_t *b)
{
    return memcmp(a, b, sizeof *a) == 0;
}

/* Where the swept allocations come from. */
typedef enum fault_source {
    FAULT_POOL,   /* CSparse built from source: its pool in the block */
    FAULT_HEAP    /* the system CSparse: malloc, calloc, realloc */
} fault_source_t;

static fault_source_t source_of(const pgem_t *graph)
{
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    return stats.csparse_pool_bytes > 0 ? FAULT_POOL : FAULT_HEAP;
}

static void arm(fault_source_t source, long index)
{
    if (source == FAULT_POOL) {
        pgem_fault_arm(index);
    }
#if !TEST_UNDER_SANITIZER
    else {
        alloc_fault_arm(index);
    }
#endif
}

/* Allocations seen since arm(); disarms. */
static long disarm(fault_source_t source)
{
    (void)source; /* the heap is not swept under the sanitizer */
    long seen = pgem_fault_seen();
    pgem_fault_arm(-1);
#if !TEST_UNDER_SANITIZER
    if (source == FAULT_HEAP) {
        seen = alloc_fault_seen;
        alloc_fault_arm(-1);
    }
#endif
    return seen;
}

/* The checks on one failed call (fault k). */
static void check_failed_call(const scenario_t *s, pgem_t *graph, int status, long k,
                              fault_source_t source, const visible_t *before)
{
    static visible_t now;
    const char *message = pgem_last_error(graph);
    if (status != PGEM_ERR_OUT_OF_MEMORY) {
        print_message("%s, fault %ld: %s: %s\n", s->name, k, pgem_error_name(status), message);
    }
    sweep_expect(status == PGEM_ERR_OUT_OF_MEMORY, s->name, k);
    sweep_expect(strstr(message, "out of memory in the symbolic analysis (") != NULL, s->name, k);
    sweep_expect(strstr(message, "AMD ordering") != NULL ||
                     strstr(message, "elimination tree and column counts") != NULL,
                 s->name, k);
    if (source == FAULT_POOL) {
        sweep_expect(strstr(message, "CSparse's pool in the memory block") != NULL, s->name, k);
        /* everything CSparse took from the pool was given back */
        sweep_expect(graph->linear->cs_pool.used == 0, s->name, k);
    } else {
        sweep_expect(strstr(message, "malloc returned NULL") != NULL, s->name, k);
    }
    look(graph, &now);
    sweep_expect(same(&now, before), s->name, k);
}

/* Fails every allocation of the scenario's call in turn; returns how many fault points. */
static long sweep(const scenario_t *s)
{
    static visible_t before, expected, now;
    const size_t need = pgem_memory_size(&s->config);
    unsigned char *twin_block = malloc(need), *block = malloc(need), *pristine = malloc(need);
    assert_true(twin_block != NULL && block != NULL && pristine != NULL);

    /* the twin never fails: what the call must give */
    pgem_t *twin = prepare(s, twin_block, need);
    pgem_memory_stats_t stats;
    pgem_memory_use(twin, &stats);
    const uint32_t analyses = stats.analyses;
    assert_int_equal(swept_call(twin, s), PGEM_OK);
    pgem_memory_use(twin, &stats);
    const uint32_t call_analyses = stats.analyses - analyses;
    look(twin, &expected);

    pgem_t *graph = prepare(s, block, need);
    const fault_source_t source = source_of(graph);
    look(graph, &before);
    assert_false(same(&before, &expected)); /* the call does change the graph */
    memcpy(pristine, block, need);          /* the instance lives in its block: a full copy */

    long points = 0, absorbed = 0;
    for (long k = 0;; k++) {
        memcpy(block, pristine, need);
#if !TEST_UNDER_SANITIZER
        const long allocated = allocations, released = releases;
#endif
        arm(source, k);
        int status = swept_call(graph, s);
        const long seen = disarm(source);
#if !TEST_UNDER_SANITIZER
        /* balanced from the heap; nothing at all from it with the pool */
        sweep_expect(allocations - allocated == releases - released, s->name, k);
        sweep_expect(source == FAULT_HEAP || allocations == allocated, s->name, k);
#endif
        if (seen <= k) { /* the call reached no fault: the sweep is complete */
            sweep_expect(status == PGEM_OK, s->name, k);
            look(graph, &now);
            sweep_expect(same(&now, &expected), s->name, k);
            break;
        }
        points++;
        if (status == PGEM_OK) {
            /* CSparse trims arrays it is done growing (cs_add, cs_fkeep: a shrinking realloc)
             * and ignores a failed trim, keeping the larger block: the call succeeds, and must
             * give exactly the twin's result */
            absorbed++;
            look(graph, &now);
            sweep_expect(same(&now, &expected), s->name, k);
            continue;
        }
        check_failed_call(s, graph, status, k, source, &before);
        /* the fault gone, the same call gives what the twin gave */
        status = swept_call(graph, s);
        sweep_expect(status == PGEM_OK, s->name, k);
        look(graph, &now);
        sweep_expect(same(&now, &expected), s->name, k);
    }
    assert_true(points > absorbed);
    print_message("%s: %ld allocations failed in turn (%s; %ld of them trims CSparse does "
                  "without), %u analyses in the call\n",
                  s->name, points, source == FAULT_POOL ? "CSparse's pool in the block" : "malloc",
                  absorbed, (unsigned)call_analyses);
    free(twin_block);
    free(block);
    free(pristine);
    return points;
}

/* 1 if this build can fail CSparse's allocations; else says why not. */
static int solve_sweeps_possible(void)
{
    pgem_t *graph = test_create(2, 4, 4);
    const fault_source_t source = source_of(graph);
    pgem_destroy(graph);
    if (source == FAULT_HEAP && TEST_UNDER_SANITIZER) {
        print_message("skipped: CSparse is the system library here and takes its workspace from "
                      "the heap, and AddressSanitizer owns malloc, so its allocations cannot be "
                      "failed in this build; the plain build (heap) and the build with CSparse "
                      "from source (pool) run this sweep\n");
        return 0;
    }
    return 1;
}

static void run_sweeps(const scenario_t *scenarios, size_t count)
{
    if (!solve_sweeps_possible()) {
        skip();
    }
    long total = 0;
    for (size_t k = 0; k < count; k++) {
        total += sweep(&scenarios[k]);
    }
    print_message("%ld fault points in %zu scenarios\n", total, count);
}

/* pgem_optimize after new edges: the analysis (AMD ordering, elimination tree, counts). */
static void test_optimize_sweep(void **state)
{
    (void)state;
    const scenario_t scenarios[] = {
        {"2D, 60 poses, Gauss-Newton", {2, 60, 0, 0, 0, 0}, 0, 0, 0, PGEM_KERNEL_NONE, 0, PGEM_GAUSS_NEWTON},
        {"2D, 120 poses, fill budget 12000, LM", {2, 120, 0, 12000, 0, 0}, 0, 0, 0, PGEM_KERNEL_NONE, 0,
         PGEM_LEVENBERG_MARQUARDT},
        {"3D, 50 poses, Gauss-Newton", {3, 50, 0, 0, 0, 0}, 0, 0, 0, PGEM_KERNEL_NONE, 0, PGEM_GAUSS_NEWTON},
        {"3D, 100 poses, fill budget 40000, LM", {3, 100, 0, 40000, 0, 0}, 0, 0, 0, PGEM_KERNEL_NONE, 0,
         PGEM_LEVENBERG_MARQUARDT},
    };
    run_sweeps(scenarios, sizeof scenarios / sizeof scenarios[0]);
}

/* pgem_robust_optimize: several analyses in one call (pruning, the structure review, the
 * consistency test's re-admissions); a failure in any of them restores the estimate and the
 * loops' weights and states. */
static void test_robust_sweep(void **state)
{
    (void)state;
    const scenario_t scenarios[] = {
        {"2D, 100 poses, EM, 20 false loops", {2, 100, 0, 0, 0, 0}, 1, 20, 1, PGEM_KERNEL_EM, 0,
         PGEM_GAUSS_NEWTON},
        {"2D, 80 poses, literal EM, 6 false loops", {2, 80, 0, 0, 0, 0}, 1, 6, 1, PGEM_KERNEL_EM, 1,
         PGEM_GAUSS_NEWTON},
        {"2D, 60 poses, Cauchy, 3 false loops", {2, 60, 0, 0, 0, 0}, 1, 3, 1, PGEM_KERNEL_CAUCHY, 0,
         PGEM_GAUSS_NEWTON},
        {"2D, 60 poses, kernel none after EM", {2, 60, 0, 0, 0, 0}, 1, 3, 1, PGEM_KERNEL_NONE, 0,
         PGEM_GAUSS_NEWTON},
        {"3D, 60 poses, EM, 5 false loops, fill budget 60000", {3, 60, 0, 60000, 0, 0}, 1, 5, 1,
         PGEM_KERNEL_EM, 0, PGEM_GAUSS_NEWTON},
    };
    run_sweeps(scenarios, sizeof scenarios / sizeof scenarios[0]);
}

/* A factor larger than an explicit fill budget (sized exactly for the graph before the new
 * edges): a clear error and nothing changed, from pgem_optimize and from an EM solve. The
 * budget's basic case is test_solver's test_fill_budget_reports_need. */
static void test_fill_budget_too_small(void **state)
{
    (void)state;
    static visible_t before, now;
    static double truth[7 * MAX_POSES];
    for (int dimension = 2; dimension <= 3; dimension++) {
        const int poses = 70;
        pgem_config_t config = {dimension, (uint32_t)poses, 0, 0, 0, 0};
        pgem_t *graph = NULL;
        assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
        build_graph(graph, dimension, poses, truth);
        assert_int_equal(pgem_analyze(graph), PGEM_OK);
        pgem_memory_stats_t stats;
        pgem_memory_use(graph, &stats);
        pgem_destroy(graph);

        config.fill_budget = stats.factor_nonzeros; /* exactly what the first graph needs */
        assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
        build_graph(graph, dimension, poses, truth);
        assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
        grow_graph(graph, dimension, poses, truth, 4);
        look(graph, &before);

        pgem_summary_t summary;
        char expected[64];
        snprintf(expected, sizeof expected, "but config.fill_budget is %u", (unsigned)config.fill_budget);
        assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_ERR_FILL_BUDGET);
        assert_int_equal(summary.termination, PGEM_TERM_FILL_BUDGET);
        assert_false(summary.usable);
        assert_contains(pgem_last_error(graph), "the Cholesky factor needs ");
        assert_contains(pgem_last_error(graph), expected);
        pgem_memory_use(graph, &stats);
        assert_true(stats.factor_nonzeros > config.fill_budget);
        look(graph, &now);
        assert_true(same(&now, &before));

        pgem_robust_options_t robust = {0};
        robust.kernel = PGEM_KERNEL_EM;
        pgem_robust_summary_t robust_summary;
        assert_int_equal(pgem_robust_optimize(graph, &robust, NULL, &robust_summary),
                         PGEM_ERR_FILL_BUDGET);
        assert_false(robust_summary.usable);
        assert_contains(pgem_last_error(graph), expected);
        look(graph, &now);
        assert_true(same(&now, &before));
        pgem_destroy(graph);
    }
}

/* A 3D helix streamed pose by pose, one incremental update each (every moved pose relinearised
 * at once, so poses leave the factor by downdates), with loops a turn back, and with the
 * `fault`-th downdate broken (negative: none). Returns how many downdates it asked for; every
 * update must succeed; *rebuilt_at gets the first update that met the fault and rebuilt, the
 * final poses go to `poses_out`. */
static long downdate_stream(long fault, int poses, double *poses_out, int *rebuilt_at)
{
    const pgem_config_t config = {3, (uint32_t)poses, 4u * (uint32_t)poses, 0, 0,
                                  64u * 36u * (uint32_t)poses};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    pgem_update_options_t options;
    memset(&options, 0, sizeof options);
    options.relinearize_threshold = -1.0; /* any motion */
    options.relinearize_skip = 1u;
    test_rng_t rng = {31};
    double information[36], truth[2][7], z[7], noise[6], estimate[7];
    test_diagonal_information(6, 400.0, information);
    *rebuilt_at = -1;
    pgem_fault_arm_downdate(fault);
    for (int k = 0; k < poses; k++) {
        const double angle = 0.25 * k;
        const double tangent[6] = {5.0 * cos(angle), 5.0 * sin(angle), 0.04 * k, 0.1, 0.0, angle};
        memcpy(truth[0], truth[1], sizeof truth[1]);
        pgem_se3_exp(tangent, truth[1]);
        if (k == 0) {
            assert_int_equal(pgem_add_pose(graph, 0, truth[1]), PGEM_OK);
            continue;
        }
        pgem_se3_between(truth[0], truth[1], z);
        for (int d = 0; d < 6; d++) {
            noise[d] = 0.03 * test_gaussian(&rng);
        }
        pgem_se3_boxplus(z, noise, z);
        assert_int_equal(pgem_pose(graph, (pgem_id_t)(k - 1), estimate), PGEM_OK);
        pgem_se3_compose(estimate, z, estimate);
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)k, estimate), PGEM_OK);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 1), (pgem_id_t)k, z, information,
                                       PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
        if (k >= 25) { /* a turn back: the truth there, composed again */
            double back[7];
            const double earlier = 0.25 * (k - 25);
            const double t_back[6] = {5.0 * cos(earlier), 5.0 * sin(earlier), 0.04 * (k - 25),
                                      0.1, 0.0, earlier};
            pgem_se3_exp(t_back, back);
            pgem_se3_between(back, truth[1], z);
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 25), (pgem_id_t)k, z,
                                           information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
        }
        const long before = pgem_fault_downdates_seen();
        pgem_update_summary_t summary;
        const int status = pgem_update(graph, &options, &summary);
        if (status != PGEM_OK) {
            fail_msg("update %d with downdate %ld broken: %s", k, fault, pgem_last_error(graph));
        }
        if (*rebuilt_at < 0 && fault >= before && fault < pgem_fault_downdates_seen()) {
            assert_true(summary.rebuilt);
            *rebuilt_at = k;
        }
    }
    const long seen = pgem_fault_downdates_seen();
    pgem_fault_arm_downdate(-1);
    for (int k = 0; k < poses; k++) {
        assert_int_equal(pgem_pose(graph, (pgem_id_t)k, poses_out + 7 * k), PGEM_OK);
    }
    pgem_destroy(graph);
    return seen;
}

/* A downdate of the incremental factor that rounding breaks costs its update a rebuild at the
 * current points, not a failure (and a host restarting a whole-graph solve): at the first,
 * a middle and the last downdate of the stream, every update succeeds, the one that met the
 * fault rebuilt, and the stream ends within 1e-6 m and rad of the stream that met none (the
 * rebuild only moves where later poses are linearised; both estimates solve the same graph). */
static void test_broken_downdate_rebuilds(void **state)
{
    (void)state;
    enum { POSES = 120 };
    static double clean[7 * POSES], faulted[7 * POSES];
    int rebuilt_at = 0;
    const long downdates = downdate_stream(-1, POSES, clean, &rebuilt_at);
    assert_true(downdates > 50);
    const long faults[3] = {0, downdates / 2, downdates - 1};
    for (int f = 0; f < 3; f++) {
        const long seen = downdate_stream(faults[f], POSES, faulted, &rebuilt_at);
        assert_true(rebuilt_at > 0 && seen > faults[f]);
        double worst = 0.0;
        for (int k = 0; k < POSES; k++) {
            for (int d = 0; d < 3; d++) {
                worst = fmax(worst, fabs(faulted[7 * k + d] - clean[7 * k + d]));
            }
            double q = 0.0; /* the rotations' angle apart, from the quaternions' dot product */
            for (int d = 3; d < 7; d++) {
                q += faulted[7 * k + d] * clean[7 * k + d];
            }
            worst = fmax(worst, 2.0 * acos(fmin(1.0, fabs(q))));
        }
        print_message("downdate %ld of %ld broken at update %d: the stream ends %.2g from the "
                      "clean one\n", faults[f], downdates, rebuilt_at, worst);
        assert_true(worst < 1e-6);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_block_one_byte_short),
        cmocka_unit_test(test_null_and_empty_block),
        cmocka_unit_test(test_every_carve_fails),
        cmocka_unit_test(test_optimize_sweep),
        cmocka_unit_test(test_robust_sweep),
        cmocka_unit_test(test_fill_budget_too_small),
        cmocka_unit_test(test_broken_downdate_rebuilds),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
