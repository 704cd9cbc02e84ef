/* Robust layer tests: kernel formulas, EM on inlier-only and corrupted graphs, the paper's
 * M-estimator equivalence, determinism, reporting and reset of pruned loops. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "instance.h" /* to put an estimate out of range behind the API */
#include "test_util.h"


#define RING 120
#define FALSE_LOOPS 12
/* Odometry noise of the test rings: 2 cm per step, and a gyro-like heading (2 mrad). With
 * heading noise as large as the translation noise (0.02 rad), the metres-long lever arm makes
 * the chain far less certain than each loop's information claims, true loops start at chi2
 * ~ 200, and EM at c = 1 prunes some (docs/design/innovation.md). */
#define SIGMA 0.02
#define HEADING_SIGMA 0.002

static void test_kernel_formulas(void **state)
{
    (void)state;
    assert_near(pgem_kernel_weight(PGEM_KERNEL_EM, 3.0, 1.0), 0.25, 1e-15);
    assert_near(pgem_kernel_weight(PGEM_KERNEL_CAUCHY, 3.0, 2.0), 1.0 / 1.75, 1e-15);
    assert_near(pgem_kernel_weight(PGEM_KERNEL_HUBER, 4.0, 3.0), 1.0, 0.0);
    assert_near(pgem_kernel_weight(PGEM_KERNEL_HUBER, 36.0, 3.0), 0.5, 1e-15);
    assert_near(pgem_kernel_weight(PGEM_KERNEL_DCS, 0.5, 1.0), 1.0, 0.0);
    assert_near(pgem_kernel_weight(PGEM_KERNEL_DCS, 3.0, 1.0), 0.25, 1e-15);
    assert_near(pgem_kernel_weight(PGEM_KERNEL_NONE, 1e9, 1.0), 1.0, 0.0);
    assert_string_equal(pgem_kernel_name(PGEM_KERNEL_DCS), "dcs");
}

/* Appends false loop closures between far-apart poses with random measurements. */
static void add_false_loops(pgem_t *graph, int count, uint64_t seed, uint32_t *indices)
{
    test_rng_t rng = {seed};
    double information[9];
    test_diagonal_information(3, 1.0 / (0.02 * 0.02), information);
    for (int k = 0; k < count; k++) {
        int from = (int)(test_uniform(&rng) * RING), to = (from + 20 + (int)(test_uniform(&rng) * (RING - 40))) % RING;
        double z[3] = {10.0 * test_uniform(&rng) - 5.0, 10.0 * test_uniform(&rng) - 5.0, 3.0 * test_uniform(&rng)};
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)from, (pgem_id_t)to, z, information,
                                       PGEM_EDGE_LOOP, &indices[k]), PGEM_OK);
    }
}

/* A ring of RING poses (a loop closure every 6) with the test rings' noise. */
static pgem_t *ring(uint64_t seed, double *truth)
{
    pgem_t *graph = test_create(2, RING, 3 * RING);
    test_ring_2d(graph, RING, 6, SIGMA, HEADING_SIGMA, seed, truth);
    return graph;
}

/* ring(), then FALSE_LOOPS false loop closures (their edge indices into false_loops). */
static pgem_t *corrupted_ring(uint64_t seed, uint64_t false_seed, double *truth,
                              uint32_t *false_loops)
{
    pgem_t *graph = ring(seed, truth);
    add_false_loops(graph, FALSE_LOOPS, false_seed, false_loops);
    return graph;
}

static pgem_robust_options_t em_options(void)
{
    pgem_robust_options_t options = {0};
    options.kernel = PGEM_KERNEL_EM;
    return options;
}

static void test_inliers_only_nothing_pruned_plain_optimum(void **state)
{
    (void)state;
    double truth[3 * RING], a[3 * RING], b[3 * RING];
    pgem_t *robust = ring(21, truth), *plain = ring(21, truth);
    pgem_robust_options_t options = em_options();
    pgem_robust_summary_t summary;
    pgem_summary_t plain_summary;
    assert_int_equal(pgem_robust_optimize(robust, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(pgem_optimize(plain, NULL, &plain_summary), PGEM_OK);
    assert_true(summary.usable);
    assert_int_equal(summary.pruned, 0);
    assert_true(summary.loops > 0);
    assert_near(summary.final_chi2, plain_summary.final_chi2, 1e-8 * plain_summary.final_chi2);
    test_snapshot(robust, a);
    test_snapshot(plain, b);
    for (int k = 0; k < 3 * RING; k++) {
        assert_near(a[k], b[k], 1e-7);
    }
    pgem_destroy(robust);
    pgem_destroy(plain);
}

static void check_outliers_found(pgem_kernel_t kernel, int literal)
{
    double truth[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    pgem_t *graph = corrupted_ring(33, 77, truth, false_loops);
    pgem_robust_options_t options = em_options();
    options.kernel = kernel;
    options.literal = literal;
    pgem_robust_summary_t summary;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
        pgem_edge_view_t edge;
        assert_int_equal(pgem_edge_at(graph, k, &edge), PGEM_OK);
        int is_false = 0;
        for (int m = 0; m < FALSE_LOOPS; m++) {
            is_false |= false_loops[m] == k;
        }
        double weight = -1.0;
        pgem_loop_state_t loop_state = PGEM_LOOP_DORMANT;
        assert_int_equal(pgem_loop_weight(graph, k, &weight), PGEM_OK);
        assert_int_equal(pgem_loop_state(graph, k, &loop_state), PGEM_OK);
        assert_true(weight == edge.weight);
        assert_int_equal(loop_state, edge.active ? PGEM_LOOP_ACCEPTED : PGEM_LOOP_PRUNED);
        if (kernel == PGEM_KERNEL_EM) {
            /* every false loop pruned, every true one accepted: precision = recall = 1 */
            assert_int_equal(edge.active, !is_false);
        } else if (is_false) {
            assert_true(edge.weight < 0.05); /* IRLS kernels keep them, nearly switched off */
        }
    }
    if (kernel == PGEM_KERNEL_EM) {
        assert_int_equal(summary.pruned, FALSE_LOOPS);
    }
    /* the map is the ground truth up to noise (EM: outliers gone; IRLS: nearly ignored) */
    for (int k = 0; kernel == PGEM_KERNEL_EM && k < RING; k++) {
        double pose[3];
        assert_int_equal(pgem_pose(graph, (pgem_id_t)k, pose), PGEM_OK);
        assert_near(pose[0], truth[3 * k], 0.5);
        assert_near(pose[1], truth[3 * k + 1], 0.5);
    }
    pgem_destroy(graph);
}

/* rho and rho' of every built-in kernel: rho' (a central difference of rho) is the weight,
 * rho is continuous where the formula changes, and rho(0) = 0. */
static void test_kernel_rho_and_derivative(void **state)
{
    (void)state;
    const pgem_kernel_t kernels[] = {PGEM_KERNEL_EM, PGEM_KERNEL_CAUCHY, PGEM_KERNEL_HUBER,
                                     PGEM_KERNEL_DCS, PGEM_KERNEL_NONE};
    const double scales[] = {0.5, 1.0, 3.0};
    for (size_t k = 0; k < sizeof kernels / sizeof kernels[0]; k++) {
        for (size_t m = 0; m < sizeof scales / sizeof scales[0]; m++) {
            const double scale = scales[m];
            assert_near(pgem_kernel_evaluate(kernels[k], 0.0, scale).rho, 0.0, 0.0);
            for (double s = 0.01; s < 200.0; s *= 1.37) {
                const pgem_kernel_value_t value = pgem_kernel_evaluate(kernels[k], s, scale);
                const double h = 1e-6 * s;
                const double derivative = (pgem_kernel_evaluate(kernels[k], s + h, scale).rho -
                                           pgem_kernel_evaluate(kernels[k], s - h, scale).rho) /
                                          (2.0 * h);
                assert_near(derivative, value.weight, 1e-6);
                assert_true(value.weight == pgem_kernel_weight(kernels[k], s, scale));
                assert_true(value.rho <= s + 1e-12); /* a robust cost never exceeds s */
            }
        }
    }
    /* the formulas' switch points: Huber at r = k, DCS at s = phi */
    assert_near(pgem_kernel_evaluate(PGEM_KERNEL_HUBER, 9.0 * (1.0 + 1e-12), 3.0).rho, 9.0, 1e-9);
    assert_near(pgem_kernel_evaluate(PGEM_KERNEL_DCS, 2.0 * (1.0 + 1e-12), 2.0).rho, 2.0, 1e-9);
    assert_near(pgem_kernel_evaluate(PGEM_KERNEL_CAUCHY, 3.0, 1.0).rho, log(4.0), 1e-15);
    assert_string_equal(pgem_kernel_name(PGEM_KERNEL_USER), "user");
}

/* A user kernel: Cauchy written by the user (counting its calls). */
typedef struct user_cauchy {
    unsigned long calls;
} user_cauchy_t;

static pgem_kernel_value_t user_cauchy(double chi2, double scale, void *user)
{
    ((user_cauchy_t *)user)->calls++;
    const double c2 = scale * scale;
    pgem_kernel_value_t value = {c2 * log1p(chi2 / c2), 1.0 / (1.0 + chi2 / c2)};
    return value;
}

/* A user kernel that switches a loop off past a chi2 of `scale` (truncated least squares). */
static pgem_kernel_value_t user_truncated(double chi2, double scale, void *user)
{
    (void)user;
    pgem_kernel_value_t value = {chi2 < scale ? chi2 : scale, chi2 < scale ? 1.0 : 0.0};
    return value;
}

static pgem_kernel_value_t user_broken(double chi2, double scale, void *user)
{
    (void)chi2;
    (void)scale;
    (void)user;
    pgem_kernel_value_t value = {0.0, (double)NAN};
    return value;
}

/* A user's kernel plugs in through the options: the same Cauchy as the built-in gives the same
 * bits; a truncated kernel switches the false loops off and keeps the true ones; a kernel whose
 * weight is not in [0, 1] fails the solve, naming the loop, and changes nothing; a user kernel
 * without a function is refused. */
static void test_user_kernel(void **state)
{
    (void)state;
    double truth[3 * RING], built_in[3 * RING], by_user[3 * RING], before[3 * RING], after[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    pgem_robust_options_t options = {0};
    pgem_robust_summary_t summary;
    options.kernel = PGEM_KERNEL_CAUCHY;
    options.scale = 2.0;
    pgem_t *graph = corrupted_ring(33, 77, truth, false_loops);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    test_snapshot(graph, built_in);
    pgem_destroy(graph);

    user_cauchy_t counter = {0};
    options.kernel = PGEM_KERNEL_USER;
    options.kernel_function = user_cauchy;
    options.kernel_user = &counter;
    graph = corrupted_ring(33, 77, truth, false_loops);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    test_snapshot(graph, by_user);
    assert_memory_equal(built_in, by_user, sizeof built_in);
    assert_true(counter.calls >= (unsigned long)summary.loops);
    pgem_destroy(graph);

    options.kernel_function = user_truncated;
    options.scale = 50.0;
    graph = corrupted_ring(33, 77, truth, false_loops);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.rejected, FALSE_LOOPS); /* weight 0 < prune_threshold */
    for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
        double weight = -1.0;
        assert_int_equal(pgem_loop_weight(graph, k, &weight), PGEM_OK);
        int is_false = 0;
        for (int m = 0; m < FALSE_LOOPS; m++) {
            is_false |= false_loops[m] == k;
        }
        assert_true(weight == (is_false ? 0.0 : 1.0));
    }
    pgem_destroy(graph);

    options.kernel_function = user_broken;
    graph = corrupted_ring(33, 77, truth, false_loops);
    test_snapshot(graph, before);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_ERR_NUMERIC);
    assert_false(summary.usable);
    assert_int_equal(summary.termination, PGEM_ROBUST_FAILED);
    assert_contains(pgem_last_error(graph), "user kernel's weight for loop closure");
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    double weight = 0.0;
    assert_int_equal(pgem_loop_weight(graph, false_loops[0], &weight), PGEM_OK);
    assert_true(weight == 1.0);

    options.kernel_function = NULL;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_ERR_INVALID_ARGUMENT);
    assert_contains(pgem_last_error(graph), "kernel_function");
    options.kernel = (pgem_kernel_t)(PGEM_KERNEL_USER + 1);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_ERR_INVALID_ARGUMENT);
    assert_contains(pgem_last_error(graph), "unknown robust kernel");
    pgem_destroy(graph);
}

