/* The supernodal factorisation: solves against the assembled Newton matrix on graphs that take
 * every path (one-block supernodes, dense fronts, AMD and nested dissection, each build of the
 * dense kernels), the same bits on any number of workers (the thread pool and an executor
 * that runs its workers one after the other in reverse), and the executor's checks. */
#include "test_util.h"

#include "instance.h" /* the instance's linear system (graph->linear) */
#include "linalg/linear.h"
#ifdef PGEM_HAVE_METIS
#include "pgem/metis.h"
#endif
#include "pgem/threads.h"

/* A 3D lattice of side^3 poses: odometry along a snake through it, a loop closure to every
 * lattice neighbour that is not the next pose on the path; the estimate perturbed. */
static pgem_t *lattice_3d(int side, uint32_t threads, uint64_t seed)
{
    const uint32_t poses = (uint32_t)(side * side * side);
    pgem_config_t config = {3, poses, 3u * poses, 36u * 200u * poses, threads, 0};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    test_rng_t rng = {seed};
    /* the snake: x runs back and forth, y likewise per z layer */
    int *cell = malloc(sizeof(int) * poses);
    for (int z = 0, k = 0; z < side; z++) {
        for (int y = 0; y < side; y++) {
            for (int x = 0; x < side; x++, k++) {
                const int yy = z % 2 == 0 ? y : side - 1 - y;
                const int xx = yy % 2 == 0 ? x : side - 1 - x;
                cell[(z * side + yy) * side + xx] = k;
            }
        }
    }
    double information[36];
    test_diagonal_information(6, 100.0, information);
    int *place = malloc(sizeof(int) * poses); /* pose -> its lattice cell */
    for (int c = 0; c < (int)poses; c++) {
        place[cell[c]] = c;
    }
    for (uint32_t k = 0; k < poses; k++) {
        const int c = place[k];
        double pose[7] = {c % side + 0.05 * test_gaussian(&rng),
                          (c / side) % side + 0.05 * test_gaussian(&rng),
                          c / (side * side) + 0.05 * test_gaussian(&rng),
                          0.01 * test_gaussian(&rng), 0, 0, 1};
        assert_int_equal(pgem_add_pose(graph, k, pose), PGEM_OK);
    }
    free(place);
    for (int c = 0; c < (int)poses; c++) {
        const int x = c % side, y = (c / side) % side, z = c / (side * side);
        const int neighbours[3] = {x + 1 < side ? c + 1 : -1, y + 1 < side ? c + side : -1,
                                   z + 1 < side ? c + side * side : -1};
        for (int n = 0; n < 3; n++) {
            if (neighbours[n] < 0) {
                continue;
            }
            const double delta[3] = {n == 0, n == 1, n == 2};
            int from = cell[c], to = cell[neighbours[n]];
            double z7[7] = {delta[0], delta[1], delta[2], 0, 0, 0, 1};
            if (from > to) {
                const int swap = from;
                from = to;
                to = swap;
                z7[0] = -z7[0];
                z7[1] = -z7[1];
                z7[2] = -z7[2];
            }
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)from, (pgem_id_t)to, z7, information,
                                           to - from == 1 ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP, NULL),
                             PGEM_OK);
        }
    }
    free(cell);
    return graph;
}

/* A 2D ring with loop closures (mostly one-block supernodes). */
static pgem_t *ring_2d(int n, uint32_t threads)
{
    pgem_config_t config = {2, (uint32_t)n, 3u * (uint32_t)n, 0, threads, 0};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    double *truth = malloc(sizeof(double) * 3u * (size_t)n);
    test_ring_2d(graph, n, 7, 0.05, 0.01, 21, truth);
    free(truth);
    return graph;
}

