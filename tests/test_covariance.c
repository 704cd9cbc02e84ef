/* The covariance calls (pgem/covariance.h) through the public header, against a dense
 * reference built here: H = sum over edges of w J^T Omega J from the geometry's Jacobians
 * (pgem_se2_error, pgem_se3_error) at the optimized estimate, inverted densely, then moved to
 * the tangent on the right of each pose (2D: the translation rotated into the pose's frame).
 * 2D and 3D, one pose, two poses, every pose; held poses zero; NO_FACTOR before
 * pgem_covariance_prepare and after anything that changes the graph. pgem_update_covariance
 * (the incremental factor's) against pgem_covariance once the updates have converged. */
#include "test_util.h"

#define MAX_POSES 40
#define MAX_N (MAX_POSES * 6)

/* In-place inverse of a symmetric positive definite matrix (Gauss-Jordan, no pivoting). */
static void dense_inverse(double *a, int n)
{
    for (int k = 0; k < n; k++) {
        const double pivot = a[k * n + k];
        assert_true(pivot > 0.0);
        for (int j = 0; j < n; j++) {
            a[k * n + j] /= pivot;
        }
        a[k * n + k] = 1.0 / pivot;
        for (int i = 0; i < n; i++) {
            if (i == k) {
                continue;
            }
            const double factor = a[i * n + k];
            for (int j = 0; j < n; j++) {
                a[i * n + j] -= factor * a[k * n + j];
            }
            a[i * n + k] = -factor * a[k * n + k];
        }
    }
}

/* Dense H over the free poses (pose p > 0 at rows (p - 1) * b ..., pose 0 held) into h. */
static void dense_h(const pgem_t *graph, double *h)
{
    const int dim = pgem_dimension(graph), b = PGEM_TANGENT_SIZE(dim);
    const int n = ((int)pgem_pose_count(graph) - 1) * b;
    memset(h, 0, (size_t)(n * n) * sizeof(double));
    for (uint32_t k = 0; k < pgem_edge_count(graph); k++) {
        pgem_edge_view_t edge;
        assert_int_equal(pgem_edge_at(graph, k, &edge), PGEM_OK);
        uint32_t ends[2];
        double poses[2][7], e[6], jacobians[2][36];
        assert_int_equal(pgem_pose_index(graph, edge.from, &ends[0]), PGEM_OK);
        assert_int_equal(pgem_pose_index(graph, edge.to, &ends[1]), PGEM_OK);
        for (int s = 0; s < 2; s++) {
            assert_int_equal(pgem_pose_at(graph, ends[s], NULL, poses[s], NULL), PGEM_OK);
        }
        if (dim == 2) {
            pgem_se2_error(poses[0], poses[1], edge.measurement, e, jacobians[0], jacobians[1]);
        } else {
            pgem_se3_error(poses[0], poses[1], edge.measurement, e, jacobians[0], jacobians[1]);
        }
        for (int s = 0; s < 2; s++) {
            for (int t = 0; t < 2; t++) {
                if (ends[s] == 0u || ends[t] == 0u) {
                    continue;
                }
                const int row = ((int)ends[s] - 1) * b, col = ((int)ends[t] - 1) * b;
                for (int i = 0; i < b; i++) {
                    for (int j = 0; j < b; j++) {
                        double sum = 0.0;
                        for (int m = 0; m < b; m++) {
                            for (int l = 0; l < b; l++) {
                                sum += jacobians[s][m * b + i] * edge.information[m * b + l] *
                                       jacobians[t][l * b + j];
                            }
                        }
                        h[(row + i) * n + col + j] += edge.weight * sum;
                    }
                }
            }
        }
    }
}

/* The dense reference of the joint covariance of poses p and q (indices, p, q > 0) in the
 * tangent on the right: T Sigma T^T with T = R^T on each 2D translation. */
