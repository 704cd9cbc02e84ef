/* Solver tests: convergence to ground truth in 2D and 3D, GN vs LM, failures that restore the
 * estimate, the fill budget, callbacks, fixed poses and re-analysis on topology change. */
#include <stdio.h>

#include "instance.h" /* to put an estimate out of range behind the API */
#include "test_util.h"

#define RING 60

static void test_exact_ring_recovers_truth(void **state)
{
    (void)state;
    double truth[3 * RING], result[3 * RING];
    pgem_t *graph = test_create(2, RING, 2 * RING);
    test_ring_2d(graph, RING, 5, 0.0, 0.0, 1, truth);
    /* spoil the initial estimate so there is work to do */
    for (int k = 1; k < RING; k++) {
        double spoiled[3] = {truth[3 * k] + 0.3 * sin(k), truth[3 * k + 1] - 0.2, truth[3 * k + 2] + 0.1};
        assert_int_equal(pgem_set_pose(graph, (pgem_id_t)k, spoiled), PGEM_OK);
    }
    pgem_summary_t summary;
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_OK);
    assert_true(summary.usable && summary.estimate_changed);
    assert_true(summary.initial_chi2 > 1.0);
    assert_true(summary.final_chi2 < 1e-12);
    assert_int_equal(summary.variables, 3 * (RING - 1));
    test_snapshot(graph, result);
    for (int k = 0; k < 3 * RING; k++) {
        assert_near(result[k], truth[k], 1e-7);
    }
    pgem_destroy(graph);
}

static void test_gn_and_lm_agree_on_noisy_ring(void **state)
{
    (void)state;
    double truth[3 * RING];
    pgem_t *gn = test_create(2, RING, 2 * RING), *lm = test_create(2, RING, 2 * RING);
    test_ring_2d(gn, RING, 4, 0.02, 0.02, 7, truth);
    test_ring_2d(lm, RING, 4, 0.02, 0.02, 7, truth);
    pgem_summary_t gn_summary, lm_summary;
    pgem_solve_options_t options = {0};
    assert_int_equal(pgem_optimize(gn, &options, &gn_summary), PGEM_OK);
    options.method = PGEM_LEVENBERG_MARQUARDT;
    assert_int_equal(pgem_optimize(lm, &options, &lm_summary), PGEM_OK);
    assert_true(gn_summary.final_chi2 < gn_summary.initial_chi2);
    assert_near(lm_summary.final_chi2, gn_summary.final_chi2, 1e-6 * gn_summary.final_chi2);
    assert_near(pgem_total_chi2(gn), gn_summary.final_chi2, 1e-9 * gn_summary.final_chi2);
    /* the optimum is a minimum: perturbing any pose raises chi2 */
    double pose[3];
    assert_int_equal(pgem_pose(gn, 17, pose), PGEM_OK);
    pose[0] += 1e-3;
    assert_int_equal(pgem_set_pose(gn, 17, pose), PGEM_OK);
    assert_true(pgem_total_chi2(gn) > gn_summary.final_chi2);
    pgem_destroy(gn);
    pgem_destroy(lm);
}

