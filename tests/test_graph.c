/* Core API tests: configuration, memory sizing, and every bad input leaving the graph unchanged. */
#include <stdio.h>

#include "test_util.h"
#include "pgem/io.h" /* lib/io's error codes (header only: test_graph links the core alone) */

static const double identity_2d[3] = {0.0, 0.0, 0.0};
static const double identity_3d[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};

static void test_config_defaults(void **state)
{
    (void)state;
    pgem_config_t zero = {0, 0, 0, 0, 0, 0}, resolved;
    assert_int_equal(pgem_config_resolve(&zero, &resolved), PGEM_OK);
    assert_int_equal(resolved.dimension, 2);
    assert_int_equal(resolved.max_poses, PGEM_DEFAULT_MAX_POSES);
    assert_int_equal(resolved.max_edges, PGEM_DEFAULT_MAX_POSES * PGEM_DEFAULT_EDGES_PER_POSE);
    assert_true(resolved.fill_budget > 0);
    pgem_config_t bad = {4, 10, 10, 0, 0, 0};
    assert_int_equal(pgem_config_resolve(&bad, &resolved), PGEM_ERR_CONFIG);
    assert_int_equal(pgem_memory_size(&bad), 0);
    pgem_config_t huge = {2, PGEM_MAX_POSES_LIMIT + 1u, 0, 0, 0, 0};
    assert_int_equal(pgem_memory_size(&huge), 0);
}

static void test_memory_grows_with_capacity(void **state)
{
    (void)state;
    pgem_config_t small = {2, 100, 200, 1000, 0, 0}, large = {2, 200, 200, 1000, 0, 0};
    pgem_config_t wider = {3, 100, 200, 1000, 0, 0};
    assert_true(pgem_memory_size(&small) < pgem_memory_size(&large));
    assert_true(pgem_memory_size(&small) < pgem_memory_size(&wider));
}

static void test_init_in_static_buffer(void **state)
{
    (void)state;
    static unsigned char buffer[1 << 20];
    pgem_config_t config = {2, 100, 200, 20000, 0, 0};
    size_t need = pgem_memory_size(&config);
    assert_true(need > 0 && need < sizeof buffer);
    pgem_t *graph = NULL;
    assert_int_equal(pgem_init(&graph, &config, buffer + 1, need - 1), PGEM_ERR_BUFFER_TOO_SMALL);
    assert_null(graph);
    /* an odd start address works: the block is aligned inside */
    assert_int_equal(pgem_init(&graph, &config, buffer + 1, need), PGEM_OK);
    assert_non_null(graph);
    assert_true((unsigned char *)graph >= buffer + 1 && (unsigned char *)graph < buffer + 1 + need);
    assert_int_equal(pgem_add_pose(graph, 7, identity_2d), PGEM_OK);
    assert_int_equal(pgem_pose_count(graph), 1);
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    assert_int_equal(stats.block_bytes, need);
    assert_true(stats.used_bytes <= need);
    assert_int_equal(pgem_init(NULL, &config, buffer, need), PGEM_ERR_INVALID_ARGUMENT);
}