static void reference(const pgem_t *graph, const double *inverse, uint32_t p, uint32_t q,
                      double *out)
{
    const int dim = pgem_dimension(graph), b = PGEM_TANGENT_SIZE(dim);
    const int n = ((int)pgem_pose_count(graph) - 1) * b;
    const uint32_t poses[2] = {p, q};
    double t[12 * 12] = {0}, sigma[12 * 12] = {0};
    for (int s = 0; s < 2; s++) {
        for (int u = 0; u < 2; u++) {
            for (int i = 0; i < b; i++) {
                for (int j = 0; j < b; j++) {
                    sigma[(s * b + i) * 12 + u * b + j] =
                        inverse[(((int)poses[s] - 1) * b + i) * n + ((int)poses[u] - 1) * b + j];
                }
            }
        }
        for (int i = 0; i < b; i++) {
            t[(s * b + i) * 12 + s * b + i] = 1.0;
        }
        if (dim == 2) {
            double pose[3];
            assert_int_equal(pgem_pose_at(graph, poses[s], NULL, pose, NULL), PGEM_OK);
            const double c = cos(pose[2]), si = sin(pose[2]);
            t[(s * b) * 12 + s * b] = c;
            t[(s * b) * 12 + s * b + 1] = si;
            t[(s * b + 1) * 12 + s * b] = -si;
            t[(s * b + 1) * 12 + s * b + 1] = c;
        }
    }
    for (int i = 0; i < 2 * b; i++) {
        for (int j = 0; j < 2 * b; j++) {
            double sum = 0.0;
            for (int m = 0; m < 2 * b; m++) {
                for (int l = 0; l < 2 * b; l++) {
                    sum += t[i * 12 + m] * sigma[m * 12 + l] * t[j * 12 + l];
                }
            }
            out[i * 2 * b + j] = sum;
        }
    }
}

/* A 3D chain of n poses with a loop closure every 5 poses back 7. */
static void build_3d(pgem_t *graph, int n)
{
    double information[36];
    test_diagonal_information(6, 40.0, information);
    for (int k = 3; k < 6; k++) {
        information[k * 6 + k] = 400.0;
    }
    information[1] = information[6] = 3.0; /* not diagonal */
    double truth[7 * MAX_POSES];
    test_rng_t rng = {11};
    for (int k = 0; k < n; k++) {
        const double tangent[6] = {0.5 * k, 2.0 * sin(0.3 * k), 0.1 * k, 0.05 * k, 0.1, 0.2 * cos(0.2 * k)};
        pgem_se3_exp(tangent, truth + 7 * k);
        double guess[7], noise[6];
        for (int d = 0; d < 6; d++) {
            noise[d] = 0.05 * test_gaussian(&rng);
        }
        pgem_se3_boxplus(truth + 7 * k, noise, guess);
        assert_int_equal(pgem_add_pose(graph, (pgem_id_t)(100 + k), guess), PGEM_OK);
        for (int back = 1; back <= (k % 5 == 0 ? 7 : 1) && back <= k; back += 6) {
            double z[7];
            pgem_se3_between(truth + 7 * (k - back), truth + 7 * k, z);
            for (int d = 0; d < 6; d++) {
                noise[d] = 0.01 * test_gaussian(&rng);
            }
            pgem_se3_boxplus(z, noise, z);
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(100 + k - back), (pgem_id_t)(100 + k),
                                           z, information,
                                           back == 1 ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP, NULL),
                             PGEM_OK);
        }
    }
}