/* One meaning for zeroed options: EM with its defaults (and NULL options the same). */
static void test_zeroed_options_mean_em(void **state)
{
    (void)state;
    double truth[3 * RING], explicit_em[3 * RING], zeroed[3 * RING], null_options[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    pgem_robust_options_t options = em_options();
    pgem_robust_summary_t summary;
    pgem_t *graph = corrupted_ring(33, 77, truth, false_loops);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.pruned, FALSE_LOOPS);
    test_snapshot(graph, explicit_em);
    pgem_destroy(graph);
    pgem_robust_options_t zero;
    memset(&zero, 0, sizeof zero);
    graph = corrupted_ring(33, 77, truth, false_loops);
    assert_int_equal(pgem_robust_optimize(graph, &zero, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.pruned, FALSE_LOOPS);
    test_snapshot(graph, zeroed);
    pgem_destroy(graph);
    graph = corrupted_ring(33, 77, truth, false_loops);
    assert_int_equal(pgem_robust_optimize(graph, NULL, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.pruned, FALSE_LOOPS);
    test_snapshot(graph, null_options);
    pgem_destroy(graph);
    assert_memory_equal(explicit_em, zeroed, sizeof zeroed);
    assert_memory_equal(explicit_em, null_options, sizeof zeroed);
}

static int stop_at_first_round(const pgem_robust_progress_t *progress, void *user)
{
    (void)progress;
    (void)user;
    return 1;
}

/* The weighted chi2 of the edges in the problem, through the API. */
static double api_weighted_chi2(const pgem_t *graph)
{
    double chi2 = 0.0;
    for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
        pgem_edge_view_t edge;
        double edge_chi2 = 0.0;
        assert_int_equal(pgem_edge_at(graph, k, &edge), PGEM_OK);
        assert_int_equal(pgem_edge_chi2(graph, k, &edge_chi2), PGEM_OK);
        chi2 += edge.active ? edge.weight * edge_chi2 : 0.0;
    }
    return chi2;
}

/* Why a robust solve stopped, and its chi2 convention: initial_chi2 is weighted at the weights
 * the call found (a second call after pruning leaves the pruned loops out), like final_chi2. */
static void test_termination_and_chi2_convention(void **state)
{
    (void)state;
    double truth[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    pgem_robust_options_t options = em_options();
    pgem_robust_summary_t summary;
    pgem_t *graph = corrupted_ring(33, 77, truth, false_loops);
    const double fresh = pgem_total_chi2(graph);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.termination, PGEM_ROBUST_CONVERGED);
    assert_true(summary.initial_chi2 == fresh); /* every weight 1, nothing pruned yet */
    assert_near(summary.final_chi2, api_weighted_chi2(graph), 1e-9 * summary.final_chi2);
    const double weighted = api_weighted_chi2(graph);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_near(summary.initial_chi2, weighted, 1e-9 * weighted);
    assert_true(summary.initial_chi2 < pgem_total_chi2(graph)); /* the pruned loops left out */
    pgem_robust_reset(graph);

    options.on_round = stop_at_first_round;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.termination, PGEM_ROBUST_STOPPED);
    pgem_robust_reset(graph);

    options = em_options();
    options.literal = 1;
    options.max_rounds = 1; /* the first round prunes: no round left to see nothing pruned */
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_true(summary.pruned > 0u);
    assert_int_equal(summary.termination, PGEM_ROBUST_ROUND_LIMIT);
    pgem_robust_reset(graph);

    options = em_options();
    options.kernel = PGEM_KERNEL_CAUCHY;
    options.max_em_iterations = 1;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.termination, PGEM_ROBUST_ITERATION_LIMIT);
    options.max_em_iterations = 100;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.termination, PGEM_ROBUST_CONVERGED);
    pgem_destroy(graph);
}

/* A loop's weight and state through the API: out of range is refused and writes nothing; a
 * dormant loop (EM's state for a loop kept out of the factor) reads as dormant, not accepted. */
static void test_loop_weight_and_state(void **state)
{
    (void)state;
    double truth[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    pgem_t *graph = corrupted_ring(33, 77, truth, false_loops);
    double weight = 7.0;
    pgem_loop_state_t loop_state = PGEM_LOOP_DORMANT;
    const uint32_t edges = pgem_edge_count(graph);
    assert_int_equal(pgem_loop_weight(graph, edges, &weight), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_loop_state(graph, edges, &loop_state), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_loop_weight(NULL, 0, &weight), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_loop_state(graph, 0, NULL), PGEM_ERR_INVALID_ARGUMENT);
    assert_true(weight == 7.0);
    assert_int_equal(loop_state, PGEM_LOOP_DORMANT);
    assert_int_equal(pgem_loop_weight(graph, false_loops[0], &weight), PGEM_OK);
    assert_int_equal(pgem_loop_state(graph, false_loops[0], &loop_state), PGEM_OK);
    assert_true(weight == 1.0); /* before any robust solve */
    assert_int_equal(loop_state, PGEM_LOOP_ACCEPTED);
    graph->store.edge_active[false_loops[0]] = PGEM_EDGE_DORMANT;
    graph->store.edge_weight[false_loops[0]] = 1e-5;
    assert_int_equal(pgem_loop_state(graph, false_loops[0], &loop_state), PGEM_OK);
    assert_int_equal(loop_state, PGEM_LOOP_DORMANT);
    assert_int_equal(pgem_loop_weight(graph, false_loops[0], &weight), PGEM_OK);
    assert_true(weight == 1e-5);
    pgem_destroy(graph);
}

static void test_em_finds_outliers(void **state)
{
    (void)state;
    check_outliers_found(PGEM_KERNEL_EM, 0);
}

static void test_literal_em_finds_outliers(void **state)
{
    (void)state;
    check_outliers_found(PGEM_KERNEL_EM, 1);
}

static void test_dcs_downweights_outliers(void **state)
{
    (void)state;
    check_outliers_found(PGEM_KERNEL_DCS, 0);
}

/* Lee et al.: EM's weight is the Cauchy M-estimator's weight. At convergence (no pruning,
 * literal method) every loop's weight equals 1 / (1 + chi2 / c^2) of its final residual, and
 * the estimate is a minimum of the Cauchy cost sum c^2 log(1 + chi2 / c^2). */
static double cauchy_cost(const pgem_t *graph, double scale)
{
    double cost = 0.0;
    for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
        pgem_edge_view_t edge;
        double chi2;
        pgem_edge_at(graph, k, &edge);
        pgem_edge_chi2(graph, k, &chi2);
        cost += edge.kind == PGEM_EDGE_LOOP ? scale * scale * log(1.0 + chi2 / (scale * scale)) : chi2;
    }
    return cost;
}