/* 3D: random poses, exact relative measurements, a spoiled start: the truth comes back. */
static void test_3d_recovers_truth(void **state)
{
    (void)state;
    enum { N = 40 };
    test_rng_t rng = {42};
    double truth[7 * N], result[7 * N], information[36];
    test_diagonal_information(6, 10.0, information);
    pgem_t *graph = test_create(3, N, 3 * N);
    for (int k = 0; k < N; k++) {
        double tangent[6];
        for (int d = 0; d < 6; d++) {
            tangent[d] = (d < 3 ? 5.0 : 1.5) * (2.0 * test_uniform(&rng) - 1.0);
        }
        pgem_se3_exp(tangent, truth + 7 * k);
        double start[7];
        double noise[6] = {0.2, -0.1, 0.1, 0.05, 0.04, -0.05};
        pgem_se3_boxplus(truth + 7 * k, noise, start);
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)k, k == 0 ? truth : start), PGEM_OK);
    }
    for (int k = 1; k < N; k++) {
        int others[2] = {k - 1, (k * 7) % k};
        for (int m = 0; m < 2; m++) {
            if (m == 1 && (others[1] == k - 1)) {
                continue;
            }
            double z[7];
            pgem_se3_between(truth + 7 * others[m], truth + 7 * k, z);
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)others[m], (pgem_id_t)k, z, information,
                                           m == 0 ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP, NULL), PGEM_OK);
        }
    }
    pgem_summary_t summary;
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_OK);
    assert_true(summary.final_chi2 < 1e-12);
    test_snapshot(graph, result);
    for (int k = 0; k < N; k++) {
        double delta[7], log_delta[6];
        pgem_se3_between(truth + 7 * k, result + 7 * k, delta);
        pgem_se3_log(delta, log_delta);
        for (int d = 0; d < 6; d++) {
            assert_near(log_delta[d], 0.0, 1e-7);
        }
    }
    pgem_destroy(graph);
}

/* Two components and only one held: singular. The estimate stays what it was. */
static void test_singular_restores_estimate(void **state)
{
    (void)state;
    double truth[3 * 10], before[3 * 12], after[3 * 12], information[9];
    pgem_t *graph = test_create(2, 13, 20);
    test_ring_2d(graph, 10, 3, 0.01, 0.01, 3, truth);
    test_diagonal_information(3, 1.0, information);
    double p[3] = {5, 5, 0}, q[3] = {6, 5, 0.1}, z[3] = {1.2, 0.1, 0};
    assert_int_equal(pgem_add_pose(graph, 100, p), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 101, q), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 100, 101, z, information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    test_snapshot(graph, before);
    pgem_summary_t summary;
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_ERR_NOT_POSITIVE_DEFINITE);
    assert_int_equal(summary.usable, 0);
    assert_int_equal(summary.estimate_changed, 0);
    assert_int_equal(summary.termination, PGEM_TERM_NOT_POSITIVE_DEFINITE);
    assert_string_equal(pgem_last_error(graph),
                        "pose 100 is in a part of the graph with no held pose (a fixed pose, or "
                        "the first pose added when none is fixed): no edge, or only pruned loop "
                        "closures, join it to one");
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    /* Levenberg-Marquardt's damping would make the matrix invertible and let the second part
     * float: the split is refused before any number is computed, whatever the method */
    pgem_solve_options_t lm = {0};
    lm.method = PGEM_LEVENBERG_MARQUARDT;
    assert_int_equal(pgem_optimize(graph, &lm, &summary), PGEM_ERR_NOT_POSITIVE_DEFINITE);
    assert_int_equal(summary.usable, 0);
    assert_contains(pgem_last_error(graph), "pose 100 is in a part");
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    /* holding the second component too makes it solvable, but a pose without any edge is a
     * part of its own */
    assert_int_equal(pgem_fix_pose(graph, 0, 1), PGEM_OK);
    assert_int_equal(pgem_fix_pose(graph, 100, 1), PGEM_OK);
    double lone[3] = {9, 9, 0};
    assert_int_equal(pgem_add_pose(graph, 77, lone), PGEM_OK);
    assert_int_equal(pgem_optimize(graph, &lm, &summary), PGEM_ERR_NOT_POSITIVE_DEFINITE);
    assert_contains(pgem_last_error(graph), "pose 77 is in a part");
    assert_int_equal(pgem_fix_pose(graph, 77, 1), PGEM_OK);
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_OK);
    double held[3];
    assert_int_equal(pgem_pose(graph, 100, held), PGEM_OK);
    assert_memory_equal(held, p, sizeof p);
    pgem_destroy(graph);
}

/* The input limits keep every chi2 finite at the inputs (the API refuses 1e200 m and an
 * information of 1e300, test_graph); an estimate that has gone out of range all the same (a
 * diverged step, here written behind the API's back) must still fail cleanly. */