/* Every call against the dense reference, on the optimized graph. */
static void check_against_dense(pgem_t *graph)
{
    static double h[MAX_N * MAX_N];
    static double all[MAX_POSES * 36];
    const int dim = pgem_dimension(graph), b = PGEM_TANGENT_SIZE(dim);
    const uint32_t count = pgem_pose_count(graph);
    assert_true(count <= MAX_POSES);
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    double got[144], expected[144];
    pgem_id_t first = 0, id_p = 0, id_q = 0;
    assert_int_equal(pgem_pose_at(graph, 0, &first, NULL, NULL), PGEM_OK);
    assert_int_equal(pgem_covariance(graph, first, got), PGEM_ERR_NO_FACTOR);
    assert_contains(pgem_last_error(graph), "pgem_covariance_prepare");
    assert_int_equal(pgem_covariances(graph, all), PGEM_ERR_NO_FACTOR);
    assert_int_equal(pgem_covariance_prepare(graph), PGEM_OK);
    dense_h(graph, h);
    dense_inverse(h, ((int)count - 1) * b);
    double scale = 0.0;
    for (int i = 0; i < ((int)count - 1) * b; i++) {
        scale = fmax(scale, fabs(h[i * ((int)count - 1) * b + i]));
    }
    const double tolerance = 1e-9 * scale;
    /* one pose and two poses by solves; a held pose is zero */
    const uint32_t pairs[4][2] = {{1, 2}, {count - 1, 1}, {count / 2, count / 2 + 3}, {5, 5}};
    for (int k = 0; k < 4; k++) {
        const uint32_t p = pairs[k][0], q = pairs[k][1];
        assert_int_equal(pgem_pose_at(graph, p, &id_p, NULL, NULL), PGEM_OK);
        assert_int_equal(pgem_pose_at(graph, q, &id_q, NULL, NULL), PGEM_OK);
        reference(graph, h, p, q, expected);
        assert_int_equal(pgem_covariance(graph, id_p, got), PGEM_OK);
        for (int i = 0; i < b; i++) {
            for (int j = 0; j < b; j++) {
                assert_near(got[i * b + j], expected[i * 2 * b + j], tolerance);
            }
        }
        assert_int_equal(pgem_joint_covariance(graph, id_p, id_q, got), PGEM_OK);
        for (int i = 0; i < 4 * b * b; i++) {
            assert_near(got[i], expected[i], tolerance);
        }
    }
    assert_int_equal(pgem_covariance(graph, first, got), PGEM_OK);
    for (int i = 0; i < b * b; i++) {
        assert_true(got[i] == 0.0);
    }
    assert_int_equal(pgem_covariance(graph, 999999, got), PGEM_ERR_UNKNOWN_ID);
    assert_string_equal(pgem_last_error(graph), "no pose with id 999999");
    /* every pose in one pass, then single and joint calls from the inverse */
    assert_int_equal(pgem_covariances(graph, all), PGEM_OK);
    for (uint32_t p = 1; p < count; p++) {
        reference(graph, h, p, p, expected);
        for (int i = 0; i < b; i++) {
            for (int j = 0; j < b; j++) {
                assert_near(all[p * (uint32_t)(b * b) + (uint32_t)(i * b + j)], expected[i * 2 * b + j], tolerance);
            }
        }
    }
    for (int i = 0; i < b * b; i++) {
        assert_true(all[i] == 0.0);
    }
    assert_int_equal(pgem_pose_at(graph, 3, &id_p, NULL, NULL), PGEM_OK);
    assert_int_equal(pgem_pose_at(graph, count - 2, &id_q, NULL, NULL), PGEM_OK);
    assert_int_equal(pgem_covariance(graph, id_p, got), PGEM_OK);
    assert_memory_equal(got, all + 3 * b * b, (size_t)(b * b) * sizeof(double));
    reference(graph, h, 3, count - 2, expected);
    assert_int_equal(pgem_joint_covariance(graph, id_p, id_q, got), PGEM_OK);
    for (int i = 0; i < 4 * b * b; i++) {
        assert_near(got[i], expected[i], tolerance);
    }
    /* a moved pose makes the factor old */
    double pose[7];
    assert_int_equal(pgem_pose(graph, id_p, pose), PGEM_OK);
    assert_int_equal(pgem_set_pose(graph, id_p, pose), PGEM_OK);
    assert_int_equal(pgem_covariance(graph, id_p, got), PGEM_ERR_NO_FACTOR);
}

static void test_covariance_2d(void **state)
{
    (void)state;
    static double truth[3 * MAX_POSES];
    pgem_t *graph = test_create(2, MAX_POSES, 4 * MAX_POSES);
    test_ring_2d(graph, 30, 4, 0.05, 0.02, 5, truth);
    check_against_dense(graph);
    pgem_destroy(graph);
}

static void test_covariance_3d(void **state)
{
    (void)state;
    pgem_t *graph = test_create(3, MAX_POSES, 4 * MAX_POSES);
    build_3d(graph, 24);
    check_against_dense(graph);
    pgem_destroy(graph);
}