static void test_pose_ids_64bit(void **state)
{
    (void)state;
    pgem_t *graph = test_create(3, 4, 4);
    const pgem_id_t big = UINT64_C(8430738502437568512), top = UINT64_MAX;
    assert_int_equal(pgem_add_pose(graph, big, identity_3d), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, top, identity_3d), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 0, identity_3d), PGEM_OK);
    double pose[7];
    assert_int_equal(pgem_pose(graph, top, pose), PGEM_OK);
    assert_int_equal(pgem_pose(graph, big + 1u, pose), PGEM_ERR_UNKNOWN_ID);
    pgem_id_t id;
    assert_int_equal(pgem_pose_at(graph, 1, &id, NULL, NULL), PGEM_OK);
    assert_true(id == top);
    uint32_t index = 99;
    assert_int_equal(pgem_pose_index(graph, 0, &index), PGEM_OK);
    assert_int_equal(index, 2);
    assert_int_equal(pgem_pose_index(graph, top, &index), PGEM_OK);
    assert_int_equal(index, 1);
    assert_int_equal(pgem_pose_index(graph, big + 1u, &index), PGEM_ERR_UNKNOWN_ID);
    assert_int_equal(index, 1);
    assert_int_equal(pgem_pose_index(graph, big, NULL), PGEM_ERR_INVALID_ARGUMENT);
    pgem_destroy(graph);
    /* every id is valid, none is reserved: the ends of the signed and unsigned ranges */
    const pgem_id_t ends[] = {UINT64_C(9223372036854775807), UINT64_C(9223372036854775808),
                              UINT64_C(18446744073709551614), UINT64_C(18446744073709551615)};
    graph = test_create(2, 4, 4);
    double information[9];
    test_diagonal_information(3, 1.0, information);
    const double z[3] = {1, 0, 0};
    for (int k = 0; k < 4; k++) {
        assert_int_equal(pgem_add_pose(graph, ends[k], identity_2d), PGEM_OK);
    }
    for (int k = 0; k < 3; k++) {
        assert_int_equal(pgem_add_edge(graph, ends[k], ends[k + 1], z, information,
                                       PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    }
    assert_int_equal(pgem_add_pose(graph, ends[3], identity_2d), PGEM_ERR_CAPACITY);
    assert_int_equal(pgem_add_edge(graph, ends[3], 0, z, information, PGEM_EDGE_LOOP, NULL),
                     PGEM_ERR_UNKNOWN_ID);
    assert_string_equal(pgem_last_error(graph),
                        "no pose with id 0 (edge 18446744073709551615 -> 0)");
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    for (int k = 0; k < 4; k++) {
        assert_int_equal(pgem_pose_at(graph, (uint32_t)k, &id, NULL, NULL), PGEM_OK);
        assert_true(id == ends[k]);
    }
    pgem_destroy(graph);
}

static void test_pose_errors_change_nothing(void **state)
{
    (void)state;
    pgem_t *graph = test_create(2, 2, 2);
    assert_int_equal(pgem_add_pose(graph, 1, identity_2d), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 1, identity_2d), PGEM_ERR_DUPLICATE_ID);
    assert_non_null(strstr(pgem_last_error(graph), "pose id 1 already exists"));
    double nan_pose[3] = {0.0, (double)NAN, 0.0};
    assert_int_equal(pgem_add_pose(graph, 2, nan_pose), PGEM_ERR_NOT_FINITE);
    assert_non_null(strstr(pgem_last_error(graph), "field y"));
    assert_non_null(strstr(pgem_last_error(graph), "pose id 2"));
    assert_int_equal(pgem_pose_count(graph), 1);
    assert_int_equal(pgem_add_pose(graph, 2, identity_2d), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 3, identity_2d), PGEM_ERR_CAPACITY);
    assert_non_null(strstr(pgem_last_error(graph), "max_poses = 2"));
    assert_int_equal(pgem_pose_count(graph), 2);
    assert_int_equal(pgem_fix_pose(graph, 99, 1), PGEM_ERR_UNKNOWN_ID);
    assert_non_null(strstr(pgem_last_error(graph), "99"));
    double inf_pose[3] = {0.0, 0.0, -(double)INFINITY}, stored[3];
    assert_int_equal(pgem_set_pose(graph, 2, inf_pose), PGEM_ERR_NOT_FINITE);
    assert_string_equal(pgem_last_error(graph), "pose: field theta is not finite (pose id 2)");
    assert_int_equal(pgem_pose(graph, 2, stored), PGEM_OK);
    assert_memory_equal(stored, identity_2d, sizeof stored);
    pgem_destroy(graph);
}

static void test_quaternion_checks(void **state)
{
    (void)state;
    pgem_t *graph = test_create(3, 4, 4);
    double slightly_off[7] = {1, 2, 3, 0, 0, 0, 1.001};
    assert_int_equal(pgem_add_pose(graph, 1, slightly_off), PGEM_OK);
    double stored[7];
    assert_int_equal(pgem_pose(graph, 1, stored), PGEM_OK);
    assert_near(stored[6], 1.0, 1e-15); /* normalised */
    double zero_quaternion[7] = {0, 0, 0, 0, 0, 0, 0};
    assert_int_equal(pgem_add_pose(graph, 2, zero_quaternion), PGEM_ERR_ROTATION);
    assert_non_null(strstr(pgem_last_error(graph), "quaternion"));
    assert_int_equal(pgem_pose_count(graph), 1);
    pgem_destroy(graph);
}

