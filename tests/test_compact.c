/* pgem_compact: poses removed in the block, their edges composed onto the poses kept. On the
 * shared datasets (skipped without them) the kept poses of the half-size graph are compared
 * with the whole graph's optimum; on a synthetic walk: loop verdicts carried, ids and maps,
 * the incremental update going on, no allocation, the arguments. */
#include "test_io_util.h"

#include "test_alloc_counters.h"

/* Largest translation difference between the kept poses of `small` and the same ids in
 * `whole`; their RMS into *rms. */
static double kept_difference(const pgem_t *small, const pgem_t *whole, double *rms)
{
    double largest = 0.0, sum = 0.0;
    const uint32_t poses = pgem_pose_count(small);
    for (uint32_t i = 0; i < poses; i++) {
        pgem_id_t id = 0;
        double a[7], b[7];
        assert_int_equal(pgem_pose_at(small, i, &id, a, NULL), PGEM_OK);
        assert_int_equal(pgem_pose(whole, id, b), PGEM_OK);
        const int three = pgem_dimension(small) == 3;
        double d2 = (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]);
        d2 += three ? (a[2] - b[2]) * (a[2] - b[2]) : 0.0;
        sum += d2;
        largest = sqrt(d2) > largest ? sqrt(d2) : largest;
    }
    *rms = sqrt(sum / (double)poses);
    return largest;
}


/* A walk of `poses` in the plane (noise sigma on every measurement) with a loop closure from
 * every fifth pose to the pose 20 before it; with `false_loops`, that many more that lie (a
 * 3 m, 1 rad shift), each with its own verdict from EM later. */
static pgem_t *walk(int poses, double sigma, int false_loops, uint32_t max_poses)
{
    test_rng_t rng = {7u};
    pgem_config_t config = {2, max_poses, 4u * max_poses, 0, 0, 64u * 9u * max_poses};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    double truth[3 * 1000], information[9], z[3], noise[3];
    test_diagonal_information(3, 1.0 / (sigma * sigma), information);
    for (int k = 0; k < poses; k++) {
        const double angle = 0.13 * k;
        truth[3 * k] = (8.0 + 0.3 * sin(0.07 * k)) * cos(angle);
        truth[3 * k + 1] = (8.0 + 0.3 * sin(0.07 * k)) * sin(angle);
        truth[3 * k + 2] = pgem_wrap_angle(angle + 1.5707963267948966);
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)(1000 + k), truth + 3 * k), PGEM_OK);
    }
    for (int k = 1; k < poses; k++) {
        for (int loop = 0; loop < 2; loop++) {
            const int from = loop ? k - 20 : k - 1;
            if (loop && (k % 5 != 0 || from < 0)) {
                continue;
            }
            pgem_se2_between(truth + 3 * from, truth + 3 * k, z);
            for (int d = 0; d < 3; d++) {
                noise[d] = sigma * test_gaussian(&rng);
            }
            pgem_se2_boxplus(z, noise, z);
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(1000 + from), (pgem_id_t)(1000 + k), z,
                                           information, loop ? PGEM_EDGE_LOOP : PGEM_EDGE_ODOMETRY,
                                           NULL), PGEM_OK);
        }
    }
    for (int f = 0; f < false_loops; f++) {
        const int a = (int)(test_uniform(&rng) * (poses - 60)), b = a + 40;
        pgem_se2_between(truth + 3 * a, truth + 3 * b, z);
        z[0] += 3.0;
        z[2] = pgem_wrap_angle(z[2] + 1.0);
        assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(1000 + a), (pgem_id_t)(1000 + b), z,
                                       information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
    }
    return graph;
}

/* Chain poses removed from a walk whose measurements are nearly exact: the kept poses are the
 * whole graph's optimum to rounding (the composition and the marginalised information are
 * exact for a linear problem, and this one is nearly linear). */