/* max |H x - rhs| / max |rhs| for the step x the factor solves, H from the lower storage. */
static double solve_residual(pgem_t *graph)
{
    pgem_linear_t *linear = graph->linear;
    const int b = linear->block, n = linear->scalar_count;
    (void)pgem_linear_assemble(graph->linear, &graph->store);
    assert_int_equal(pgem_linear_factor(graph->linear, &graph->store, &graph->executor, graph->message), PGEM_OK);
    double *rhs = malloc(sizeof(double) * (size_t)n), *x = malloc(sizeof(double) * (size_t)n);
    double *product = calloc((size_t)n, sizeof(double));
    memcpy(rhs, linear->rhs, sizeof(double) * (size_t)n);
    memcpy(x, rhs, sizeof(double) * (size_t)n);
    pgem_linear_solve(graph->linear, x);
    for (int block = 0; block < linear->block_count; block++) {
        for (int c = 0; c < b; c++) {
            const int j = block * b + c;
            const double *h = linear->lower_values + pgem_lower_column(linear, block, c);
            for (int r = c; r < b; r++) { /* the diagonal block, both triangles */
                const int i = block * b + r;
                product[i] += h[r - c] * x[j];
                if (i != j) {
                    product[j] += h[r - c] * x[i];
                }
            }
            h += b - c;
            for (int q = linear->block_colptr[block]; q < linear->block_colptr[block + 1]; q++) {
                for (int r = 0; r < b; r++, h++) {
                    const int i = linear->block_rows[q] * b + r;
                    product[i] += *h * x[j];
                    product[j] += *h * x[i];
                }
            }
        }
    }
    double worst = 0.0, scale = 0.0;
    for (int i = 0; i < n; i++) {
        worst = fmax(worst, fabs(product[i] - rhs[i]));
        scale = fmax(scale, fabs(rhs[i]));
    }
    free(rhs);
    free(x);
    free(product);
    return worst / scale;
}

static void check_residual(pgem_t *graph, const char *label)
{
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    const double residual = solve_residual(graph);
    if (!(residual < 1e-9)) {
        fail_msg("%s: relative residual %g", label, residual);
    }
}

/* One-block supernodes (blocks.c) and AMD: a sparse ring. */
static void test_solves_sparse_ring(void **state)
{
    (void)state;
    pgem_t *graph = ring_2d(600, 1);
    check_residual(graph, "ring");
    assert_int_equal(graph->linear->factor.ordering, PGEM_ORDERING_AMD);
    pgem_destroy(graph);
}

/* Wide supernodes (the dense kernels), nested dissection, on every build this CPU runs. */
static void test_solves_lattice_every_build(void **state)
{
    (void)state;
    pgem_t *graph = lattice_3d(14, 1, 5);
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    const pgem_factor_t *factor = &graph->linear->factor;
    assert_int_equal(factor->ordering, PGEM_ORDERING_NESTED);
    assert_true(factor->nested_flops < factor->amd_flops);
    int widest = 0;
    for (int s = 0; s < factor->super_count; s++) {
        const int width = factor->super_first[s + 1] - factor->super_first[s];
        widest = width > widest ? width : widest;
    }
    assert_true(widest * factor->block > PGEM_DENSE_PANEL); /* blocked dense factorisation */
    const pgem_dense_ops_t *builds[3] = {&pgem_dense_portable, NULL, NULL};
#ifdef PGEM_DENSE_X86
    __builtin_cpu_init();
    builds[1] = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") ? &pgem_dense_avx2 : NULL;
    builds[2] = __builtin_cpu_supports("avx512f") ? &pgem_dense_avx512 : NULL;
#endif
    for (int k = 0; k < 3; k++) {
        if (builds[k] != NULL) {
            graph->linear->dense = builds[k];
            check_residual(graph, builds[k]->name);
        }
    }
    pgem_destroy(graph);
}

/* Runs the workers one after the other, the last first: any order the threads could take. */
static void reverse_run(void *executor, pgem_task_fn task, void *context)
{
    const uint32_t workers = *(const uint32_t *)executor;
    for (uint32_t w = workers; w-- > 0u;) {
        task(context, w);
    }
}

/* The factor's values and the optimised poses after a few Gauss-Newton iterations. */
typedef struct run_result {
    double *values;
    size_t value_count;
    double *poses;
} run_result_t;

/* Under valgrind or qemu (tens of times slower) the graphs are smaller. */
static int slow_machine(void)
{
    return getenv("PGEM_TEST_VALGRIND") != NULL || getenv("PGEM_TEST_EMULATED") != NULL;
}