/* Edge inputs: each bad one is rejected with a message naming the ids, graph unchanged. */
static void test_edge_errors_change_nothing(void **state)
{
    (void)state;
    pgem_t *graph = test_create(2, 4, 2);
    double z[3] = {1, 0, 0}, information[9];
    test_diagonal_information(3, 1.0, information);
    assert_int_equal(pgem_add_pose(graph, 10, identity_2d), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 11, identity_2d), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 10, 12, z, information, PGEM_EDGE_LOOP, NULL), PGEM_ERR_UNKNOWN_ID);
    assert_non_null(strstr(pgem_last_error(graph), "no pose with id 12 (edge 10 -> 12)"));
    assert_int_equal(pgem_add_edge(graph, 10, 10, z, information, PGEM_EDGE_LOOP, NULL), PGEM_ERR_SELF_LOOP);
    assert_non_null(strstr(pgem_last_error(graph), "10 -> 10"));
    double bad_z[3] = {1, (double)INFINITY, 0};
    assert_int_equal(pgem_add_edge(graph, 10, 11, bad_z, information, PGEM_EDGE_LOOP, NULL), PGEM_ERR_NOT_FINITE);
    assert_non_null(strstr(pgem_last_error(graph), "measurement: field y"));
    double asymmetric[9] = {1, 0.5, 0, 0, 1, 0, 0, 0, 1};
    assert_int_equal(pgem_add_edge(graph, 10, 11, z, asymmetric, PGEM_EDGE_LOOP, NULL), PGEM_ERR_INFORMATION);
    assert_non_null(strstr(pgem_last_error(graph), "symmetric"));
    double indefinite[9] = {1, 2, 0, 2, 1, 0, 0, 0, 1};
    assert_int_equal(pgem_add_edge(graph, 10, 11, z, indefinite, PGEM_EDGE_LOOP, NULL), PGEM_ERR_INFORMATION);
    assert_non_null(strstr(pgem_last_error(graph), "positive definite"));
    double nan_info[9] = {1, 0, 0, 0, (double)NAN, 0, 0, 0, 1};
    assert_int_equal(pgem_add_edge(graph, 10, 11, z, nan_info, PGEM_EDGE_LOOP, NULL), PGEM_ERR_NOT_FINITE);
    assert_non_null(strstr(pgem_last_error(graph), "information(1,1)"));
    assert_int_equal(pgem_add_edge(graph, 10, 11, z, information, (pgem_edge_kind_t)7, NULL), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_edge_count(graph), 0);
    uint32_t index = 99;
    assert_int_equal(pgem_add_edge(graph, 10, 11, z, information, PGEM_EDGE_ODOMETRY, &index), PGEM_OK);
    assert_int_equal(index, 0);
    assert_int_equal(pgem_add_edge(graph, 11, 10, z, information, PGEM_EDGE_LOOP, &index), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 11, 10, z, information, PGEM_EDGE_LOOP, &index), PGEM_ERR_CAPACITY);
    assert_non_null(strstr(pgem_last_error(graph), "max_edges = 2"));
    assert_int_equal(pgem_edge_count(graph), 2);
    pgem_edge_view_t view;
    assert_int_equal(pgem_edge_at(graph, 1, &view), PGEM_OK);
    assert_true(view.from == 11 && view.to == 10 && view.kind == PGEM_EDGE_LOOP);
    assert_near(view.weight, 1.0, 0.0);
    assert_int_equal(pgem_edge_at(graph, 2, &view), PGEM_ERR_INVALID_ARGUMENT);
    pgem_destroy(graph);
}

/* Issue 17: one finite but huge loop closure (dx = 1e160) made every later solve's chi2
 * infinite, so nothing solved again. Translations beyond PGEM_TRANSLATION_LIMIT and
 * information entries beyond PGEM_INFORMATION_LIMIT are refused by name, changing nothing;
 * at the limits a graph still solves, and EM prunes the most extreme loop it can be given. */