static void test_chain_poses_exact(void **state)
{
    (void)state;
    pgem_t *whole = walk(400, 1e-5, 0, 400);
    pgem_t *graph = walk(400, 1e-5, 0, 400);
    assert_int_equal(pgem_optimize(whole, NULL, NULL), PGEM_OK);
    pgem_compact_options_t options;
    memset(&options, 0, sizeof options);
    options.chain_only = 1;
    pgem_compact_summary_t summary;
    assert_int_equal(pgem_compact(graph, 200, &options, &summary), PGEM_OK);
    assert_int_equal(summary.poses_after, 200); /* 4 in 5 poses have no loop: enough */
    assert_int_equal(summary.loops_carried, 0);
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    double rms = 0.0;
    const double largest = kept_difference(graph, whole, &rms);
    print_message("chain poses of a nearly exact walk: 400 -> 200, kept poses off by %.3g m\n", largest);
    assert_true(largest < 1e-8);
    pgem_destroy(graph);
    pgem_destroy(whole);
}

/* EM on the graph (default options); its summary into *robust. */
static void em_decides(pgem_t *graph, pgem_robust_summary_t *robust)
{
    pgem_robust_options_t em;
    memset(&em, 0, sizeof em);
    em.kernel = PGEM_KERNEL_EM;
    assert_int_equal(pgem_robust_optimize(graph, &em, NULL, robust), PGEM_OK);
}

/* A robust stream's verdicts survive: EM decides, then half the poses go; every carried loop
 * keeps its state and weight, the pruned ones at removed poses are dropped and counted, ids
 * stay (removed ones are unknown), the maps say where each went, the incremental update goes
 * on from the compacted graph, and nothing is allocated. */