/* Whether the thread pool can start its threads here. Under qemu-user (the aarch64 build's
 * tests, PGEM_TEST_EMULATED) the first pthread_create of a process never returns: Debian 12's
 * qemu-aarch64 7.2 hangs so on a five-line program that starts one thread. There the worker
 * tests run the same schedules through reverse_run, one worker after another, the last first;
 * the pool's threads run in the native, sanitizer, valgrind, clang and m32 builds. */
static int threads_can_start(void)
{
    return getenv("PGEM_TEST_EMULATED") == NULL;
}

/* Side of the lattice of the worker tests. */
static int worker_side(void)
{
    return slow_machine() ? 7 : 10;
}

static run_result_t run_lattice(uint32_t workers, int pool)
{
    pgem_t *graph = lattice_3d(worker_side(), workers, 9);
    pgem_thread_pool_t *threads = NULL;
    uint32_t reverse_workers = workers;
    pgem_executor_t executor = {reverse_run, &reverse_workers, workers};
    if (pool) {
        assert_int_equal(pgem_thread_pool_create(workers, &threads), PGEM_OK);
        executor = pgem_thread_pool_executor(threads);
    }
    assert_int_equal(pgem_set_executor(graph, workers > 1u ? &executor : NULL), PGEM_OK);
    pgem_solve_options_t options = {0};
    options.max_iterations = slow_machine() ? 1 : 3;
    assert_int_equal(pgem_optimize(graph, &options, NULL), PGEM_OK);
    assert_true(graph->linear->factor.task_count > 1);
    run_result_t result;
    result.value_count = (size_t)graph->linear->factor.nonzeros;
    result.values = malloc(sizeof(double) * result.value_count);
    memcpy(result.values, graph->linear->factor.values, sizeof(double) * result.value_count);
    result.poses = malloc(sizeof(double) * 7u * pgem_pose_count(graph));
    test_snapshot(graph, result.poses);
    pgem_destroy(graph);
    pgem_thread_pool_destroy(threads);
    return result;
}

static void test_workers_give_the_same_bits(void **state)
{
    (void)state;
    run_result_t one = run_lattice(1, 0);
    const uint32_t counts[] = {2, 3, 4, 7};
    const size_t tried = slow_machine() ? 2u : sizeof counts / sizeof counts[0];
    const size_t poses = (size_t)(worker_side() * worker_side() * worker_side());
    for (int pool = 0; pool < (threads_can_start() ? 2 : 1); pool++) {
        for (size_t k = 0; k < tried; k++) {
            run_result_t many = run_lattice(counts[k], pool);
            assert_int_equal(many.value_count, one.value_count);
            assert_memory_equal(many.values, one.values, sizeof(double) * one.value_count);
            assert_memory_equal(many.poses, one.poses, sizeof(double) * 7u * poses);
            free(many.values);
            free(many.poses);
        }
    }
    free(one.values);
    free(one.poses);
}

/* A factorisation that fails reports the same pivot on any number of workers. */
static void test_failure_is_the_same_on_every_worker_count(void **state)
{
    (void)state;
    char first[PGEM_MESSAGE_SIZE] = "";
    for (uint32_t workers = 1; workers <= (slow_machine() ? 2u : 4u); workers++) {
        pgem_t *graph = lattice_3d(worker_side(), workers, 9);
        pgem_thread_pool_t *threads = NULL;
        uint32_t reverse_workers = workers;
        pgem_executor_t executor = {reverse_run, &reverse_workers, workers};
        if (threads_can_start()) {
            assert_int_equal(pgem_thread_pool_create(workers, &threads), PGEM_OK);
            executor = pgem_thread_pool_executor(threads);
        }
        assert_int_equal(pgem_set_executor(graph, &executor), PGEM_OK);
        assert_int_equal(pgem_analyze(graph), PGEM_OK);
        (void)pgem_linear_assemble(graph->linear, &graph->store);
        /* a negative diagonal entry deep in one subtree and one in another */
        graph->linear->lower_values[pgem_lower_column(graph->linear, 40, 2)] = -1.0;
        graph->linear->lower_values[pgem_lower_column(graph->linear, worker_side() * 30, 1)] = -1.0;
        assert_int_equal(pgem_linear_factor(graph->linear, &graph->store, &graph->executor, graph->message), PGEM_ERR_NOT_POSITIVE_DEFINITE);
        if (workers == 1) {
            snprintf(first, sizeof first, "%s", pgem_last_error(graph));
        } else {
            assert_string_equal(pgem_last_error(graph), first);
        }
        pgem_destroy(graph);
        pgem_thread_pool_destroy(threads);
    }
    assert_contains(first, "not positive definite at unknown");
}