static void test_non_finite_chi2_fails_cleanly(void **state)
{
    (void)state;
    double huge[9], a[3] = {0, 0, 0}, b[3] = {1e200, 0, 0}, z[3] = {0, 0, 0}, one[9];
    test_diagonal_information(3, 1e300, huge);
    test_diagonal_information(3, 1.0, one);
    pgem_t *graph = test_create(2, 2, 1);
    assert_int_equal(pgem_add_pose(graph, 0, a), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 1, b), PGEM_ERR_OUT_OF_RANGE);
    assert_int_equal(pgem_add_pose(graph, 1, z), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 0, 1, z, huge, PGEM_EDGE_ODOMETRY, NULL),
                     PGEM_ERR_OUT_OF_RANGE);
    assert_int_equal(pgem_add_edge(graph, 0, 1, z, one, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    memcpy(graph->store.pose + 3, b, sizeof b);
    memcpy(graph->store.edge_information, huge, sizeof huge);
    pgem_summary_t summary;
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_ERR_NUMERIC);
    assert_int_equal(summary.usable, 0);
    assert_non_null(strstr(pgem_last_error(graph), "not finite"));
    double pose[3];
    assert_int_equal(pgem_pose(graph, 1, pose), PGEM_OK);
    assert_memory_equal(pose, b, sizeof b);
    pgem_destroy(graph);
}

/* A NaN or Inf solver option is refused, naming it, before anything changes (a NaN tolerance
 * would otherwise never stop the solve, a NaN damping poison the matrix). */
static void test_non_finite_options_refused(void **state)
{
    (void)state;
    double truth[3 * 10], before[3 * 10], after[3 * 10];
    pgem_t *graph = test_create(2, 10, 20);
    test_ring_2d(graph, 10, 3, 0.01, 0.01, 5, truth);
    test_snapshot(graph, before);
    const char *names[] = {"relative_chi2_tolerance", "step_tolerance", "initial_lambda"};
    const double bad[] = {(double)NAN, (double)INFINITY, -(double)INFINITY};
    for (int field = 0; field < 3; field++) {
        for (int k = 0; k < 3; k++) {
            pgem_solve_options_t options = {0};
            options.method = PGEM_LEVENBERG_MARQUARDT;
            double *value = field == 0 ? &options.relative_chi2_tolerance
                            : field == 1 ? &options.step_tolerance
                                         : &options.initial_lambda;
            *value = bad[k];
            pgem_summary_t summary;
            assert_int_equal(pgem_optimize(graph, &options, &summary), PGEM_ERR_INVALID_ARGUMENT);
            assert_int_equal(summary.usable, 0);
            char expected[96];
            snprintf(expected, sizeof expected, "option %s is not a finite number", names[field]);
            assert_string_equal(pgem_last_error(graph), expected);
        }
    }
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    pgem_destroy(graph);
}

static void test_fill_budget_reports_need(void **state)
{
    (void)state;
    double truth[3 * RING], before[3 * RING], after[3 * RING];
    pgem_config_t config = {2, RING, 2 * RING, 50, 0, 0};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    test_ring_2d(graph, RING, 5, 0.01, 0.01, 5, truth);
    test_snapshot(graph, before);
    pgem_summary_t summary;
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_ERR_FILL_BUDGET);
    assert_int_equal(summary.termination, PGEM_TERM_FILL_BUDGET);
    assert_non_null(strstr(pgem_last_error(graph), "fill_budget is 50"));
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    assert_true(stats.factor_nonzeros > 50);
    test_snapshot(graph, after);
    assert_memory_equal(before, after, sizeof before);
    pgem_destroy(graph);
    /* exactly the reported need is enough */
    config.fill_budget = stats.factor_nonzeros;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    test_ring_2d(graph, RING, 5, 0.01, 0.01, 5, truth);
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_OK);
    pgem_destroy(graph);
}

/* pgem_fill_needed sizes the factor without failing: on a budget too small it returns the need
 * (the figure the failed analysis reports), keeps the ordering for pgem_copy, and an instance of
 * exactly that budget solves while one value fewer does not. Within the budget it is the
 * analysis's own figure. */