static void test_magnitude_limits(void **state)
{
    (void)state;
    const double past = nextafter(PGEM_TRANSLATION_LIMIT, (double)INFINITY);
    double information[9], z[3] = {1, 0, 0}, stored[3];
    test_diagonal_information(3, 1.0, information);
    pgem_t *graph = test_create(2, 8, 8);
    const double far_pose[3] = {0.0, -past, 0.0};
    assert_int_equal(pgem_add_pose(graph, 3, far_pose), PGEM_ERR_OUT_OF_RANGE);
    assert_string_equal(pgem_last_error(graph), "pose: field y is beyond the translation limit "
                                                "(|x|, |y|, |z| at most 1e8 m, "
                                                "PGEM_TRANSLATION_LIMIT) (pose id 3)");
    assert_int_equal(pgem_pose_count(graph), 0);
    const double at_limit[3] = {PGEM_TRANSLATION_LIMIT, -PGEM_TRANSLATION_LIMIT, 1e300};
    assert_int_equal(pgem_add_pose(graph, 9, at_limit), PGEM_OK); /* angles are wrapped */
    const double moved[3] = {past, 0.0, 0.0};
    assert_int_equal(pgem_set_pose(graph, 9, moved), PGEM_ERR_OUT_OF_RANGE);
    assert_int_equal(pgem_pose(graph, 9, stored), PGEM_OK);
    assert_true(stored[0] == at_limit[0] && stored[1] == at_limit[1]);
    pgem_destroy(graph);

    graph = test_create(2, 8, 8);
    for (pgem_id_t id = 0; id < 5; id++) {
        const double pose[3] = {(double)id, 0.0, 0.0};
        assert_int_equal(pgem_add_pose(graph, id, pose), PGEM_OK);
    }
    for (pgem_id_t id = 0; id < 4; id++) {
        assert_int_equal(pgem_add_edge(graph, id, id + 1, z, information, PGEM_EDGE_ODOMETRY,
                                       NULL), PGEM_OK);
    }
    const double huge_loop[3] = {1e160, 0.0, 0.0};
    assert_int_equal(pgem_add_edge(graph, 4, 0, huge_loop, information, PGEM_EDGE_LOOP, NULL),
                     PGEM_ERR_OUT_OF_RANGE);
    assert_string_equal(pgem_last_error(graph),
                        "measurement: field x is beyond the translation limit (|x|, |y|, |z| at "
                        "most 1e8 m, PGEM_TRANSLATION_LIMIT) (edge 4 -> 0)");
    double strong[9];
    test_diagonal_information(3, nextafter(PGEM_INFORMATION_LIMIT, (double)INFINITY), strong);
    assert_int_equal(pgem_add_edge(graph, 4, 0, z, strong, PGEM_EDGE_LOOP, NULL),
                     PGEM_ERR_OUT_OF_RANGE);
    assert_string_equal(pgem_last_error(graph),
                        "information(0,0) is beyond the information limit (|entry| at most 1e15, "
                        "PGEM_INFORMATION_LIMIT) (edge 4 -> 0)");
    assert_int_equal(pgem_edge_count(graph), 4);
    /* the worst loop closure within the limits: the solves stay finite, and EM prunes it */
    test_diagonal_information(3, PGEM_INFORMATION_LIMIT, strong);
    const double worst[3] = {PGEM_TRANSLATION_LIMIT, -PGEM_TRANSLATION_LIMIT, 3.0};
    assert_int_equal(pgem_add_edge(graph, 4, 0, worst, strong, PGEM_EDGE_LOOP, NULL), PGEM_OK);
    assert_true(isfinite(pgem_total_chi2(graph)));
    pgem_robust_options_t options = {0};
    options.kernel = PGEM_KERNEL_EM;
    pgem_robust_summary_t summary;
    assert_int_equal(pgem_robust_optimize(graph, &options, NULL, &summary), PGEM_OK);
    assert_true(isfinite(summary.initial_chi2) && summary.final_chi2 < 1e-12);
    assert_int_equal(summary.pruned, 1);
    pgem_edge_view_t view;
    assert_int_equal(pgem_edge_at(graph, 4, &view), PGEM_OK);
    assert_false(view.active);
    pgem_destroy(graph);
}