static void test_executor_checks(void **state)
{
    (void)state;
    pgem_t *graph = ring_2d(50, 2);
    uint32_t workers = 3;
    pgem_executor_t executor = {reverse_run, &workers, 3};
    assert_int_equal(pgem_set_executor(graph, &executor), PGEM_ERR_INVALID_ARGUMENT);
    assert_contains(pgem_last_error(graph), "1 .. config.threads (2)");
    executor.workers = 0;
    assert_int_equal(pgem_set_executor(graph, &executor), PGEM_ERR_INVALID_ARGUMENT);
    executor.workers = 2;
    executor.run = NULL;
    assert_int_equal(pgem_set_executor(graph, &executor), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_set_executor(NULL, &executor), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_set_executor(graph, NULL), PGEM_OK);
    pgem_config_t too_many = {2, 10, 10, 0, PGEM_MAX_THREADS + 1u, 0};
    assert_int_equal(pgem_memory_size(&too_many), 0u);
    pgem_thread_pool_t *pool = NULL;
    assert_int_equal(pgem_thread_pool_create(0, &pool), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_thread_pool_create(PGEM_MAX_THREADS + 1u, &pool), PGEM_ERR_INVALID_ARGUMENT);
    assert_true(pgem_thread_count_online() >= 1u);
    pgem_destroy(graph);
}

/* Two analyses of the same graph choose the same ordering, to the pose. */
static void test_ordering_is_deterministic(void **state)
{
    (void)state;
    pgem_t *a = lattice_3d(13, 1, 9), *b = lattice_3d(13, 1, 9); /* 2197 poses: dissected */
    assert_int_equal(pgem_analyze(a), PGEM_OK);
    assert_int_equal(pgem_analyze(b), PGEM_OK);
    assert_memory_equal(a->linear->pose_block, b->linear->pose_block, sizeof(int) * 13u * 13u * 13u);
    pgem_linear_invalidate(a->linear);
    assert_int_equal(pgem_analyze(a), PGEM_OK);
    assert_memory_equal(a->linear->pose_block, b->linear->pose_block, sizeof(int) * 13u * 13u * 13u);
    pgem_destroy(a);
    pgem_destroy(b);
}

/* An orderer that counts its calls and eliminates the poses in the order `kind` says:
 * 0 the natural one reversed, 1 not a permutation, 2 a failure. */
typedef struct test_orderer {
    int kind;
    int calls;
} test_orderer_t;

static int test_order(void *orderer, int blocks, const int *colptr, const int *rows, int *order)
{
    test_orderer_t *test = orderer;
    test->calls++;
    assert_true(colptr[0] == 0 && colptr[blocks] > 0);
    for (int j = 0; j < blocks; j++) {
        for (int q = colptr[j]; q < colptr[j + 1]; q++) {
            assert_true(rows[q] < j && (q == colptr[j] || rows[q] > rows[q - 1]));
        }
        order[j] = test->kind == 1 ? 0 : blocks - 1 - j;
    }
    return test->kind == 2;
}

/* The orderer is weighed by flops under AUTO (the natural order of a lattice loses to AMD, so
 * nested dissection is tried too and wins), used alone when the choice names it, skipped when
 * the choice is AMD or NESTED, and ignored when it fails or is no permutation. The orderings
 * chosen alone are factorised on a small lattice: the natural order's band is slow under
 * valgrind on the large one. */