static void test_em_weights_are_cauchy_weights(void **state)
{
    (void)state;
    double truth[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    pgem_t *graph = corrupted_ring(44, 55, truth, false_loops);
    pgem_robust_options_t options = em_options();
    options.scale = 2.0;
    options.literal = 1;
    options.prune_threshold = 1e-300; /* no pruning: pure EM */
    options.weight_tolerance = 1e-10;
    options.m_step_iterations = 3;
    pgem_robust_summary_t summary;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.pruned, 0);
    for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
        pgem_edge_view_t edge;
        double chi2;
        pgem_edge_at(graph, k, &edge);
        pgem_edge_chi2(graph, k, &chi2);
        double expected = edge.kind == PGEM_EDGE_LOOP ? 1.0 / (1.0 + chi2 / 4.0) : 1.0;
        assert_near(edge.weight, expected, 1e-8);
    }
    /* a stationary point of the Cauchy cost: any small move of any pose raises it */
    double best = cauchy_cost(graph, 2.0);
    for (pgem_id_t id = 1; id < RING; id += 17) {
        for (int d = 0; d < 3; d++) {
            double pose[3], moved[3];
            pgem_pose(graph, id, pose);
            for (int sign = -1; sign <= 1; sign += 2) {
                memcpy(moved, pose, sizeof pose);
                moved[d] += sign * 1e-4;
                pgem_set_pose(graph, id, moved);
                assert_true(cauchy_cost(graph, 2.0) > best);
            }
            pgem_set_pose(graph, id, pose);
        }
    }
    pgem_destroy(graph);
}

static void test_deterministic_and_resettable(void **state)
{
    (void)state;
    double truth[3 * RING], first[3 * RING], second[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    double weights[2][3 * RING + FALSE_LOOPS];
    memset(weights, 0, sizeof weights);
    for (int run = 0; run < 2; run++) {
        pgem_t *graph = corrupted_ring(66, 88, truth, false_loops);
        pgem_robust_options_t options = em_options();
        assert_int_equal(pgem_robust_optimize(graph, &options, NULL, NULL), PGEM_OK);
        test_snapshot(graph, run == 0 ? first : second);
        for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
            pgem_edge_view_t edge;
            pgem_edge_at(graph, k, &edge);
            weights[run][k] = edge.weight;
        }
        pgem_robust_reset(graph);
        for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
            pgem_edge_view_t edge;
            pgem_edge_at(graph, k, &edge);
            assert_true(edge.active && edge.weight == 1.0);
        }
        pgem_destroy(graph);
    }
    assert_memory_equal(first, second, sizeof first);
    assert_memory_equal(weights[0], weights[1], sizeof weights[0]);
}

/* Pruned loops leave H's structure (a re-analysis without them), so long-range false loops
 * stop costing fill once pruned; a reset brings them back. */
static void test_pruned_loops_leave_the_structure(void **state)
{
    (void)state;
    double truth[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    pgem_t *graph = ring(33, truth);
    pgem_memory_stats_t clean, corrupted, after, reset;
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    pgem_memory_use(graph, &clean);
    add_false_loops(graph, FALSE_LOOPS, 77, false_loops);
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    pgem_memory_use(graph, &corrupted);
    assert_true(corrupted.factor_nonzeros > clean.factor_nonzeros);
    pgem_robust_options_t options = em_options();
    pgem_robust_summary_t summary;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.pruned, FALSE_LOOPS);
    pgem_memory_use(graph, &after);
    assert_int_equal(after.factor_nonzeros, clean.factor_nonzeros);
    pgem_robust_reset(graph);
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    pgem_memory_use(graph, &reset);
    assert_int_equal(reset.factor_nonzeros, corrupted.factor_nonzeros);
    pgem_destroy(graph);
}

/* ring() and its false loops in an instance whose fill budget is fill_budget. */
static pgem_t *corrupted_ring_budget(uint32_t fill_budget, double *truth, uint32_t *false_loops)
{
    pgem_config_t config = {2, RING, 3 * RING, fill_budget, 0, 0};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    test_ring_2d(graph, RING, 6, SIGMA, HEADING_SIGMA, 33, truth);
    add_false_loops(graph, FALSE_LOOPS, 77, false_loops);
    return graph;
}

/* Dormant loops (weight below the dormant threshold) get no place in H's structure, so EM
 * solves a corrupted graph inside a fill budget that only the clean structure fits; with the
 * exact Newton matrix (dormant_threshold < 0) the same solve needs the corrupted fill and fails
 * cleanly in that budget. Both reach the same answer when the budget allows. */
static void test_dormant_loops_keep_the_factor_sparse(void **state)
{
    (void)state;
    double truth[3 * RING], dormant[3 * RING], exact[3 * RING], before[3 * RING], after[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    pgem_memory_stats_t clean, corrupted;
    pgem_t *probe = ring(33, truth);
    assert_int_equal(pgem_analyze(probe), PGEM_OK);
    pgem_memory_use(probe, &clean);
    add_false_loops(probe, FALSE_LOOPS, 77, false_loops);
    assert_int_equal(pgem_analyze(probe), PGEM_OK);
    pgem_memory_use(probe, &corrupted);
    pgem_destroy(probe);
    assert_true(corrupted.factor_nonzeros > clean.factor_nonzeros + clean.factor_nonzeros / 5);
    const uint32_t tight_budget = clean.factor_nonzeros + (corrupted.factor_nonzeros - clean.factor_nonzeros) / 4;

    pgem_robust_options_t options = em_options();
    pgem_robust_summary_t summary;
    pgem_t *graph = corrupted_ring_budget(tight_budget, truth, false_loops);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.pruned, FALSE_LOOPS);
    for (int m = 0; m < FALSE_LOOPS; m++) {
        pgem_edge_view_t edge;
        assert_int_equal(pgem_edge_at(graph, false_loops[m], &edge), PGEM_OK);
        assert_int_equal(edge.active, 0);
    }
    test_snapshot(graph, dormant);
    pgem_destroy(graph);

    options.dormant_threshold = -1.0; /* exact Newton matrix: needs the corrupted fill */
    graph = corrupted_ring_budget(tight_budget, truth, false_loops);
    test_snapshot(graph, before);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_ERR_FILL_BUDGET);
    assert_false(summary.usable);
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    pgem_destroy(graph);

    graph = corrupted_ring_budget(corrupted.factor_nonzeros, truth, false_loops);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.pruned, FALSE_LOOPS);
    test_snapshot(graph, exact);
    pgem_destroy(graph);
    /* the dormant loops' couplings come back through conjugate gradients: the same answer */
    for (int k = 0; k < 3 * RING; k++) {
        assert_near(dormant[k], exact[k], 1e-9);
    }
}

/* The final consistency test prunes a false loop EM alone keeps. The loop claims a loose
 * 0.2 m (so the chain, surer than that, barely bends to it) and is 1.5 m off: chi2 ~ 56 at the
 * truth, weight ~ 0.018 > tau, so it survives the rounds, but it still fails the 99.9%
 * chi-square gate under the polished estimate. The literal method keeps it. */
static void test_consistency_gate_prunes_what_em_keeps(void **state)
{
    (void)state;
    for (int literal = 0; literal <= 1; literal++) {
        double truth[3 * RING];
        pgem_t *graph = ring(12, truth);
        double z[3], information[9];
        pgem_se2_between(truth + 3 * 30, truth + 3 * 60, z);
        z[0] += 1.5;
        test_diagonal_information(3, 1.0 / (0.2 * 0.2), information);
        uint32_t bad;
        assert_int_equal(pgem_add_edge(graph, 30, 60, z, information, PGEM_EDGE_LOOP, &bad), PGEM_OK);
        pgem_robust_options_t options = em_options();
        options.literal = literal;
        pgem_robust_summary_t summary;
        assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
        pgem_edge_view_t edge;
        assert_int_equal(pgem_edge_at(graph, bad, &edge), PGEM_OK);
        assert_int_equal(edge.active, literal);
        assert_int_equal(summary.pruned, literal ? 0 : 1);
        assert_int_equal(summary.gated, literal ? 0 : 1);
        pgem_destroy(graph);
    }
}

/* A straight chain of 40 poses (1 m steps, 5 cm and 10 mrad per step) and two loop
 * closures from its first pose to its last that disagree by 1.2 m (10 cm each): the chain
 * alone predicts either (the test re-admits both), and each contradicts the other (the test
 * then prunes both), so the passes cycle. The run ends at the cycle, says so, and leaves
 * both loops in the same state; one loop alone settles, accepted. */
static pgem_t *conflicting_chain(int loops, uint32_t *first_loop)
{
    pgem_t *graph = test_create(2, 40, 41);
    double odometry_information[9], loop_information[9];
    test_diagonal_information(3, 400.0, odometry_information);
    odometry_information[8] = 10000.0;
    test_diagonal_information(3, 100.0, loop_information);
    loop_information[8] = 1000.0;
    for (int i = 0; i < 40; i++) {
        const double pose[3] = {(double)i, 0.0, 0.0};
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)i, pose), PGEM_OK);
    }
    for (int i = 0; i + 1 < 40; i++) {
        const double z[3] = {1.0, 0.0, 0.0};
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)i, (pgem_id_t)(i + 1), z, odometry_information,
                                       PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    }
    for (int k = 0; k < loops; k++) {
        const double z[3] = {39.0 + (k == 0 ? 0.6 : -0.6), 0.0, 0.0};
        uint32_t index = 0;
        assert_int_equal(pgem_add_edge(graph, 0, 39, z, loop_information, PGEM_EDGE_LOOP, &index), PGEM_OK);
        if (k == 0) {
            *first_loop = index;
        }
    }
    return graph;
}

static void test_oscillating_passes_end_in_the_cycle(void **state)
{
    (void)state;
    for (int loops = 2; loops >= 1; loops--) {
        uint32_t first = 0;
        pgem_t *graph = conflicting_chain(loops, &first);
        pgem_robust_options_t options = em_options();
        pgem_robust_summary_t summary;
        assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
        assert_int_equal(summary.usable, 1);
        assert_true(summary.rounds <= 4u);
        pgem_edge_view_t a, b;
        assert_int_equal(pgem_edge_at(graph, first, &a), PGEM_OK);
        if (loops == 2) {
            assert_int_equal(summary.termination, PGEM_ROBUST_OSCILLATED);
            assert_string_equal(pgem_robust_termination_name(summary.termination), "oscillated");
            assert_int_equal(summary.readmitted, 2);
            assert_int_equal(summary.gated, 2);
            assert_int_equal(pgem_edge_at(graph, first + 1u, &b), PGEM_OK);
            assert_int_equal(a.active, b.active);
        } else {
            assert_int_equal(summary.termination, PGEM_ROBUST_CONVERGED);
            assert_string_equal(pgem_robust_termination_name(summary.termination), "converged");
            assert_int_equal(a.active, 1);
            assert_int_equal(summary.pruned, 0);
        }
        pgem_destroy(graph);
    }
}