/* The checks a caller can run before adding: the same verdicts, the offending value's place. */
static void test_pose_and_information_checks(void **state)
{
    (void)state;
    int field = 99;
    const double good3[7] = {1e8, -1e8, 1e8, 0, 0, 0, 1};
    assert_int_equal(pgem_pose_check(good3, 3, &field), PGEM_OK);
    assert_int_equal(field, -1);
    const double far3[7] = {0, 0, -2e8, 0, 0, 0, 1};
    assert_int_equal(pgem_pose_check(far3, 3, &field), PGEM_ERR_OUT_OF_RANGE);
    assert_int_equal(field, 2);
    const double nan3[7] = {2e8, 0, 0, (double)NAN, 0, 0, 1}; /* NaN is reported first */
    assert_int_equal(pgem_pose_check(nan3, 3, &field), PGEM_ERR_NOT_FINITE);
    assert_int_equal(field, 3);
    const double half3[7] = {0, 0, 0, 0, 0, 0, 0.5};
    assert_int_equal(pgem_pose_check(half3, 3, &field), PGEM_ERR_ROTATION);
    assert_int_equal(field, 3);
    const double huge_q[7] = {0, 0, 0, 1e200, 1e200, 0, 0}; /* its norm overflows */
    assert_int_equal(pgem_pose_check(huge_q, 3, NULL), PGEM_ERR_ROTATION);
    const double far2[3] = {0, 1e9, 0};
    assert_int_equal(pgem_pose_check(far2, 2, &field), PGEM_ERR_OUT_OF_RANGE);
    assert_int_equal(field, 1);
    assert_int_equal(pgem_pose_check(far2, 4, &field), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_pose_check(NULL, 2, &field), PGEM_ERR_INVALID_ARGUMENT);
    double m[9] = {1, 0, 0, 0, 1, -2e15, 0, -2e15, 1};
    int entry = -1;
    assert_int_equal(pgem_information_check(m, 3, &entry), PGEM_ERR_OUT_OF_RANGE);
    assert_int_equal(entry, 5);
    m[5] = m[7] = (double)INFINITY; /* not finite comes first */
    assert_int_equal(pgem_information_check(m, 3, &entry), PGEM_ERR_NOT_FINITE);
    assert_int_equal(entry, 5);
}

static void test_error_names(void **state)
{
    (void)state;
    assert_string_equal(pgem_error_name(PGEM_ERR_CAPACITY), "PGEM_ERR_CAPACITY");
    assert_string_equal(pgem_error_name(12345), "PGEM_ERR_UNKNOWN_CODE");
    for (int code = 0; code >= PGEM_ERR_NO_FACTOR; code--) {
        if (code == PGEM_ERR_IO || code == PGEM_ERR_PARSE) {
            continue; /* lib/io's codes, below */
        }
        assert_string_not_equal(pgem_error_name(code), "PGEM_ERR_UNKNOWN_CODE");
        assert_true(strlen(pgem_error_description(code)) > 3);
        assert_string_equal(pgem_io_error_name(code), pgem_error_name(code));
    }
}

/* The core's enum holds only what the core returns: lib/io's two codes kept their values
 * (-17, -18) in pgem_io_error_t, and only pgem_io_error_name knows them. */
static void test_io_error_codes(void **state)
{
    (void)state;
    assert_int_equal(PGEM_ERR_IO, -17);
    assert_int_equal(PGEM_ERR_PARSE, -18);
    assert_string_equal(pgem_error_name(PGEM_ERR_IO), "PGEM_ERR_UNKNOWN_CODE");
    assert_string_equal(pgem_error_name(PGEM_ERR_PARSE), "PGEM_ERR_UNKNOWN_CODE");
    assert_string_equal(pgem_io_error_name(PGEM_ERR_IO), "PGEM_ERR_IO");
    assert_string_equal(pgem_io_error_name(PGEM_ERR_PARSE), "PGEM_ERR_PARSE");
    assert_string_equal(pgem_io_error_description(PGEM_ERR_PARSE),
                        "a line of a graph file is malformed");
    assert_string_equal(pgem_io_error_name(12345), "PGEM_ERR_UNKNOWN_CODE");
}

static void test_chi2_of_edges(void **state)
{
    (void)state;
    pgem_t *graph = test_create(2, 2, 1);
    double a[3] = {0, 0, 0}, b[3] = {1, 0, 0}, z[3] = {0.5, 0, 0}, information[9];
    test_diagonal_information(3, 4.0, information);
    assert_int_equal(pgem_add_pose(graph, 0, a), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 1, b), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 0, 1, z, information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    double chi2 = 0.0;
    assert_int_equal(pgem_edge_chi2(graph, 0, &chi2), PGEM_OK);
    assert_near(chi2, 4.0 * 0.25, 1e-12);
    assert_near(pgem_total_chi2(graph), 1.0, 1e-12);
    pgem_destroy(graph);
}