static void test_verdicts_ids_and_update(void **state)
{
    (void)state;
    pgem_t *graph = walk(400, 0.01, 12, 500);
    pgem_robust_summary_t robust;
    em_decides(graph, &robust);
    assert_true(robust.pruned >= 10u);
    const uint32_t edges = pgem_edge_count(graph);
    static uint32_t pose_map[400], edge_map[2000];
    static pgem_edge_view_t before[2000];
    for (uint32_t k = 0; k < edges; k++) {
        assert_int_equal(pgem_edge_at(graph, k, &before[k]), PGEM_OK);
    }
    pgem_compact_options_t options;
    memset(&options, 0, sizeof options);
    options.tail = 50;
    options.pose_map = pose_map;
    options.edge_map = edge_map;
    pgem_compact_summary_t summary;
#if !TEST_UNDER_SANITIZER /* the counters need malloc, which AddressSanitizer owns */
    const long allocated = allocations;
#endif
    assert_int_equal(pgem_compact(graph, 100, &options, &summary), PGEM_OK);
#if !TEST_UNDER_SANITIZER
    assert_int_equal(allocations, allocated);
#endif
    assert_int_equal(summary.poses_after, 100);
    assert_true(summary.loops_carried > 0u && summary.loops_dropped > 0u);
    uint32_t kept = 0, carried = 0;
    for (uint32_t i = 0; i < 400; i++) {
        double pose[3];
        const int status = pgem_pose(graph, (pgem_id_t)(1000 + i), pose);
        assert_int_equal(status, pose_map[i] == UINT32_MAX ? PGEM_ERR_UNKNOWN_ID : PGEM_OK);
        if (pose_map[i] != UINT32_MAX) {
            pgem_id_t id = 0;
            assert_int_equal(pgem_pose_at(graph, pose_map[i], &id, NULL, NULL), PGEM_OK);
            assert_int_equal(id, 1000 + i);
            kept++;
        } else {
            assert_true(i < 350u); /* the tail of 50 stays */
        }
    }
    assert_int_equal(kept, 100);
    uint32_t pruned_after = 0, fused = 0;
    for (uint32_t k = 0; k < edges; k++) {
        if (edge_map[k] == UINT32_MAX) { /* odometry composed, a pruned loop dropped, a loop fused */
            fused += before[k].kind == PGEM_EDGE_LOOP && before[k].active;
            continue;
        }
        pgem_edge_view_t after;
        assert_int_equal(pgem_edge_at(graph, edge_map[k], &after), PGEM_OK);
        assert_int_equal(after.kind, before[k].kind);
        if (after.kind == PGEM_EDGE_LOOP) {
            assert_int_equal(after.active, before[k].active); /* nothing decided again */
            assert_true(after.weight == before[k].weight || after.weight == 1.0); /* 1: fused */
            carried += after.from != before[k].from || after.to != before[k].to;
            pruned_after += !after.active;
        }
    }
    assert_true(carried > 0u && carried <= summary.loops_carried); /* some moved more than once */
    assert_int_equal(pruned_after + summary.loops_dropped, robust.pruned);
    assert_int_equal(fused, summary.loops_fused);
    /* the incremental update goes on: a rebuild, then new poses as before */
    pgem_update_options_t update_options;
    memset(&update_options, 0, sizeof update_options);
    update_options.robust = 1;
    pgem_update_summary_t update;
    assert_int_equal(pgem_update(graph, &update_options, &update), PGEM_OK);
    assert_int_equal(update.rebuilt, 1);
    double last[3], next[3], z[3] = {0.3, 0.0, 0.05}, information[9];
    test_diagonal_information(3, 1e4, information);
    assert_int_equal(pgem_pose(graph, 1399, last), PGEM_OK);
    pgem_se2_compose(last, z, next);
    assert_int_equal(pgem_add_pose(graph, 1400, next), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 1399, 1400, z, information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    assert_int_equal(pgem_update(graph, &update_options, &update), PGEM_OK);
    assert_int_equal(update.rebuilt, 0);
    assert_int_equal(update.poses_added, 1);
    pgem_destroy(graph);
}

/* The arguments: NULL refused; a target at or above the count changes nothing; a graph with
 * nothing removable (every pose in the tail) says so by its count. */
static void test_arguments(void **state)
{
    (void)state;
    pgem_compact_summary_t summary;
    assert_int_equal(pgem_compact(NULL, 10, NULL, &summary), PGEM_ERR_INVALID_ARGUMENT);
    pgem_t *graph = walk(40, 0.01, 0, 40);
    assert_int_equal(pgem_compact(graph, 40, NULL, &summary), PGEM_OK);
    assert_int_equal(summary.poses_after, 40);
    assert_int_equal(pgem_compact(graph, 10, NULL, &summary), PGEM_OK); /* tail 32: 8 may go */
    assert_true(summary.poses_after > 10u && summary.poses_after < 40u);
    assert_int_equal(pgem_pose_count(graph), summary.poses_after);
    pgem_destroy(graph);
}

/* Pruned loops carried, still pruned, when asked (a live stream's verdicts are provisional):
 * nothing is dropped, and EM can take them up again after. */
static uint32_t pruned_loops(const pgem_t *graph)
{
    uint32_t pruned = 0;
    for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
        pgem_edge_view_t view;
        assert_int_equal(pgem_edge_at(graph, k, &view), PGEM_OK);
        pruned += view.kind == PGEM_EDGE_LOOP && !view.active;
    }
    return pruned;
}

static void test_keep_pruned(void **state)
{
    (void)state;
    pgem_t *graph = walk(400, 0.01, 12, 500);
    em_decides(graph, NULL);
    const uint32_t before = pruned_loops(graph);
    assert_true(before >= 10u);
    pgem_compact_options_t options;
    memset(&options, 0, sizeof options);
    options.keep_pruned = 1;
    pgem_compact_summary_t summary;
    assert_int_equal(pgem_compact(graph, 150, &options, &summary), PGEM_OK);
    assert_true(summary.poses_after < 300u);
    assert_int_equal(summary.loops_dropped, 0);
    assert_int_equal(pruned_loops(graph), before);
    em_decides(graph, NULL);
    print_message("pruned loops kept: %u before, %u after compaction and EM again\n", before,
                  pruned_loops(graph));
    assert_true(pruned_loops(graph) >= before - 2u);
    pgem_destroy(graph);
}

/* A block whose edges fill first: past the pose target, poses keep going until the edges fit,
 * and the carried loops fuse; a target no removal can meet ends with what could go. */