/* The rule that ends a cycle, on the passes' marks: a pass that comes back to an earlier set
 * ends the passes if that set is the cheapest of the cycle (ties too); else the passes go
 * around to the cheapest and end there, or, if they stray from the cycle, after as many passes
 * as it had. */
static void test_cycle_ends_at_its_cheapest_set(void **state)
{
    (void)state;
    const pgem_pass_mark_t a = {0xa, 10, 5.0}, b = {0xb, 9, 3.0}, c = {0xc, 8, 4.0}, d = {0xd, 7, 1.0};
    pgem_settle_t settle;
    memset(&settle, 0, sizeof settle);
    assert_int_equal(pgem_settle_pass(&settle, &a), 0);
    assert_int_equal(pgem_settle_pass(&settle, &b), 0);
    assert_int_equal(pgem_settle_pass(&settle, &a), 0); /* A, B, A: B is cheaper */
    assert_int_equal(settle.cycling, 1);
    assert_int_equal(pgem_settle_pass(&settle, &b), 1);
    memset(&settle, 0, sizeof settle);
    assert_int_equal(pgem_settle_pass(&settle, &b), 0);
    assert_int_equal(pgem_settle_pass(&settle, &a), 0);
    assert_int_equal(pgem_settle_pass(&settle, &b), 1); /* B, A, B: B is the cheapest */
    memset(&settle, 0, sizeof settle);
    assert_int_equal(pgem_settle_pass(&settle, &a), 0);
    assert_int_equal(pgem_settle_pass(&settle, &c), 0);
    assert_int_equal(pgem_settle_pass(&settle, &b), 0);
    assert_int_equal(pgem_settle_pass(&settle, &a), 0); /* A, C, B, A: to B, two passes on */
    assert_int_equal(pgem_settle_pass(&settle, &c), 0);
    assert_int_equal(pgem_settle_pass(&settle, &b), 1);
    memset(&settle, 0, sizeof settle);
    assert_int_equal(pgem_settle_pass(&settle, &a), 0);
    assert_int_equal(pgem_settle_pass(&settle, &b), 0);
    assert_int_equal(pgem_settle_pass(&settle, &a), 0);
    assert_int_equal(pgem_settle_pass(&settle, &d), 0); /* strays: ends a cycle's length on */
    assert_int_equal(pgem_settle_pass(&settle, &c), 1);
    pgem_pass_mark_t same = a;
    same.accepted = 11; /* the same fingerprint with another count is another set */
    memset(&settle, 0, sizeof settle);
    assert_int_equal(pgem_settle_pass(&settle, &a), 0);
    assert_int_equal(pgem_settle_pass(&settle, &same), 0);
    assert_int_equal(settle.cycling, 0);
}

/* Two chains joined only by two loop closures that contradict each other, the second chain's
 * guess halfway between them: EM prunes both, which leaves the second chain with no held pose.
 * Under Gauss-Newton and under Levenberg-Marquardt (whose damping would hide a singular
 * matrix) the solve goes on with that chain held at its own gauge (pose 100, its smallest id)
 * and reports it; the first chain ends where its odometry puts it, as before the solve, and
 * the second keeps its odometry's shape wherever EM left it. A graph whose part no edge joins
 * to a held pose, pruned or not, still fails, naming a pose of it, and changes nothing. */