/* The public information check is the one pgem_add_edge applies, and says where it failed. */
static void test_information_check(void **state)
{
    (void)state;
    double m[9] = {4, 1, 0, 1, 3, 0, 0, 0, 2};
    int entry = 99;
    assert_int_equal(pgem_information_check(m, 3, &entry), PGEM_OK);
    assert_int_equal(entry, -1);
    m[5] = (double)NAN;
    assert_int_equal(pgem_information_check(m, 3, &entry), PGEM_ERR_NOT_FINITE);
    assert_int_equal(entry, 5);
    m[5] = 0.5; /* (1,2) = 0.5 but (2,1) = 0 */
    assert_int_equal(pgem_information_check(m, 3, &entry), PGEM_ERR_INFORMATION);
    assert_int_equal(entry, 1 * 3 + 2);
    double singular[9] = {1, 1, 0, 1, 1, 0, 0, 0, 1};
    assert_int_equal(pgem_information_check(singular, 3, NULL), PGEM_ERR_INFORMATION);
    assert_int_equal(pgem_information_check(singular, 3, &entry), PGEM_ERR_INFORMATION);
    assert_int_equal(entry, 1 * 3 + 1); /* second pivot */
    assert_int_equal(pgem_information_check(singular, 4, &entry), PGEM_ERR_INVALID_ARGUMENT);
    /* and pgem_add_edge refuses the same matrix with the same verdict */
    pgem_t *graph = test_create(2, 4, 4);
    const double pose[3] = {0, 0, 0}, z[3] = {1, 0, 0};
    assert_int_equal(pgem_add_pose(graph, 0, pose), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 1, pose), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 0, 1, z, singular, PGEM_EDGE_ODOMETRY, NULL), PGEM_ERR_INFORMATION);
    assert_non_null(strstr(pgem_last_error(graph), "pivot 1"));
    pgem_destroy(graph);
}

/* PGEM_MEMORY_BOUND is an upper bound of pgem_memory_size, and not a loose one: within the id
 * map's slack (8 bytes per pose), CSparse's pool when it is the system library (56 per pose, 24
 * per edge) and a constant. */
/* The block by part: the parts sum to pgem_memory_size; capacities grow the parts that hold
 * them (poses and edges: graph, solver, robust, linalg), the fill budget only linalg's factor
 * (8 bytes per value and 4 per block of values in 2D). */
static void test_memory_parts(void **state)
{
    (void)state;
    pgem_config_t config = {2, 1000, 1500, 90000, 1, 0};
    pgem_memory_parts_t parts, more_poses, more_fill;
    assert_int_equal(pgem_memory_layout(&config, &parts), PGEM_OK);
    assert_int_equal(parts.total, pgem_memory_size(&config));
    assert_int_equal(parts.total, parts.instance + parts.graph + parts.solver + parts.robust +
                                      parts.linalg);
    assert_true(parts.factor + parts.csparse_pool < parts.linalg);
    assert_true(parts.instance >= 16u && parts.instance < 4096u);
    /* solver: two estimates of 3 doubles per pose; robust: one estimate, 18 bytes per edge */
    assert_int_equal(parts.solver, 2u * 1000u * 3u * sizeof(double));
    assert_true(parts.robust >= 1000u * 3u * sizeof(double) + 1500u * 18u);
    pgem_config_t bigger = config;
    bigger.max_poses = 2000;
    assert_int_equal(pgem_memory_layout(&bigger, &more_poses), PGEM_OK);
    assert_true(more_poses.graph > parts.graph && more_poses.solver == 2u * parts.solver);
    assert_true(more_poses.linalg > parts.linalg);
    assert_int_equal(more_poses.factor, parts.factor);
    pgem_config_t fuller = config;
    fuller.fill_budget = 90000u + 9u * 1600u;
    assert_int_equal(pgem_memory_layout(&fuller, &more_fill), PGEM_OK);
    assert_int_equal(more_fill.factor - parts.factor, 9u * 1600u * 8u + 1600u * 4u);
    assert_int_equal(more_fill.linalg - parts.linalg, more_fill.factor - parts.factor);
    assert_int_equal(more_fill.graph, parts.graph);
    pgem_config_t invalid = config;
    invalid.dimension = 4;
    assert_int_equal(pgem_memory_layout(&invalid, &parts), PGEM_ERR_CONFIG);
    assert_int_equal(pgem_memory_layout(NULL, &parts), PGEM_ERR_INVALID_ARGUMENT);
}