/* NO_FACTOR whenever the graph changed since the factor: a solve, a new pose, a reset. */
static void test_no_factor(void **state)
{
    (void)state;
    static double truth[3 * 20];
    pgem_t *graph = test_create(2, 21, 60);
    test_ring_2d(graph, 20, 5, 0.05, 0.02, 7, truth);
    double out[36];
    assert_int_equal(pgem_covariance(graph, 3, out), PGEM_ERR_NO_FACTOR);
    assert_int_equal(pgem_joint_covariance(graph, 3, 4, out), PGEM_ERR_NO_FACTOR);
    assert_contains(pgem_last_error(graph), "no factor is current");
    assert_string_equal(pgem_error_name(PGEM_ERR_NO_FACTOR), "PGEM_ERR_NO_FACTOR");
    assert_int_equal(pgem_covariance_prepare(graph), PGEM_OK); /* before a solve: fine */
    assert_int_equal(pgem_covariance(graph, 3, out), PGEM_OK);
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    assert_int_equal(pgem_covariance(graph, 3, out), PGEM_ERR_NO_FACTOR);
    assert_int_equal(pgem_covariance_prepare(graph), PGEM_OK);
    pgem_robust_reset(graph);
    assert_int_equal(pgem_covariance(graph, 3, out), PGEM_ERR_NO_FACTOR);
    assert_int_equal(pgem_covariance_prepare(graph), PGEM_OK);
    const double pose[3] = {1.0, 2.0, 0.0};
    assert_int_equal(pgem_add_pose(graph, 50, pose), PGEM_OK);
    assert_int_equal(pgem_covariance(graph, 3, out), PGEM_ERR_NO_FACTOR);
    /* pose 50 has no edge: its part has no held pose */
    assert_int_equal(pgem_covariance_prepare(graph), PGEM_ERR_NOT_POSITIVE_DEFINITE);
    assert_int_equal(pgem_covariance(graph, 3, out), PGEM_ERR_NO_FACTOR);
    assert_int_equal(pgem_covariance(NULL, 3, out), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_covariance(graph, 3, NULL), PGEM_ERR_INVALID_ARGUMENT);
    pgem_destroy(graph);
}

/* A pose fixed in the middle: zero, and the others still match the joint's blocks. */
static void test_fixed_pose_is_zero(void **state)
{
    (void)state;
    static double truth[3 * 20];
    pgem_t *graph = test_create(2, 20, 60);
    test_ring_2d(graph, 20, 5, 0.05, 0.02, 9, truth);
    assert_int_equal(pgem_fix_pose(graph, 0, 1), PGEM_OK);
    assert_int_equal(pgem_fix_pose(graph, 10, 1), PGEM_OK);
    assert_int_equal(pgem_covariance_prepare(graph), PGEM_OK);
    double one[9], joint[36], all[20 * 9];
    assert_int_equal(pgem_covariance(graph, 10, one), PGEM_OK);
    for (int i = 0; i < 9; i++) {
        assert_true(one[i] == 0.0);
    }
    assert_int_equal(pgem_joint_covariance(graph, 10, 4, joint), PGEM_OK);
    assert_int_equal(pgem_covariance(graph, 4, one), PGEM_OK);
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) {
            assert_true(joint[i * 6 + j] == 0.0 && joint[i * 6 + 3 + j] == 0.0);
            assert_near(joint[(3 + i) * 6 + 3 + j], one[i * 3 + j], 1e-12);
        }
    }
    assert_int_equal(pgem_covariances(graph, all), PGEM_OK);
    for (int i = 0; i < 9; i++) {
        assert_true(all[10 * 9 + i] == 0.0);
        assert_near(all[4 * 9 + i], one[i], 1e-12);
    }
    pgem_destroy(graph);
}

/* An instance with room for the incremental factor. */
static pgem_t *create_online(int dimension, uint32_t poses)
{
    const uint32_t b = (uint32_t)PGEM_TANGENT_SIZE(dimension);
    pgem_config_t config = {dimension, poses, 4u * poses, 0, 0, 64u * b * b * poses};
    pgem_t *graph = NULL;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    return graph;
}

/* The incremental factor's marginals against the batch ones: updates that relinearise every
 * pose each time until they converge (the factor's points are then the estimate), for the
 * newest pose (the root of the tree: one block), one in the middle and the second (the longest
 * paths); the held first pose zero; NO_FACTOR after any other change. */