static pgem_t *split_chains(int joined)
{
    pgem_t *graph = test_create(2, 20, 20);
    double information[9];
    test_diagonal_information(3, 100.0, information);
    for (int part = 0; part < 2; part++) {
        for (int k = 0; k < 10; k++) {
            const double pose[3] = {k, part * 32.5, 0.0};
            assert_int_equal(pgem_add_pose(graph, (pgem_id_t)(part * 100 + k), pose), PGEM_OK);
        }
        for (int k = 0; k < 9; k++) {
            const double step[3] = {1.0, 0.0, 0.0};
            const pgem_id_t from = (pgem_id_t)(part * 100 + k);
            assert_int_equal(pgem_add_edge(graph, from, from + 1u, step, information,
                                           PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
        }
    }
    const double near[3] = {0.0, 5.0, 0.0}, far[3] = {0.0, 60.0, 0.0};
    if (joined) {
        assert_int_equal(pgem_add_edge(graph, 5, 105, near, information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
        assert_int_equal(pgem_add_edge(graph, 6, 106, far, information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
    }
    return graph;
}

static void test_pruning_that_splits_the_graph_holds_the_part(void **state)
{
    (void)state;
    for (int method = 0; method < 2; method++) {
        pgem_t *graph = split_chains(1);
        double before[3 * 20], after[3 * 20];
        test_snapshot(graph, before);
        pgem_robust_options_t options = em_options();
        pgem_solve_options_t solve = {0};
        solve.method = method == 0 ? PGEM_GAUSS_NEWTON : PGEM_LEVENBERG_MARQUARDT;
        pgem_robust_summary_t summary;
        assert_int_equal(pgem_robust_optimize(graph, &options, &solve, &summary), PGEM_OK);
        assert_int_equal(summary.usable, 1);
        assert_int_equal(summary.pruned, 2);
        assert_int_equal(summary.outcome, PGEM_ROBUST_ALL_REJECTED);
        assert_int_equal(summary.termination, PGEM_ROBUST_CONVERGED);
        assert_int_equal(summary.parts_held, 1);
        pgem_id_t held[2] = {0, 0};
        assert_int_equal(pgem_robust_held_parts(graph, held, 2), 1);
        assert_int_equal(held[0], 100);
        assert_int_equal(pgem_robust_held_parts(graph, NULL, 0), 1);
        test_snapshot(graph, after);
        for (int k = 0; k < 10; k++) {
            for (int c = 0; c < 3; c++) {
                assert_near(after[3 * k + c], before[3 * k + c], 1e-9);
            }
            if (k > 0) { /* the second chain: its odometry's shape where it stands */
                const double *a = after + 3 * (10 + k - 1), *b = after + 3 * (10 + k);
                assert_near(b[0] - a[0], cos(a[2]), 1e-9);
                assert_near(b[1] - a[1], sin(a[2]), 1e-9);
                assert_near(b[2], a[2], 1e-9);
            }
        }
        /* a loop at weight 0 (a run the leave-run-out test leaves out for one factorisation)
         * joins nothing either: with the loops back and one at weight 0, the chain is loose */
        pgem_t *probe = split_chains(1);
        probe->store.edge_weight[18] = 0.0;
        assert_int_equal(pgem_linear_unheld_parts(probe->linear, &probe->store, 0, 0u), 0); /* the other loop joins */
        probe->store.edge_weight[19] = 0.0;
        assert_int_equal(pgem_linear_unheld_parts(probe->linear, &probe->store, 0, 0u), 1);
        assert_int_equal(pgem_linear_unheld_parts(probe->linear, &probe->store, 1, 0u), 0); /* every edge: joined */
        pgem_destroy(probe);
        /* the holds hold for a plain solve of the result; a reset releases them with the loops */
        assert_int_equal(pgem_optimize(graph, &solve, NULL), PGEM_OK);
        pgem_robust_reset(graph);
        assert_int_equal(pgem_robust_held_parts(graph, held, 2), 0);
        pgem_destroy(graph);
    }
    pgem_t *graph = split_chains(0);
    double before[3 * 20], after[3 * 20];
    test_snapshot(graph, before);
    pgem_robust_summary_t summary;
    assert_int_equal(pgem_robust_optimize(graph, NULL, NULL, &summary), PGEM_ERR_NOT_POSITIVE_DEFINITE);
    assert_int_equal(summary.usable, 0);
    assert_int_equal(summary.parts_held, 0);
    assert_contains(pgem_last_error(graph), "pose 100 is in a part of the graph with no held pose");
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    assert_int_equal(pgem_robust_held_parts(graph, NULL, 0), 0);
    pgem_destroy(graph);
}

/* Two robots, each from its own origin (issue 36, item 2): robot A (ids 0..19) holds the
 * gauge; robot B (ids 1000..1019) starts at the identity while its true frame is
 * (40, -25, 2.5) in A's. Odometry and true loops are exact; the false inter-robot loops are
 * far from any frame the true ones agree on. */
#define TEAM_POSES 20
static const int team_true[4][2] = {{3, 4}, {8, 10}, {12, 6}, {17, 15}};
static const int team_false[3][2] = {{5, 2}, {10, 18}, {15, 12}};
static const double team_false_z[3][3] = {{3.0, 7.0, 2.0}, {-6.0, 1.0, -1.2}, {2.0, -9.0, 0.4}};

static pgem_t *two_robots(int true_loops, int false_loops, double *truth)
{
    pgem_t *graph = test_create(2, 2 * TEAM_POSES, 2 * TEAM_POSES + 8);
    double information[9]; /* 0.05 m and 0.01 rad, as pgem simulate's */
    test_diagonal_information(3, 400.0, information);
    information[8] = 1e4;
    const double frame[3] = {40.0, -25.0, 2.5}, steps[2][3] = {{1.0, 0.0, 0.1}, {1.0, 0.0, -0.08}};
    for (int robot = 0; robot < 2; robot++) {
        double local[3] = {0.0, 0.0, 0.0};
        for (int k = 0; k < TEAM_POSES; k++) {
            double *world = truth + 3 * (robot * TEAM_POSES + k);
            if (robot == 0) {
                memcpy(world, local, sizeof local);
            } else {
                pgem_se2_compose(frame, local, world);
            }
            const pgem_id_t id = (pgem_id_t)(robot * 1000 + k);
            assert_int_equal(pgem_add_pose(graph, id, local), PGEM_OK);
            if (k > 0) {
                assert_int_equal(pgem_add_edge(graph, id - 1u, id, steps[robot], information,
                                               PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
            }
            pgem_se2_compose(local, steps[robot], local);
        }
    }
    for (int k = 0; k < true_loops; k++) {
        double z[3];
        pgem_se2_between(truth + 3 * team_true[k][0], truth + 3 * (TEAM_POSES + team_true[k][1]), z);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)team_true[k][0], (pgem_id_t)(1000 + team_true[k][1]),
                                       z, information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
    }
    for (int k = 0; k < false_loops; k++) {
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(1000 + team_false[k][1]), (pgem_id_t)team_false[k][0],
                                       team_false_z[k], information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
    }
    return graph;
}

static void test_robot_frame_from_agreeing_loops(void **state)
{
    (void)state;
    double truth[3 * 2 * TEAM_POSES], after[3 * 2 * TEAM_POSES];
    pgem_t *graph = two_robots(4, 3, truth);
    pgem_robust_summary_t summary;
    assert_int_equal(pgem_robust_optimize(graph, NULL, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.frames_placed, 1);
    assert_int_equal(summary.parts_held, 0);
    assert_int_equal(summary.rejected, 3);
    for (uint32_t k = 2 * TEAM_POSES - 2; k < 2 * TEAM_POSES + 5; k++) { /* the true loops */
        pgem_edge_view_t edge;
        assert_int_equal(pgem_edge_at(graph, k, &edge), PGEM_OK);
        assert_int_equal(edge.active, k < 2 * TEAM_POSES + 2);
    }
    test_snapshot(graph, after);
    for (int k = 0; k < 3 * 2 * TEAM_POSES; k++) {
        assert_near(after[k], truth[k], 1e-6);
    }
    pgem_destroy(graph);
    /* without the stage, the same EM judges the loops from B's origin and loses B */
    graph = two_robots(4, 3, truth);
    pgem_robust_options_t options = em_options();
    options.frames = -1;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.frames_placed, 0);
    test_snapshot(graph, after);
    double worst = 0.0;
    for (int k = 3 * TEAM_POSES; k < 3 * 2 * TEAM_POSES; k++) {
        worst = fmax(worst, fabs(after[k] - truth[k]));
    }
    assert_true(worst > 1.0);
    pgem_destroy(graph);
}

/* The frames stage on the instance's parts (robust/frames.c). */
static uint32_t test_frames(pgem_t *graph, const pgem_robust_options_t *options, int with_loops)
{
    const pgem_robust_parts_t parts = pgem_robust_parts(graph);
    return pgem_robust_frames(&parts, options, with_loops);
}

/* Loops that agree on no frame move nothing (the part stays where its odometry put it for
 * EM to judge them), a single loop places its part, a part joined only by pruned loops after
 * a round is placed again by them, and a graph of one part is never touched. */
static void test_robot_frame_needs_agreeing_loops(void **state)
{
    (void)state;
    double truth[3 * 2 * TEAM_POSES], before[3 * 2 * TEAM_POSES], after[3 * 2 * TEAM_POSES];
    pgem_t *graph = two_robots(0, 3, truth);
    const pgem_robust_options_t options = pgem_robust_resolve(NULL);
    test_snapshot(graph, before);
    assert_int_equal(test_frames(graph, &options, 0), 0);
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    pgem_destroy(graph);
    /* one true loop and one false one: they disagree, nothing moves */
    graph = two_robots(1, 1, truth);
    test_snapshot(graph, before);
    assert_int_equal(test_frames(graph, &options, 0), 0);
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    pgem_destroy(graph);
    /* a single loop places its robot where it says */
    graph = two_robots(1, 0, truth);
    assert_int_equal(test_frames(graph, &options, 0), 1);
    test_snapshot(graph, after);
    for (int k = 0; k < 3 * 2 * TEAM_POSES; k++) {
        assert_near(after[k], truth[k], 1e-9);
    }
    pgem_destroy(graph);
    /* after a round: a part joined only by pruned loops is placed again by them; one that
     * accepted loops join, or that already stands where they say, is not moved */
    graph = two_robots(4, 3, truth);
    test_snapshot(graph, before);
    assert_int_equal(test_frames(graph, &options, 1), 0); /* joined by its loops */
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    for (uint32_t k = 2 * TEAM_POSES - 2; k < 2 * TEAM_POSES + 5; k++) {
        graph->store.edge_active[k] = PGEM_EDGE_PRUNED;
    }
    assert_int_equal(test_frames(graph, &options, 1), 1);
    test_snapshot(graph, after);
    for (int k = 0; k < 3 * 2 * TEAM_POSES; k++) {
        assert_near(after[k], truth[k], 1e-9);
    }
    test_snapshot(graph, before);
    assert_int_equal(test_frames(graph, &options, 1), 0); /* already there */
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    pgem_destroy(graph);
    double ring_truth[3 * RING];
    graph = ring(5, ring_truth);
    double ring_before[3 * RING], ring_after[3 * RING];
    test_snapshot(graph, ring_before);
    assert_int_equal(test_frames(graph, &options, 0), 0);
    test_snapshot(graph, ring_after);
    assert_memory_equal(ring_before, ring_after, sizeof ring_before);
    pgem_destroy(graph);
}

/* NaN or Inf in a robust option (or in the solve options it passes on) is refused by name. */
static void test_non_finite_robust_options_refused(void **state)
{
    (void)state;
    double truth[3 * RING];
    pgem_t *graph = ring(5, truth);
    pgem_robust_options_t options = em_options();
    options.scale = (double)NAN;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, NULL), PGEM_ERR_INVALID_ARGUMENT);
    assert_string_equal(pgem_last_error(graph), "option scale is not a finite number");
    options = em_options();
    options.gate = (double)INFINITY;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, NULL), PGEM_ERR_INVALID_ARGUMENT);
    assert_string_equal(pgem_last_error(graph), "option gate is not a finite number");
    options = em_options();
    options.dormant_threshold = -(double)INFINITY;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, NULL), PGEM_ERR_INVALID_ARGUMENT);
    assert_string_equal(pgem_last_error(graph), "option dormant_threshold is not a finite number");
    options = em_options();
    options.prune_threshold = (double)NAN;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, NULL), PGEM_ERR_INVALID_ARGUMENT);
    options.prune_threshold = 0.0;
    options.weight_tolerance = (double)NAN;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, NULL), PGEM_ERR_INVALID_ARGUMENT);
    assert_string_equal(pgem_last_error(graph), "option weight_tolerance is not a finite number");
    pgem_solve_options_t solve = {0};
    solve.step_tolerance = (double)NAN;
    options = em_options();
    assert_int_equal(pgem_robust_optimize(graph, &options, &solve, NULL), PGEM_ERR_INVALID_ARGUMENT);
    assert_string_equal(pgem_last_error(graph), "option step_tolerance is not a finite number");
    pgem_destroy(graph);
}

/* Found by fuzzing (tests/fuzz/fuzz_core_api): a pose at the edge of the double range makes
 * an edge's chi2 NaN (Inf - Inf); the E-step turned it into a NaN loop weight, which the
 * failed solve left on the edge, so every later solve of the graph failed too. A robust solve
 * from an estimate whose chi2 is not finite now fails before any E-step. (The API now refuses
 * such poses, PGEM_TRANSLATION_LIMIT; the estimate is put there behind its back, as a
 * diverged solve could leave it.) */
static void test_non_finite_start_leaves_the_weights(void **state)
{
    (void)state;
    static const double poses[3][3] = {{0.0, 0.0, 0.0}, {DBL_MAX, 0.0, 0.5}, {-DBL_MAX, 0.0, 0.0}};
    pgem_t *graph = test_create(2, 3, 3);
    double information[9], z[3] = {1.0, 0.0, 0.0}, before[9], after[9];
    test_diagonal_information(3, 1.0, information);
    for (int i = 0; i < 3; i++) {
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)i, poses[i]),
                         i == 0 ? PGEM_OK : PGEM_ERR_OUT_OF_RANGE);
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)i, poses[0]), i == 0 ? PGEM_ERR_DUPLICATE_ID : PGEM_OK);
        memcpy(graph->store.pose + 3 * i, poses[i], sizeof poses[i]);
    }
    assert_int_equal(pgem_add_edge(graph, 0, 1, z, information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 1, 2, z, information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 0, 2, z, information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
    assert_false(isfinite(pgem_total_chi2(graph)));
    test_snapshot(graph, before);
    for (int kernel = PGEM_KERNEL_EM; kernel <= PGEM_KERNEL_DCS; kernel++) {
        pgem_robust_options_t options = {0};
        options.kernel = (pgem_kernel_t)kernel;
        pgem_robust_summary_t summary;
        assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_ERR_NUMERIC);
        assert_false(summary.usable);
        /* plain least squares refuses the start; a robust kernel names the odometry edge that
         * cannot be an outlier */
        assert_contains(pgem_last_error(graph), kernel == PGEM_KERNEL_NONE
                                                    ? "initial chi2 is not finite"
                                                    : "the chi2 of odometry edge 0-1 is not finite");
        pgem_edge_view_t loop;
        assert_int_equal(pgem_edge_at(graph, 2, &loop), PGEM_OK);
        assert_true(loop.weight == 1.0 && loop.active);
        test_snapshot(graph, after);
        assert_memory_equal(before, after, sizeof before);
    }
    /* with the pose back in range the graph solves: nothing was left behind */
    const double moved[3] = {2.0, 0.0, 0.0};
    assert_int_equal(pgem_set_pose(graph, 2, moved), PGEM_OK);
    const double near[3] = {1.0, 0.0, 0.0};
    assert_int_equal(pgem_set_pose(graph, 1, near), PGEM_OK);
    pgem_robust_options_t options = em_options();
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, NULL), PGEM_OK);
    pgem_destroy(graph);
}