static void test_orderer_is_weighed(void **state)
{
    (void)state;
    pgem_t *graph = lattice_3d(14, 1, 5);
    test_orderer_t test = {0, 0};
    const pgem_orderer_t orderer = {test_order, &test};
    const pgem_factor_t *factor = &graph->linear->factor;
    assert_int_equal(pgem_set_ordering(graph, PGEM_ORDER_AUTO, &orderer), PGEM_OK);
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    assert_int_equal(test.calls, 1);
    assert_int_equal(factor->ordering, PGEM_ORDERING_NESTED);
    assert_true(factor->orderer_flops > factor->amd_flops);
    assert_true(factor->nested_flops > 0.0 && factor->nested_flops < factor->amd_flops);
    pgem_destroy(graph);

    graph = lattice_3d(6, 1, 5);
    factor = &graph->linear->factor;
    assert_int_equal(pgem_set_ordering(graph, PGEM_ORDER_ORDERER, &orderer), PGEM_OK);
    check_residual(graph, "the orderer's ordering");
    assert_int_equal(test.calls, 2);
    assert_int_equal(factor->ordering, PGEM_ORDERING_ORDERER);
    assert_true(factor->nested_flops < 0.0 && factor->orderer_flops > factor->amd_flops);
    assert_true(factor->exact_flops == factor->orderer_flops);
    for (int kind = 1; kind <= 2; kind++) {
        test.kind = kind;
        pgem_linear_invalidate(graph->linear);
        check_residual(graph, "a failing orderer");
        assert_int_equal(factor->ordering, PGEM_ORDERING_AMD);
        assert_true(factor->orderer_flops < 0.0);
    }
    test.kind = 0;
    assert_int_equal(pgem_set_ordering(graph, PGEM_ORDER_AMD, &orderer), PGEM_OK);
    check_residual(graph, "AMD alone");
    assert_int_equal(factor->ordering, PGEM_ORDERING_AMD);
    assert_int_equal(pgem_set_ordering(graph, PGEM_ORDER_NESTED, &orderer), PGEM_OK);
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    assert_int_equal(test.calls, 4);
    assert_true(factor->orderer_flops < 0.0);
    const pgem_orderer_t empty = {NULL, NULL};
    assert_int_equal(pgem_set_ordering(graph, PGEM_ORDER_AUTO, &empty), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_set_ordering(graph, PGEM_ORDER_ORDERER, NULL), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_set_ordering(graph, (pgem_order_choice_t)7, NULL),
                     PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_analyze(graph), PGEM_OK); /* the refusals changed nothing */
    assert_int_equal(test.calls, 4);
    pgem_destroy(graph);
}

#ifdef PGEM_HAVE_METIS
/* METIS as the orderer: under AUTO on a large lattice it beats AMD, so it is kept and our own
 * dissection is not run beside it; chosen alone, its ordering solves. */
static void test_metis_orderer(void **state)
{
    (void)state;
    pgem_t *graph = lattice_3d(14, 1, 5);
    const pgem_orderer_t metis = pgem_metis_orderer();
    const pgem_factor_t *factor = &graph->linear->factor;
    assert_int_equal(pgem_set_ordering(graph, PGEM_ORDER_AUTO, &metis), PGEM_OK);
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    assert_int_equal(factor->ordering, PGEM_ORDERING_ORDERER);
    assert_true(factor->orderer_flops > 0.0 && factor->orderer_flops < factor->amd_flops);
    assert_true(factor->nested_flops < 0.0); /* not tried */
    assert_true(factor->exact_flops == factor->orderer_flops);
    pgem_destroy(graph);
    graph = lattice_3d(8, 1, 5);
    factor = &graph->linear->factor;
    assert_int_equal(pgem_metis_use(graph, PGEM_ORDER_ORDERER), PGEM_OK);
    check_residual(graph, "METIS");
    assert_int_equal(factor->ordering, PGEM_ORDERING_ORDERER);
    assert_true(factor->orderer_flops > 0.0);
    pgem_destroy(graph);
}
#endif

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_solves_sparse_ring),
        cmocka_unit_test(test_solves_lattice_every_build),
        cmocka_unit_test(test_workers_give_the_same_bits),
        cmocka_unit_test(test_failure_is_the_same_on_every_worker_count),
        cmocka_unit_test(test_executor_checks),
        cmocka_unit_test(test_orderer_is_weighed),
#ifdef PGEM_HAVE_METIS
        cmocka_unit_test(test_metis_orderer),
#endif
        cmocka_unit_test(test_ordering_is_deterministic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