static void test_edge_target(void **state)
{
    (void)state;
    pgem_t *graph = walk(400, 0.01, 0, 400);
    const uint32_t edges = pgem_edge_count(graph);
    pgem_compact_options_t options;
    memset(&options, 0, sizeof options);
    options.target_edges = edges / 2u;
    pgem_compact_summary_t summary;
    assert_int_equal(pgem_compact(graph, 390, &options, &summary), PGEM_OK);
    print_message("edge target %u: %u -> %u poses, %u -> %u edges (%u loops fused)\n",
                  options.target_edges, summary.poses_before, summary.poses_after,
                  summary.edges_before, summary.edges_after, summary.loops_fused);
    assert_true(summary.poses_after < 390u);
    assert_true(summary.edges_after <= edges / 2u);
    assert_int_equal(pgem_edge_count(graph), summary.edges_after);
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    options.target_edges = 1u; /* the tail and the first pose stay: it cannot be met */
    assert_int_equal(pgem_compact(graph, 1, &options, &summary), PGEM_OK);
    assert_true(summary.edges_after > 1u && summary.poses_after >= 32u);
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    pgem_destroy(graph);
}

static void dataset_case(const char *file, double chain_bound, double full_bound)
{
    const char *dir = test_datasets_dir("2d/intel.g2o");
    if (dir == NULL) {
        skip();
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    pgem_solve_options_t tight; /* both solves to the last digit: the difference is the graph's */
    memset(&tight, 0, sizeof tight);
    tight.relative_chi2_tolerance = 1e-15;
    tight.step_tolerance = 1e-12;
    pgem_t *whole = test_load_file(path);
    assert_int_equal(pgem_optimize(whole, &tight, NULL), PGEM_OK);
    for (int chain_only = 1; chain_only >= 0; chain_only--) {
        pgem_t *graph = test_load_file(path);
        assert_int_equal(pgem_optimize(graph, &tight, NULL), PGEM_OK); /* a solved map, as a robot's */
        pgem_compact_options_t options;
        memset(&options, 0, sizeof options);
        options.chain_only = chain_only;
        pgem_compact_summary_t summary;
        assert_int_equal(pgem_compact(graph, pgem_pose_count(graph) / 2u, &options, &summary), PGEM_OK);
        assert_int_equal(summary.poses_after, pgem_pose_count(graph));
        assert_int_equal(summary.edges_before - summary.edges_after,
                         summary.poses_before - summary.poses_after + summary.loops_dropped +
                             summary.loops_fused);
        pgem_summary_t solved;
        if (pgem_optimize(graph, &tight, &solved) != PGEM_OK) {
            fail_msg("%s: %s", file, pgem_last_error(graph));
        }
        double rms = 0.0;
        const double largest = kept_difference(graph, whole, &rms);
        print_message("%s, %s: %u -> %u poses (%u edges composed, %u loops carried, %u fused): "
                      "kept poses off the whole graph's optimum by %.3g m at most, %.3g m RMS\n",
                      file, chain_only ? "chain poses only" : "with loop closures",
                      summary.poses_before, summary.poses_after, summary.edges_composed,
                      summary.loops_carried, summary.loops_fused, largest, rms);
        assert_true(largest <= (chain_only ? chain_bound : full_bound));
        pgem_destroy(graph);
    }
    pgem_destroy(whole);
}

static void test_m3500(void **state)
{
    (void)state;
    dataset_case("2d/input_M3500_g2o.g2o", 1e-6, 0.4); /* measured 2e-9, 0.33 */
}

static void test_city10000(void **state)
{
    (void)state;
    dataset_case("2d/city10000.g2o", 1e-6, 0.4); /* measured 1e-14, 0.31 */
}

static void test_sphere2500(void **state)
{
    (void)state;
    dataset_case("3d/sphere2500.g2o", 1e-9, 1.3); /* every pose has loops; measured 1.21 */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_chain_poses_exact),
        cmocka_unit_test(test_verdicts_ids_and_update),
        cmocka_unit_test(test_arguments),
        cmocka_unit_test(test_edge_target),
        cmocka_unit_test(test_keep_pruned),
        cmocka_unit_test(test_m3500),
        cmocka_unit_test(test_city10000),
        cmocka_unit_test(test_sphere2500),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