/* Found by fuzzing: with a scale so small that c^2 underflows to 0, the Cauchy weight of an
 * exact fit (chi2 = 0) was 1 / (1 + 0 / 0) = NaN. */
static void test_cauchy_weight_of_an_exact_fit(void **state)
{
    (void)state;
    assert_near(pgem_kernel_weight(PGEM_KERNEL_CAUCHY, 0.0, 1e-200), 1.0, 0.0);
    assert_near(pgem_kernel_weight(PGEM_KERNEL_EM, 0.0, 4.9406564584124654e-324), 1.0, 0.0);
    assert_near(pgem_kernel_weight(PGEM_KERNEL_EM, 1e-300, 1e-200), 0.0, 0.0);
}

/* A chain of odometry through the poses of truth (3 doubles each): each step measured with
 * N(0, sigma^2) noise on x and y and N(0, heading_sigma^2) on the heading, the poses added at
 * the odometry-composed estimate (into estimate), pose 0 at the origin; rng goes on from there. */
static void add_noisy_odometry(pgem_t *graph, const double *truth, int poses, const double *information,
                               double sigma, double heading_sigma, test_rng_t *rng, double *estimate)
{
    memset(estimate, 0, 3 * sizeof(double));
    assert_int_equal(pgem_add_pose(graph, 0, estimate), PGEM_OK);
    for (int i = 1; i < poses; i++) {
        double z[3];
        pgem_se2_between(truth + 3 * (i - 1), truth + 3 * i, z);
        z[0] += sigma * test_gaussian(rng);
        z[1] += sigma * test_gaussian(rng);
        z[2] += heading_sigma * test_gaussian(rng);
        pgem_se2_compose(estimate + 3 * (i - 1), z, estimate + 3 * i);
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)i, estimate + 3 * i), PGEM_OK);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(i - 1), (pgem_id_t)i, z, information,
                                       PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    }
}

/* A corridor walked out and back (N poses each way, 1 m apart, the way back 2 m to the side),
 * odometry whose stated information is four times too confident (standard deviations half
 * the real ones, as real front-ends report them), and two true loop closures at the end of
 * the walk back, with the same information, onto its start. The drift makes the loops' chi2
 * far beyond their own information under the odometry guess. */
#define CORRIDOR 100
static pgem_t *corridor(uint64_t seed, double *truth, uint32_t *loops)
{
    const int poses = 2 * CORRIDOR;
    pgem_t *graph = test_create(2, (uint32_t)poses, (uint32_t)poses + 8u);
    const double sigma = 0.01, heading_sigma = 0.005, stated = 0.5;
    double information[9], estimate[3 * 2 * CORRIDOR];
    test_diagonal_information(3, 1.0 / (sigma * sigma * stated * stated), information);
    information[8] = 1.0 / (heading_sigma * heading_sigma * stated * stated);
    for (int i = 0; i < CORRIDOR; i++) {
        truth[3 * i] = i, truth[3 * i + 1] = 0.0, truth[3 * i + 2] = 0.0;
        const int back = CORRIDOR + i;
        truth[3 * back] = CORRIDOR - 1 - i, truth[3 * back + 1] = 2.0;
        truth[3 * back + 2] = 3.141592653589793;
    }
    test_rng_t rng = {seed};
    add_noisy_odometry(graph, truth, poses, information, sigma, heading_sigma, &rng, estimate);
    for (int m = 0; m < 2; m++) {
        const int from = poses - 1 - m, to = m;
        double z[3];
        pgem_se2_between(truth + 3 * from, truth + 3 * to, z);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)from, (pgem_id_t)to, z, information,
                                       PGEM_EDGE_LOOP, &loops[m]), PGEM_OK);
    }
    return graph;
}

static int loops_kept(const pgem_t *graph, const uint32_t *loops, int count)
{
    int kept = 0;
    for (int m = 0; m < count; m++) {
        pgem_edge_view_t edge;
        assert_int_equal(pgem_edge_at(graph, loops[m], &edge), PGEM_OK);
        kept += edge.active;
    }
    return kept;
}

/* Issue 16: under the odometry guess the true loops' chi2 is far beyond their information
 * (10^4 and more), so the paper's point distance prunes them in some seeds and the map stays
 * at the odometry; measured against what the map predicts for them (the innovation, with the
 * allowance for optimistic odometry), they are kept in every seed. */
static void test_drifted_true_loops_are_kept(void **state)
{
    (void)state;
    int point_failures = 0;
    for (uint64_t seed = 1; seed <= 8; seed++) {
        for (int distance = 0; distance <= 1; distance++) {
            double truth[3 * 2 * CORRIDOR];
            uint32_t loops[2];
            pgem_t *graph = corridor(seed, truth, loops);
            double chi2;
            assert_int_equal(pgem_edge_chi2(graph, loops[0], &chi2), PGEM_OK);
            assert_true(chi2 > 100.0);
            pgem_robust_options_t options = em_options();
            options.distance = (pgem_loop_distance_t)distance;
            pgem_robust_summary_t summary;
            assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
            const int kept = loops_kept(graph, loops, 2);
            if (distance == PGEM_DISTANCE_INNOVATION) {
                assert_int_equal(kept, 2);
                assert_int_equal(summary.outcome, PGEM_ROBUST_LOOPS_ACCEPTED);
            } else {
                point_failures += kept < 2;
            }
            pgem_destroy(graph);
        }
    }
    assert_true(point_failures > 0); /* the case the innovation distance fixes */
}

/* Issue 16: the summary says when every loop (or nearly every one) was rejected, and gives the
 * chi2 with the rejected loops beside the one without them. */
static void test_degenerate_outcomes_are_reported(void **state)
{
    (void)state;
    double truth[3 * RING];
    uint32_t false_loops[FALSE_LOOPS];
    /* a chain with only false loop closures */
    pgem_t *graph = test_create(2, RING, 2 * RING);
    double information[9];
    test_diagonal_information(3, 1.0 / (SIGMA * SIGMA), information);
    double pose[3] = {0.0, 0.0, 0.0};
    assert_int_equal(pgem_add_pose(graph, 0, pose), PGEM_OK);
    for (int k = 1; k < RING; k++) {
        const double z[3] = {1.0, 0.0, 0.0};
        pose[0] = k;
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)k, pose), PGEM_OK);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 1), (pgem_id_t)k, z, information,
                                       PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    }
    pgem_robust_options_t options = em_options();
    pgem_robust_summary_t summary;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.outcome, PGEM_ROBUST_NO_LOOPS);
    add_false_loops(graph, FALSE_LOOPS, 5, false_loops);
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.outcome, PGEM_ROBUST_ALL_REJECTED);
    assert_int_equal(summary.rejected, FALSE_LOOPS);
    assert_int_equal(summary.loops, FALSE_LOOPS);
    assert_true(summary.usable);
    assert_true(summary.final_chi2 < 1e-6);
    assert_true(summary.final_chi2_all > 1e3 * (summary.final_chi2 + 1.0));
    assert_near(summary.final_chi2_all, pgem_total_chi2(graph), 1e-9 * summary.final_chi2_all);
    assert_string_equal(pgem_robust_outcome_name(summary.outcome), "all_rejected");
    pgem_destroy(graph);
    /* a ring with its true loops, then many more false ones: most rejected */
    graph = test_create(2, RING, 6 * RING);
    test_ring_2d(graph, RING, 6, SIGMA, HEADING_SIGMA, 3, truth);
    for (int batch = 0; batch < 16; batch++) {
        add_false_loops(graph, FALSE_LOOPS, 100u + (uint64_t)batch, false_loops);
    }
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_true(summary.rejected > (uint32_t)(0.9 * summary.loops));
    assert_int_equal(summary.outcome, PGEM_ROBUST_MOST_REJECTED);
    assert_string_equal(pgem_robust_outcome_name(summary.outcome), "most_rejected");
    pgem_destroy(graph);
}

#define REVISIT_LAP 160   /* poses in one lap of the revisit ring */
#define REVISIT_RUN 16    /* true loops: the second lap's first poses matched to the first's */
#define REVISIT_GROUPS 12 /* groups of false loops, each a run with one wrong transform */
#define REVISIT_GROUP 8   /* loops per false group */

/* A lap of a circle with heading noise so large that the odometry predicts nothing across it
 * (like Vertigo's ring), then REVISIT_RUN poses of a second lap, each matched by a true loop
 * to the first lap's pose; then REVISIT_GROUPS runs of false loops, each run's measurements
 * one random transform (a place recogniser fooled along a stretch). Their indices into
 * true_loops (without with_true, no true loop) and false_loops. */