static void check_update_covariance(pgem_t *graph)
{
    const int b = PGEM_TANGENT_SIZE(pgem_dimension(graph));
    const uint32_t count = pgem_pose_count(graph);
    pgem_id_t first = 0, newest = 0;
    assert_int_equal(pgem_pose_at(graph, 0, &first, NULL, NULL), PGEM_OK);
    assert_int_equal(pgem_pose_at(graph, count - 1, &newest, NULL, NULL), PGEM_OK);
    double got[36], expected[36];
    assert_int_equal(pgem_update_covariance(graph, newest, got), PGEM_ERR_NO_FACTOR);
    assert_contains(pgem_last_error(graph), "incremental factor is not current");
    pgem_update_options_t options;
    memset(&options, 0, sizeof options);
    options.relinearize_threshold = -1.0;
    options.relinearize_skip = 1;
    options.wildfire_threshold = -1.0;
    for (int k = 0; k < 30; k++) {
        assert_int_equal(pgem_update(graph, &options, NULL), PGEM_OK);
    }
    assert_int_equal(pgem_covariance_prepare(graph), PGEM_OK); /* changes nothing of the graph */
    const uint32_t poses[3] = {count - 1, count / 2, 1};
    for (int k = 0; k < 3; k++) {
        pgem_id_t id = 0;
        assert_int_equal(pgem_pose_at(graph, poses[k], &id, NULL, NULL), PGEM_OK);
        assert_int_equal(pgem_update_covariance(graph, id, got), PGEM_OK);
        assert_int_equal(pgem_covariance(graph, id, expected), PGEM_OK);
        double scale = 0.0;
        for (int i = 0; i < b; i++) {
            scale = fmax(scale, expected[i * b + i]);
        }
        for (int i = 0; i < b * b; i++) {
            assert_near(got[i], expected[i], 1e-9 * scale);
        }
    }
    assert_int_equal(pgem_update_covariance(graph, first, got), PGEM_OK);
    for (int i = 0; i < b * b; i++) {
        assert_true(got[i] == 0.0);
    }
    assert_int_equal(pgem_update_covariance(graph, 999999, got), PGEM_ERR_UNKNOWN_ID);
    assert_int_equal(pgem_update_covariance(NULL, newest, got), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(pgem_update_covariance(graph, newest, NULL), PGEM_ERR_INVALID_ARGUMENT);
    /* a moved pose, then a solve: not current until the next update */
    double pose[7];
    assert_int_equal(pgem_pose(graph, newest, pose), PGEM_OK);
    assert_int_equal(pgem_set_pose(graph, newest, pose), PGEM_OK);
    assert_int_equal(pgem_update_covariance(graph, newest, got), PGEM_ERR_NO_FACTOR);
    assert_int_equal(pgem_update(graph, &options, NULL), PGEM_OK);
    assert_int_equal(pgem_update_covariance(graph, newest, got), PGEM_OK);
    assert_int_equal(pgem_optimize(graph, NULL, NULL), PGEM_OK);
    assert_int_equal(pgem_update_covariance(graph, newest, got), PGEM_ERR_NO_FACTOR);
    /* a pose no edge reaches: the update leaves it out of its factor */
    assert_int_equal(pgem_add_pose(graph, 777777, pose), PGEM_OK);
    assert_int_equal(pgem_update_covariance(graph, newest, got), PGEM_ERR_NO_FACTOR);
    assert_int_equal(pgem_update(graph, &options, NULL), PGEM_OK);
    assert_int_equal(pgem_update_covariance(graph, newest, got), PGEM_OK);
    assert_int_equal(pgem_update_covariance(graph, 777777, got), PGEM_ERR_NO_FACTOR);
    assert_contains(pgem_last_error(graph), "pose 777777 is not in the incremental factor");
}

static void test_update_covariance_2d(void **state)
{
    (void)state;
    static double truth[3 * MAX_POSES];
    pgem_t *graph = create_online(2, MAX_POSES);
    test_ring_2d(graph, 30, 4, 0.05, 0.02, 5, truth);
    check_update_covariance(graph);
    pgem_destroy(graph);
    graph = test_create(2, 4, 8); /* no room for the incremental factor */
    const double origin[3] = {0.0, 0.0, 0.0};
    double out[9];
    assert_int_equal(pgem_add_pose(graph, 0, origin), PGEM_OK);
    assert_int_equal(pgem_update_covariance(graph, 0, out), PGEM_ERR_CONFIG);
    assert_contains(pgem_last_error(graph), "online_fill");
    pgem_destroy(graph);
}

static void test_update_covariance_3d(void **state)
{
    (void)state;
    pgem_t *graph = create_online(3, MAX_POSES);
    build_3d(graph, 24);
    check_update_covariance(graph);
    pgem_destroy(graph);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_covariance_2d),
        cmocka_unit_test(test_covariance_3d),
        cmocka_unit_test(test_no_factor),
        cmocka_unit_test(test_fixed_pose_is_zero),
        cmocka_unit_test(test_update_covariance_2d),
        cmocka_unit_test(test_update_covariance_3d),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