static void test_fill_needed(void **state)
{
    (void)state;
    double truth[3 * RING];
    pgem_config_t config = {2, RING, 2 * RING, 50, 0, 0};
    pgem_t *probe = NULL;
    assert_int_equal(pgem_create(&probe, &config), PGEM_OK);
    uint32_t needed = 0;
    assert_int_equal(pgem_fill_needed(probe, &needed), PGEM_ERR_EMPTY);
    assert_int_equal(pgem_fill_needed(probe, NULL), PGEM_ERR_INVALID_ARGUMENT);
    test_ring_2d(probe, RING, 5, 0.01, 0.01, 5, truth);
    assert_int_equal(pgem_fill_needed(probe, &needed), PGEM_OK);
    assert_string_equal(pgem_last_error(probe), "");
    assert_int_equal(pgem_analyze(probe), PGEM_ERR_FILL_BUDGET);
    pgem_memory_stats_t stats;
    pgem_memory_use(probe, &stats);
    assert_int_equal(stats.factor_nonzeros, needed);
    assert_int_equal(pgem_fill_needed(probe, &needed), PGEM_OK);
    assert_int_equal(stats.factor_nonzeros, needed);

    pgem_summary_t summary;
    pgem_t *graph = NULL;
    config.fill_budget = needed;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    assert_int_equal(pgem_copy(graph, probe), PGEM_OK);
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.factor_nonzeros, needed);
    uint32_t again = 0;
    assert_int_equal(pgem_fill_needed(graph, &again), PGEM_OK);
    assert_int_equal(again, needed);
    pgem_memory_use(graph, &stats);
    assert_int_equal(stats.analyses, 1); /* the solve's analysis answered it */
    pgem_destroy(graph);
    config.fill_budget = needed - 1u;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    assert_int_equal(pgem_copy(graph, probe), PGEM_OK);
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_ERR_FILL_BUDGET);
    pgem_destroy(graph);
    pgem_destroy(probe);
}

static int stop_after_first(const pgem_iteration_t *iteration, void *user)
{
    int *calls = user;
    (*calls)++;
    return iteration->iteration >= 1;
}

static void test_callback_can_stop(void **state)
{
    (void)state;
    double truth[3 * RING];
    pgem_t *graph = test_create(2, RING, 2 * RING);
    test_ring_2d(graph, RING, 5, 0.05, 0.05, 9, truth);
    int calls = 0;
    pgem_solve_options_t options = {0};
    options.on_iteration = stop_after_first;
    options.user = &calls;
    pgem_summary_t summary;
    assert_int_equal(pgem_optimize(graph, &options, &summary), PGEM_OK);
    assert_int_equal(calls, 1);
    assert_int_equal(summary.iterations, 1);
    assert_int_equal(summary.termination, PGEM_TERM_STOPPED);
    assert_true(summary.usable);
    pgem_destroy(graph);
}