static pgem_t *revisit_ring(uint64_t seed, int with_true, double *truth, uint32_t *true_loops,
                            uint32_t *false_loops)
{
    const int poses = REVISIT_LAP + REVISIT_RUN;
    const double sigma = 0.05, heading_sigma = 0.08, turn = 2.0 * 3.141592653589793 / REVISIT_LAP;
    pgem_t *graph = test_create(2, (uint32_t)poses, (uint32_t)(4 * poses + REVISIT_GROUPS * REVISIT_GROUP));
    double information[9], estimate[3 * (REVISIT_LAP + REVISIT_RUN)];
    test_diagonal_information(3, 1.0 / (sigma * sigma), information);
    information[8] = 1.0 / (heading_sigma * heading_sigma);
    test_rng_t rng = {seed};
    memset(truth, 0, 3 * sizeof(double));
    memset(estimate, 0, 3 * sizeof(double));
    assert_int_equal(pgem_add_pose(graph, 0, estimate), PGEM_OK);
    for (int i = 1; i < poses; i++) {
        const double step[3] = {1.0, 0.0, turn};
        double z[3];
        pgem_se2_compose(truth + 3 * (i - 1), step, truth + 3 * i);
        z[0] = 1.0 + sigma * test_gaussian(&rng);
        z[1] = sigma * test_gaussian(&rng);
        z[2] = turn + heading_sigma * test_gaussian(&rng);
        pgem_se2_compose(estimate + 3 * (i - 1), z, estimate + 3 * i);
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)i, estimate + 3 * i), PGEM_OK);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(i - 1), (pgem_id_t)i, z, information,
                                       PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    }
    for (int m = 0; with_true && m < REVISIT_RUN; m++) {
        double z[3];
        pgem_se2_between(truth + 3 * (REVISIT_LAP + m), truth + 3 * m, z);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(REVISIT_LAP + m), (pgem_id_t)m, z,
                                       information, PGEM_EDGE_LOOP, &true_loops[m]), PGEM_OK);
    }
    for (int g = 0; g < REVISIT_GROUPS; g++) {
        const int from = (int)(test_uniform(&rng) * (REVISIT_LAP - REVISIT_GROUP));
        const int to = (from + 40 + (int)(test_uniform(&rng) * (REVISIT_LAP - 80))) % (REVISIT_LAP - REVISIT_GROUP);
        const double z[3] = {10.0 * test_uniform(&rng) - 5.0, 10.0 * test_uniform(&rng) - 5.0,
                             3.0 * test_uniform(&rng) - 1.5};
        for (int m = 0; m < REVISIT_GROUP; m++) {
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(from + m), (pgem_id_t)(to + m), z,
                                           information, PGEM_EDGE_LOOP,
                                           &false_loops[g * REVISIT_GROUP + m]), PGEM_OK);
        }
    }
    return graph;
}

/* Issue 16: with runs of grouped false loops and an odometry that predicts nothing across the
 * ring, EM pruned every loop in seeds 2, 3, 5 and 6 and the map stayed at the odometry. The
 * true run, tried alone, passes the global test, and then every true loop is kept and every
 * false one rejected; without the true run, no false group passes it. */
static void test_true_run_rescued_when_every_loop_is_rejected(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 6; seed++) {
        for (int with_true = 1; with_true >= 0; with_true--) {
            double truth[3 * (REVISIT_LAP + REVISIT_RUN)];
            uint32_t true_loops[REVISIT_RUN], false_loops[REVISIT_GROUPS * REVISIT_GROUP];
            pgem_t *graph = revisit_ring(seed, with_true, truth, true_loops, false_loops);
            pgem_robust_options_t options = em_options();
            pgem_robust_summary_t summary;
            assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
            const int false_kept = loops_kept(graph, false_loops, REVISIT_GROUPS * REVISIT_GROUP);
            if (with_true) {
                assert_int_equal(false_kept, 0);
                assert_int_equal(loops_kept(graph, true_loops, REVISIT_RUN), REVISIT_RUN);
                assert_int_equal(summary.outcome, PGEM_ROBUST_LOOPS_ACCEPTED);
            } else { /* EM alone keeps one false loop in seeds 1 and 6; no group comes back */
                assert_true(false_kept <= 1);
                assert_int_not_equal(summary.outcome, PGEM_ROBUST_LOOPS_ACCEPTED);
            }
            pgem_destroy(graph);
        }
    }
}

#define REVISIT_SINGLES 300
/* REVISIT_SINGLES false loops with random measurements between far-apart poses of the first
 * lap of the revisit ring, each on its own. */
static void add_single_false_loops(pgem_t *graph, uint64_t seed)
{
    test_rng_t rng = {seed};
    double information[9];
    test_diagonal_information(3, 1.0 / (0.05 * 0.05), information);
    information[8] = 1.0 / (0.08 * 0.08);
    for (int m = 0; m < REVISIT_SINGLES; m++) {
        const int from = (int)(test_uniform(&rng) * REVISIT_LAP);
        const int to = (from + 30 + (int)(test_uniform(&rng) * (REVISIT_LAP - 60))) % REVISIT_LAP;
        const double z[3] = {10.0 * test_uniform(&rng) - 5.0, 10.0 * test_uniform(&rng) - 5.0,
                             3.0 * test_uniform(&rng) - 1.5};
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)from, (pgem_id_t)to, z, information,
                                       PGEM_EDGE_LOOP, NULL), PGEM_OK);
    }
}

/* Issue 16: the revisit ring's true run among single false loops with random measurements
 * (REVISIT_SINGLES of them, besides the false groups): EM kept one false loop and pruned every
 * true one in seeds 1, 2, 3 and 5; the true run, tried alone, is a larger consistent set than
 * EM's, and now every true loop is kept and every false one rejected in all six seeds. */
static void test_true_run_rescued_when_em_keeps_one_false_loop(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 6; seed++) {
        double truth[3 * (REVISIT_LAP + REVISIT_RUN)];
        uint32_t true_loops[REVISIT_RUN], false_loops[REVISIT_GROUPS * REVISIT_GROUP];
        pgem_t *graph = revisit_ring(seed, 1, truth, true_loops, false_loops);
        add_single_false_loops(graph, seed + 100u);
        pgem_robust_options_t options = em_options();
        pgem_robust_summary_t summary;
        assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
        assert_int_equal(loops_kept(graph, true_loops, REVISIT_RUN), REVISIT_RUN);
        assert_int_equal(summary.loops - summary.rejected, REVISIT_RUN); /* no false one kept */
        pgem_destroy(graph);
    }
}

/* Issue 16: the revisit ring with a run of REVISIT_GROUP false loops between poses 4 apart,
 * each measuring the true motion with one common offset, so that each loop alone is near the
 * odometry's uncertainty and the run's members predict each other, and REVISIT_SINGLES single
 * false loops (most loops false: the outcome is degenerate). Before the leave-run-out test,
 * EM kept 3 loops of the run and lost the true run in 3 of these 9 cases; left out as a whole,
 * the run's chi2 falls by more than the 99.9% quantile for its rows, and it is rejected (one
 * member may come back alone, judged by the per-loop test), the true loops kept. */
static void test_local_false_run_left_out(void **state)
{
    (void)state;
    static const double offsets[][3] = {{-0.45, -0.45, -0.08}, {-0.6, 0.3, 0.06}, {0.5, -0.4, 0.0}};
    for (uint64_t seed = 1; seed <= 3; seed++) {
        for (int o = 0; o < 3; o++) {
            double truth[3 * (REVISIT_LAP + REVISIT_RUN)];
            uint32_t true_loops[REVISIT_RUN], false_loops[REVISIT_GROUPS * REVISIT_GROUP];
            pgem_t *graph = revisit_ring(seed, 1, truth, true_loops, false_loops);
            double information[9];
            test_diagonal_information(3, 1.0 / (0.05 * 0.05), information);
            information[8] = 1.0 / (0.08 * 0.08);
            uint32_t run[REVISIT_GROUP];
            for (int m = 0; m < REVISIT_GROUP; m++) {
                const int from = 60 + m, to = from + 4;
                double z[3];
                pgem_se2_between(truth + 3 * from, truth + 3 * to, z);
                for (int r = 0; r < 3; r++) {
                    z[r] += offsets[o][r];
                }
                assert_int_equal(pgem_add_edge(graph, (pgem_id_t)from, (pgem_id_t)to, z, information,
                                               PGEM_EDGE_LOOP, &run[m]), PGEM_OK);
            }
            add_single_false_loops(graph, seed + 200u); /* most loops false: degenerate */
            pgem_robust_options_t options = em_options();
            pgem_robust_summary_t summary;
            assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
            assert_int_equal(loops_kept(graph, true_loops, REVISIT_RUN), REVISIT_RUN);
            assert_int_equal(loops_kept(graph, false_loops, REVISIT_GROUPS * REVISIT_GROUP), 0);
            assert_true(loops_kept(graph, run, REVISIT_GROUP) <= 1); /* one alone may fit */
            pgem_destroy(graph);
        }
    }
}

#define SQUARE_SIDE 50                  /* poses along a side of the square walk */
#define SQUARE_LAP (4 * SQUARE_SIDE)     /* poses in a lap */
#define SQUARE_POSES (2 * SQUARE_LAP + 1) /* two laps */
#define SQUARE_EVERY 10                  /* a true loop every 10 poses of the second lap */
#define SQUARE_RUN 20                    /* poses of the second lap matched along a stretch */
#define SQUARE_GROUP 20                  /* the attacker's loops */

#define SQUARE_SIGMA 0.02          /* odometry and loop noise per step, m */
#define SQUARE_HEADING_SIGMA 0.01  /* and rad */

/* The square's truth (1 m steps, a quarter turn every SQUARE_SIDE) and its noisy odometry
 * (SQUARE_SIGMA, SQUARE_HEADING_SIGMA) into a new instance, with information `stated` times
 * too loose (written to information, for the loops too); rng goes on for the loops. */
static pgem_t *square_odometry(test_rng_t *rng, double stated, double *information, double *truth)
{
    double estimate[3 * SQUARE_POSES];
    pgem_t *graph = test_create(2, SQUARE_POSES, 2 * SQUARE_POSES);
    test_diagonal_information(3, 1.0 / (SQUARE_SIGMA * SQUARE_SIGMA * stated * stated), information);
    information[8] = 1.0 / (SQUARE_HEADING_SIGMA * SQUARE_HEADING_SIGMA * stated * stated);
    memset(truth, 0, 3 * sizeof(double));
    for (int i = 1; i < SQUARE_POSES; i++) {
        const double step[3] = {1.0, 0.0, i % SQUARE_SIDE == 0 ? 1.5707963267948966 : 0.0};
        pgem_se2_compose(truth + 3 * (i - 1), step, truth + 3 * i);
    }
    add_noisy_odometry(graph, truth, SQUARE_POSES, information, SQUARE_SIGMA, SQUARE_HEADING_SIGMA,
                       rng, estimate);
    return graph;
}

/* A loop measurement's noise, as the odometry's. */
static void square_noise(test_rng_t *rng, double *z)
{
    z[0] += SQUARE_SIGMA * test_gaussian(rng);
    z[1] += SQUARE_SIGMA * test_gaussian(rng);
    z[2] += SQUARE_HEADING_SIGMA * test_gaussian(rng);
}