static void test_memory_bound(void **state)
{
    (void)state;
    const uint32_t poses[] = {1, 2, 7, 8, 9, 31, 100, 250, 500, 512, 513, 1000, 1023, 1025, 4097,
                              20000};
    for (int dimension = 2; dimension <= 3; dimension++) {
        for (size_t k = 0; k < sizeof poses / sizeof poses[0]; k++) {
            const uint32_t n = poses[k];
            const uint32_t edge_counts[] = {1, n, 3 * n + 7};
            for (int e = 0; e < 3; e++) {
                const uint32_t m = edge_counts[e];
                const uint32_t fills[] = {1, 9, 36, 17 * n + 5, 40 * n};
                for (int f = 0; f < 5; f++) {
                    pgem_config_t config = {dimension, n, m, fills[f], 0, 0};
                    size_t exact = pgem_memory_size(&config);
                    size_t bound = PGEM_MEMORY_BOUND(dimension, n, m, fills[f]);
                    assert_true(exact > 0);
                    assert_true(bound >= exact);
                    /* the bound holds the x86 builds' dense workspace floor (32 doubles per
                     * column of a 128-column product); other builds need a quarter of it */
                    const size_t unknowns = (size_t)n * (dimension == 3 ? 6u : 3u);
                    const size_t floor_slack = 8u * 24u * (unknowns < 128u ? unknowns : 128u);
                    assert_true(bound - exact <= 64u * n + 24u * m + 2400u + floor_slack);
                }
            }
        }
    }
}

/* Issue 31, row 9 (g): diag(1e15, 1e15, 1e-3) is positive definite, but its condition number
 * (1e18) is beyond what double precision factors (pivots below n * DBL_EPSILON of the
 * largest entry are rounding noise): refused, and the message says so rather than calling it
 * "not positive definite". A pivot at or below zero is still "not positive definite". */
static void test_information_badly_conditioned(void **state)
{
    (void)state;
    double m[9] = {1e15, 0, 0, 0, 1e15, 0, 0, 0, 1e-3};
    int entry = -1;
    assert_int_equal(pgem_information_check(m, 3, &entry), PGEM_ERR_INFORMATION);
    assert_int_equal(entry, 2 * 3 + 2);
    assert_int_equal(pgem_information_positive(m, 3), 1);
    pgem_t *graph = test_create(2, 4, 4);
    const double pose[3] = {0, 0, 0}, z[3] = {1, 0, 0};
    assert_int_equal(pgem_add_pose(graph, 0, pose), PGEM_OK);
    assert_int_equal(pgem_add_pose(graph, 1, pose), PGEM_OK);
    assert_int_equal(pgem_add_edge(graph, 0, 1, z, m, PGEM_EDGE_LOOP, NULL), PGEM_ERR_INFORMATION);
    assert_string_equal(pgem_last_error(graph),
                        "information is positive definite but too badly conditioned for "
                        "double precision (pivot 2 below n * DBL_EPSILON of the largest "
                        "entry: condition number beyond about 1e15) (edge 0 -> 1)");
    m[8] = -1e-3;
    assert_int_equal(pgem_information_positive(m, 3), 0);
    assert_int_equal(pgem_add_edge(graph, 0, 1, z, m, PGEM_EDGE_LOOP, NULL), PGEM_ERR_INFORMATION);
    assert_non_null(strstr(pgem_last_error(graph),
                           "information is not positive definite (pivot 2 is not positive)"));
    assert_int_equal(pgem_edge_count(graph), 0);
    pgem_destroy(graph);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_config_defaults),
        cmocka_unit_test(test_memory_bound),
        cmocka_unit_test(test_memory_parts),
        cmocka_unit_test(test_memory_grows_with_capacity),
        cmocka_unit_test(test_init_in_static_buffer),
        cmocka_unit_test(test_pose_ids_64bit),
        cmocka_unit_test(test_pose_errors_change_nothing),
        cmocka_unit_test(test_quaternion_checks),
        cmocka_unit_test(test_edge_errors_change_nothing),
        cmocka_unit_test(test_magnitude_limits),
        cmocka_unit_test(test_pose_and_information_checks),
        cmocka_unit_test(test_error_names),
        cmocka_unit_test(test_io_error_codes),
        cmocka_unit_test(test_chi2_of_edges),
        cmocka_unit_test(test_information_check),
        cmocka_unit_test(test_information_badly_conditioned),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