static void test_analysis_once_per_topology(void **state)
{
    (void)state;
    double truth[3 * RING], information[9];
    test_diagonal_information(3, 100.0, information);
    pgem_t *graph = test_create(2, RING, 2 * RING);
    test_ring_2d(graph, RING, 5, 0.01, 0.01, 11, truth);
    pgem_memory_stats_t stats;
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    pgem_memory_use(graph, &stats);
    assert_int_equal(stats.analyses, 1);
    double z[3];
    pgem_se2_between(truth + 3, truth + 3 * 40, z);
    assert_int_equal(pgem_add_edge(graph, 1, 40, z, information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    pgem_memory_use(graph, &stats);
    assert_int_equal(stats.analyses, 2);
    pgem_destroy(graph);
}

static void test_empty_graph(void **state)
{
    (void)state;
    pgem_t *graph = test_create(2, 4, 4);
    pgem_summary_t summary;
    assert_int_equal(pgem_optimize(graph, NULL, &summary), PGEM_ERR_EMPTY);
    assert_non_null(strstr(pgem_last_error(graph), "no edges"));
    pgem_solve_options_t bad = {0};
    bad.method = (pgem_method_t)9;
    assert_int_equal(pgem_optimize(graph, &bad, &summary), PGEM_ERR_INVALID_ARGUMENT);
    assert_string_equal(pgem_termination_name(PGEM_TERM_CHI2_CONVERGED), "chi2-converged");
    assert_string_equal(pgem_method_name(PGEM_LEVENBERG_MARQUARDT), "levenberg-marquardt");
    pgem_destroy(graph);
}

/* pgem_check_solvable answers as pgem_optimize would before its first iteration, on every
 * kind of graph it refuses, and changes nothing (issue 17: `pgem stats` said ok for graphs
 * `optimize` refused). */
static void expect_same_verdict(pgem_t *graph, int expected, const char *fragment)
{
    double before[3 * 4], after[3 * 4];
    uint32_t poses = pgem_pose_count(graph);
    for (uint32_t i = 0; i < poses; i++) {
        pgem_pose_at(graph, i, NULL, before + 3 * i, NULL);
    }
    assert_int_equal(pgem_check_solvable(graph), expected);
    if (fragment != NULL) {
        assert_non_null(strstr(pgem_last_error(graph), fragment));
    }
    for (uint32_t i = 0; i < poses; i++) {
        pgem_pose_at(graph, i, NULL, after + 3 * i, NULL);
    }
    assert_memory_equal(before, after, sizeof(double) * 3 * poses);
    pgem_summary_t summary;
    assert_int_equal(pgem_optimize(graph, NULL, &summary), expected);
}

static void test_check_solvable(void **state)
{
    (void)state;
    double information[9], z[3] = {1.0, 0.0, 0.0};
    test_diagonal_information(3, 1.0, information);
    assert_int_equal(pgem_check_solvable(NULL), PGEM_ERR_INVALID_ARGUMENT);
    pgem_t *graph = test_create(2, 4, 4);
    const double origin[3] = {0.0, 0.0, 0.0};
    assert_int_equal(pgem_add_pose(graph, 0, origin), PGEM_OK);
    expect_same_verdict(graph, PGEM_ERR_EMPTY, "no edges"); /* one vertex */
    assert_int_equal(pgem_add_pose(graph, 1, z), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 0, 1, z, information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    assert_int_equal(pgem_fix_pose(graph, 0, 1), PGEM_OK);
    assert_int_equal(pgem_fix_pose(graph, 1, 1), PGEM_OK);
    expect_same_verdict(graph, PGEM_ERR_EMPTY, "every pose is fixed");
    assert_int_equal(pgem_fix_pose(graph, 1, 0), PGEM_OK);
    const double two[3] = {2.0, 0.0, 0.0}, three[3] = {3.0, 0.0, 0.0};
    assert_int_equal(pgem_add_pose(graph, 2, two), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 3, three), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 2, 3, z, information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    expect_same_verdict(graph, PGEM_ERR_NOT_POSITIVE_DEFINITE, "pose 2 is in a part of the graph");
    assert_int_equal(pgem_add_edge(graph, 1, 2, z, information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    expect_same_verdict(graph, PGEM_OK, NULL);
    assert_string_equal(pgem_last_error(graph), "");
    /* an estimate gone out of range behind the API's back (as in the test above) */
    graph->store.pose[3] = 1e300;
    expect_same_verdict(graph, PGEM_ERR_NUMERIC, "not finite");
    pgem_destroy(graph);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exact_ring_recovers_truth),
        cmocka_unit_test(test_gn_and_lm_agree_on_noisy_ring),
        cmocka_unit_test(test_3d_recovers_truth),
        cmocka_unit_test(test_singular_restores_estimate),
        cmocka_unit_test(test_non_finite_chi2_fails_cleanly),
        cmocka_unit_test(test_non_finite_options_refused),
        cmocka_unit_test(test_fill_budget_reports_need),
        cmocka_unit_test(test_fill_needed),
        cmocka_unit_test(test_callback_can_stop),
        cmocka_unit_test(test_analysis_once_per_topology),
        cmocka_unit_test(test_empty_graph),
        cmocka_unit_test(test_check_solvable),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