/* Two laps of a square, 1 m steps, with odometry noise of 2 cm and 10 mrad stated three times
 * too large (as M3500's, whose information is about ten times too loose); a true loop from
 * every SQUARE_EVERY-th pose of the second lap to the same place in the first; with run, a
 * revisited corridor: a true loop from every other pose of the second lap's poses 20-39 (a
 * run, cut by the single loops at 30 and 40 into two); with group, an attacker's group:
 * SQUARE_GROUP loops from the first lap's poses 10, 11, ... to 100, 101, ..., each measuring
 * the true relative pose with the second stretch moved by one rigid shift (2 m, 2 m, 0.3 rad
 * in pose 10's frame), so that the group agrees with itself and with the odometry along both
 * stretches, and only the path between them, and the loops there, contradict it. */
static pgem_t *square_walk(uint64_t seed, int run, int group, uint32_t *run_loops, uint32_t *group_loops)
{
    double information[9], truth[3 * SQUARE_POSES];
    test_rng_t rng = {seed};
    pgem_t *graph = square_odometry(&rng, 3.0, information, truth);
    for (int i = SQUARE_LAP; i < SQUARE_POSES; i++) {
        const int place = i - SQUARE_LAP;
        const int single = place % SQUARE_EVERY == 0, in_run = run && place >= 20 && place < 20 + SQUARE_RUN;
        if (!single && !(in_run && place % 2 == 1)) {
            continue;
        }
        double z[3];
        pgem_se2_between(truth + 3 * i, truth + 3 * place, z);
        square_noise(&rng, z);
        uint32_t index;
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)i, (pgem_id_t)place, z, information,
                                       PGEM_EDGE_LOOP, &index), PGEM_OK);
        if (in_run && !single) {
            run_loops[(place - 20) / 2] = index;
        }
    }
    const double shift[3] = {2.0, 2.0, 0.3};
    const double *base = truth + 3 * 10;
    for (int g = 0; group && g < SQUARE_GROUP; g++) {
        double relative[3], moved[3], z[3];
        pgem_se2_between(base, truth + 3 * (100 + g), relative);
        pgem_se2_compose(shift, relative, moved);
        pgem_se2_compose(base, moved, moved);
        pgem_se2_between(truth + 3 * (10 + g), moved, z);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(10 + g), (pgem_id_t)(100 + g), z, information,
                                       PGEM_EDGE_LOOP, &group_loops[g]), PGEM_OK);
    }
    return graph;
}

/* Issue 34: an attacker's group of mutually consistent false loops, on a graph whose stated
 * covariances are too loose for the odometry between the group's ends to refute it at the
 * 99.9 % level: before the leave-group-out test, EM accepted the group (or most of it) in
 * every seed and the map bent by 2 m. Left out as a whole, the group's fall is far above its
 * quantile scaled by the variance factor of the rest; it is rejected whole, and a revisited
 * corridor's true run is kept, with or without the attacker. */
static void test_consistent_false_group_rejected_whole(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 4; seed++) {
        for (int group = 1; group >= 0; group--) {
            uint32_t run_loops[SQUARE_RUN / 2], group_loops[SQUARE_GROUP];
            pgem_t *graph = square_walk(seed, 1, group, run_loops, group_loops);
            pgem_robust_options_t options = em_options();
            pgem_robust_summary_t summary;
            assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
            assert_int_equal(loops_kept(graph, run_loops, SQUARE_RUN / 2), SQUARE_RUN / 2);
            if (group) {
                assert_int_equal(loops_kept(graph, group_loops, SQUARE_GROUP), 0);
            }
            assert_true(summary.rejected <= (group ? SQUARE_GROUP + 1u : 1u)); /* at most one true loop */
            pgem_destroy(graph);
        }
    }
}

/* A square walk as square_walk's, with the stated standard deviations ten times the real
 * ones and a true loop from every second pose of the second lap, and one false loop on the
 * first lap from pose 22 to pose 36: the true relative pose moved `lateral` metres to the
 * side, near what the odometry alone gives for fourteen steps whose rotation the map cannot
 * predict to 0.1 rad. */
static pgem_t *loose_square(uint64_t seed, double lateral, uint32_t *false_loop)
{
    double information[9], truth[3 * SQUARE_POSES];
    test_rng_t rng = {seed};
    pgem_t *graph = square_odometry(&rng, 10.0, information, truth);
    for (int i = SQUARE_LAP; i < SQUARE_POSES; i += 2) {
        double z[3];
        pgem_se2_between(truth + 3 * i, truth + 3 * (i - SQUARE_LAP), z);
        square_noise(&rng, z);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)i, (pgem_id_t)(i - SQUARE_LAP), z, information,
                                       PGEM_EDGE_LOOP, NULL), PGEM_OK);
    }
    double z[3];
    pgem_se2_between(truth + 3 * 22, truth + 3 * 36, z);
    z[1] += lateral;
    assert_int_equal(pgem_add_edge(graph, 22, 36, z, information, PGEM_EDGE_LOOP, false_loop), PGEM_OK);
    return graph;
}

/* Issue 34: a loop whose rotation the map does not predict is tested by its innovation under
 * the stated covariances alone; when they are ten times too loose, a false loop 2.5 m off
 * passed that test (the synthetic M3500 cells' single local false loops). Tested against the
 * gate scaled by the adjustment's variance factor, it is rejected, every true loop is kept,
 * and the passes converge (the test of a pruned loop is no looser than that of an accepted
 * one, so nothing flips between them). */
static void test_loose_covariances_scale_the_unpredicted_test(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 4; seed++) {
        uint32_t false_loop;
        pgem_t *graph = loose_square(seed, 2.5, &false_loop);
        pgem_robust_options_t options = em_options();
        pgem_robust_summary_t summary;
        assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
        assert_int_equal(loops_kept(graph, &false_loop, 1), 0);
        assert_int_equal(summary.rejected, 1u);
        assert_int_equal(summary.termination, PGEM_ROBUST_CONVERGED);
        pgem_destroy(graph);
    }
}

/* Issue 17: a loop closure whose chi2 is not finite (its measurement near the double range,
 * written past the input checks here) is an outlier from the start, not the end of every
 * solve: pruned at weight 0 and named by its index, the rest solved. */
static void test_non_finite_loop_is_pruned(void **state)
{
    (void)state;
    double truth[3 * RING];
    pgem_t *graph = ring(4, truth);
    const uint32_t bad = 5u + (uint32_t)RING; /* a loop closure: the odometry comes first */
    pgem_edge_view_t edge;
    assert_int_equal(pgem_edge_at(graph, bad, &edge), PGEM_OK);
    assert_int_equal(edge.kind, PGEM_EDGE_LOOP);
    graph->store.edge_measurement[3u * bad] = 1e300;
    for (int kernel = PGEM_KERNEL_EM; kernel <= PGEM_KERNEL_DCS; kernel++) {
        if (kernel == PGEM_KERNEL_NONE) {
            continue; /* plain least squares has no loop to prune */
        }
        pgem_robust_reset(graph);
        pgem_robust_options_t options = {0};
        options.kernel = (pgem_kernel_t)kernel;
        pgem_robust_summary_t summary;
        assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
        assert_int_equal(summary.non_finite, 1);
        assert_int_equal(summary.first_non_finite, bad);
        assert_int_equal(pgem_edge_at(graph, bad, &edge), PGEM_OK);
        assert_int_equal(edge.active, 0);
        assert_true(edge.weight == 0.0);
        assert_true(isfinite(summary.final_chi2));
        assert_false(isfinite(summary.final_chi2_all));
    }
    pgem_destroy(graph);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kernel_formulas),
        cmocka_unit_test(test_inliers_only_nothing_pruned_plain_optimum),
        cmocka_unit_test(test_loop_weight_and_state),
        cmocka_unit_test(test_kernel_rho_and_derivative),
        cmocka_unit_test(test_user_kernel),
        cmocka_unit_test(test_zeroed_options_mean_em),
        cmocka_unit_test(test_termination_and_chi2_convention),
        cmocka_unit_test(test_em_finds_outliers),
        cmocka_unit_test(test_literal_em_finds_outliers),
        cmocka_unit_test(test_dcs_downweights_outliers),
        cmocka_unit_test(test_em_weights_are_cauchy_weights),
        cmocka_unit_test(test_deterministic_and_resettable),
        cmocka_unit_test(test_pruned_loops_leave_the_structure),
        cmocka_unit_test(test_dormant_loops_keep_the_factor_sparse),
        cmocka_unit_test(test_consistency_gate_prunes_what_em_keeps),
        cmocka_unit_test(test_pruning_that_splits_the_graph_holds_the_part),
        cmocka_unit_test(test_robot_frame_from_agreeing_loops),
        cmocka_unit_test(test_robot_frame_needs_agreeing_loops),
        cmocka_unit_test(test_oscillating_passes_end_in_the_cycle),
        cmocka_unit_test(test_cycle_ends_at_its_cheapest_set),
        cmocka_unit_test(test_non_finite_robust_options_refused),
        cmocka_unit_test(test_non_finite_start_leaves_the_weights),
        cmocka_unit_test(test_cauchy_weight_of_an_exact_fit),
        cmocka_unit_test(test_drifted_true_loops_are_kept),
        cmocka_unit_test(test_degenerate_outcomes_are_reported),
        cmocka_unit_test(test_true_run_rescued_when_every_loop_is_rejected),
        cmocka_unit_test(test_true_run_rescued_when_em_keeps_one_false_loop),
        cmocka_unit_test(test_local_false_run_left_out),
        cmocka_unit_test(test_consistent_false_group_rejected_whole),
        cmocka_unit_test(test_loose_covariances_scale_the_unpredicted_test),
        cmocka_unit_test(test_non_finite_loop_is_pruned),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
