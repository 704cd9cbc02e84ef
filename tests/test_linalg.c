/* The linear-algebra layer against a dense reference: on random graphs (2D and 3D, chains with
 * random loop closures, a held pose), the assembled H applied to unit vectors gives the dense
 * matrix; the block Cholesky solve matches a dense solve; the sparse inverse on the factor's
 * pattern matches the dense inverse; the marginal A H^-1 A^T of two poses matches, by the
 * forward solve and by the inverse; and the supernodal factor L itself, entry by entry, is the
 * dense Cholesky factor of H, on random block patterns from a chain to nearly dense. */
#include "test_util.h"

#include "instance.h" /* the instance's linear system (graph->linear) */
#include "linalg/linear.h"

#define MAX_SCALARS 240

/* A graph of `poses` poses (a chain plus `loops` random loop closures), random estimate. */
static pgem_t *random_graph(int dimension, uint32_t poses, uint32_t loops, uint64_t seed)
{
    test_rng_t rng = {seed};
    const int n = dimension == 3 ? 6 : 3, size = dimension == 3 ? 7 : 3;
    pgem_t *graph = test_create(dimension, poses, poses + loops);
    double information[36];
    for (uint32_t p = 0; p < poses; p++) {
        double pose[7] = {test_uniform_in(&rng, -5, 5), test_uniform_in(&rng, -5, 5),
                          test_uniform_in(&rng, -3, 3), 1, 0, 0, 0};
        if (size == 3) {
            pose[2] = test_uniform_in(&rng, -3, 3);
        } else {
            pose[2] = test_uniform_in(&rng, -5, 5);
            pose[3] = test_uniform_in(&rng, -1, 1);
            pose[4] = test_uniform_in(&rng, -1, 1);
            pose[5] = test_uniform_in(&rng, -1, 1);
            pose[6] = test_uniform_in(&rng, 0.2, 1);
            const double norm = sqrt(pose[3] * pose[3] + pose[4] * pose[4] + pose[5] * pose[5] +
                                     pose[6] * pose[6]);
            for (int q = 3; q < 7; q++) {
                pose[q] /= norm;
            }
        }
        assert_int_equal(pgem_add_pose(graph, p, pose), PGEM_OK);
    }
    for (uint32_t k = 0; k + 1 < poses + loops; k++) {
        uint32_t a = k, b = k + 1;
        if (k + 1 >= poses) {
            a = (uint32_t)(test_next(&rng) % poses);
            do {
                b = (uint32_t)(test_next(&rng) % poses);
            } while (b == a);
        }
        double z[7] = {test_uniform_in(&rng, -1, 1), test_uniform_in(&rng, -1, 1),
                       test_uniform_in(&rng, -1, 1), 1, 0, 0, 0};
        if (size == 7) {
            z[2] = test_uniform_in(&rng, -1, 1);
            z[6] = 1.0;
            z[3] = test_uniform_in(&rng, -0.3, 0.3);
            z[6] = sqrt(1.0 - z[3] * z[3]);
        }
        /* a random positive definite information: diagonal plus a small symmetric coupling */
        for (int r = 0; r < n; r++) {
            for (int c = 0; c <= r; c++) {
                double value = r == c ? test_uniform_in(&rng, 5, 50) : test_uniform_in(&rng, -1, 1);
                information[r * n + c] = information[c * n + r] = value;
            }
        }
        assert_int_equal(pgem_add_edge(graph, a, b, z, information,
                                       k + 1 < poses ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP, NULL),
                         PGEM_OK);
    }
    return graph;
}

/* Dense H (count x count, permuted order) from pgem_linear_multiply on unit vectors. */
static void dense_h(pgem_t *graph, double *h)
{
    const int count = graph->linear->scalar_count;
    double unit[MAX_SCALARS], column[MAX_SCALARS];
    for (int j = 0; j < count; j++) {
        memset(unit, 0, sizeof unit);
        unit[j] = 1.0;
        pgem_linear_multiply(graph->linear, unit, column);
        for (int i = 0; i < count; i++) {
            h[i * count + j] = column[i];
        }
    }
}

/* In-place dense inverse of a symmetric positive definite matrix (Gauss-Jordan). */
static void dense_inverse(double *a, int count)
{
    static double work[MAX_SCALARS * 2 * MAX_SCALARS];
    const int width = 2 * count;
    for (int i = 0; i < count; i++) {
        for (int j = 0; j < count; j++) {
            work[i * width + j] = a[i * count + j];
            work[i * width + count + j] = i == j ? 1.0 : 0.0;
        }
    }
    for (int i = 0; i < count; i++) {
        double pivot = work[i * width + i];
        assert_true(pivot > 0.0);
        for (int j = 0; j < width; j++) {
            work[i * width + j] /= pivot;
        }
        for (int r = 0; r < count; r++) {
            if (r != i) {
                double factor = work[r * width + i];
                for (int j = 0; j < width; j++) {
                    work[r * width + j] -= factor * work[i * width + j];
                }
            }
        }
    }
    for (int i = 0; i < count; i++) {
        for (int j = 0; j < count; j++) {
            a[i * count + j] = work[i * width + count + j];
        }
    }
}

static double largest_magnitude(const double *values, int count)
{
    double largest = 0.0;
    for (int k = 0; k < count; k++) {
        largest = fmax(largest, fabs(values[k]));
    }
    return largest;
}

/* Analyses, assembles and factors; returns the scalar count. */
static int factor(pgem_t *graph)
{
    assert_int_equal(pgem_analyze(graph), PGEM_OK);
    (void)pgem_linear_assemble(graph->linear, &graph->store);
    assert_int_equal(pgem_linear_factor(graph->linear, &graph->store, &graph->executor, graph->message), PGEM_OK);
    assert_true(graph->linear->scalar_count <= MAX_SCALARS);
    return graph->linear->scalar_count;
}

static void check_solve(int dimension, uint32_t poses, uint32_t loops, uint64_t seed)
{
    static double h[MAX_SCALARS * MAX_SCALARS];
    pgem_t *graph = random_graph(dimension, poses, loops, seed);
    const int count = factor(graph);
    dense_h(graph, h);
    double x[MAX_SCALARS] = {0}, b[MAX_SCALARS] = {0}, solved[MAX_SCALARS];
    test_rng_t rng = {seed + 1};
    for (int j = 0; j < count; j++) {
        x[j] = test_uniform_in(&rng, -1, 1);
    }
    for (int i = 0; i < count; i++) {
        b[i] = 0.0;
        for (int j = 0; j < count; j++) {
            b[i] += h[i * count + j] * x[j];
        }
    }
    memcpy(solved, b, (size_t)count * sizeof(double));
    pgem_linear_solve(graph->linear, solved);
    for (int j = 0; j < count; j++) {
        assert_near(solved[j], x[j], 1e-8 * (1.0 + fabs(x[j])));
    }
    pgem_destroy(graph);
}

/* In-place dense Cholesky (lower triangle, row-major) of a symmetric positive definite matrix. */
static void dense_cholesky(double *a, int count)
{
    for (int j = 0; j < count; j++) {
        double diagonal = a[j * count + j];
        for (int m = 0; m < j; m++) {
            diagonal -= a[j * count + m] * a[j * count + m];
        }
        assert_true(diagonal > 0.0);
        a[j * count + j] = sqrt(diagonal);
        for (int i = j + 1; i < count; i++) {
            double sum = a[i * count + j];
            for (int m = 0; m < j; m++) {
                sum -= a[i * count + m] * a[j * count + m];
            }
            a[i * count + j] = sum / a[j * count + j];
        }
        for (int i = 0; i < j; i++) {
            a[i * count + j] = 0.0;
        }
    }
}

/* Every entry the factor stores (its block pattern with relaxed amalgamation's zeros) is the
 * dense factor's, and every entry of the dense factor outside that pattern is zero. */
static void check_factor(int dimension, uint32_t poses, uint32_t loops, uint64_t seed)
{
    static double h[MAX_SCALARS * MAX_SCALARS];
    static unsigned char stored[MAX_SCALARS * MAX_SCALARS];
    pgem_t *graph = random_graph(dimension, poses, loops, seed);
    const int count = factor(graph);
    const pgem_linear_t *linear = graph->linear;
    const int b = linear->block;
    dense_h(graph, h);
    dense_cholesky(h, count);
    const double tolerance = 1e-10 * largest_magnitude(h, count * count);
    memset(stored, 0, sizeof stored);
    for (int column = 0; column < linear->block_count; column++) {
        const pgem_factor_column_t view = pgem_factor_column_view(&linear->factor, column);
        for (int c = 0; c < b; c++) {
            const int j = column * b + c;
            const double *values = view.base[c];
            for (int r = c; r < b; r++) {
                assert_near(values[r - c], h[(column * b + r) * count + j], tolerance);
                stored[(column * b + r) * count + j] = 1;
            }
            for (int q = 0; q < view.count; q++) {
                const int row = pgem_factor_column_row(&view, column, q);
                for (int r = 0; r < b; r++) {
                    assert_near(values[(b - c) + q * b + r], h[(row * b + r) * count + j], tolerance);
                    stored[(row * b + r) * count + j] = 1;
                }
            }
        }
    }
    for (int i = 0; i < count; i++) {
        for (int j = 0; j <= i; j++) {
            if (!stored[i * count + j]) {
                assert_near(h[i * count + j], 0.0, tolerance);
            }
        }
    }
    pgem_destroy(graph);
}

/* Every block of the sparse inverse on L's pattern, and the marginals of every edge by the
 * forward solve and by the inverse, against the dense inverse. */
static void check_inverse(int dimension, uint32_t poses, uint32_t loops, uint64_t seed)
{
    static double h[MAX_SCALARS * MAX_SCALARS];
    pgem_t *graph = random_graph(dimension, poses, loops, seed);
    const int count = factor(graph);
    const int b = graph->linear->block;
    /* supernodes of several columns: the inverse and the solves read across them */
    assert_true(graph->linear->factor.super_count < graph->linear->block_count);
    dense_h(graph, h);
    dense_inverse(h, count);
    const double scale = largest_magnitude(h, count * count);
    test_rng_t rng = {seed + 2};
    double a_from[36], a_to[36], by_solve[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX * 200];
    const uint32_t edges = pgem_edge_count(graph) < 200u ? pgem_edge_count(graph) : 200u;
    double blocks_from[36 * 200], blocks_to[36 * 200];
    for (uint32_t k = 0; k < edges; k++) {
        for (int q = 0; q < b * b; q++) {
            blocks_from[k * 36 + (uint32_t)q] = test_uniform_in(&rng, -1, 1);
            blocks_to[k * 36 + (uint32_t)q] = test_uniform_in(&rng, -1, 1);
        }
        pgem_linear_marginal(graph->linear, graph->store.edge_from[k], graph->store.edge_to[k], blocks_from + k * 36,
                             blocks_to + k * 36, by_solve + k * 36);
    }
    pgem_linear_invert(graph->linear);
    const pgem_linear_t *linear = graph->linear;
    for (int column = 0; column < linear->block_count; column++) {
        const pgem_factor_column_t view = pgem_factor_column_view(&linear->factor, column);
        for (int c = 0; c < b; c++) {
            const double *values = view.base[c];
            for (int r = c; r < b; r++) {
                assert_near(values[r - c], h[(column * b + r) * count + column * b + c], 1e-7 * scale);
            }
            for (int q = 0; q < view.count; q++) {
                const int row = pgem_factor_column_row(&view, column, q);
                for (int r = 0; r < b; r++) {
                    assert_near(values[(b - c) + q * b + r], h[(row * b + r) * count + column * b + c],
                                1e-7 * scale);
                }
            }
        }
    }
    /* the marginal A H^-1 A^T of each edge's poses, three ways */
    for (uint32_t k = 0; k < edges; k++) {
        memcpy(a_from, blocks_from + k * 36, sizeof a_from);
        memcpy(a_to, blocks_to + k * 36, sizeof a_to);
        double by_inverse[36];
        int status = pgem_linear_marginal_inverse(graph->linear, graph->store.edge_from[k], graph->store.edge_to[k],
                                                  a_from, a_to, by_inverse);
        const int pf = linear->pose_block[graph->store.edge_from[k]];
        const int pt = linear->pose_block[graph->store.edge_to[k]];
        for (int r = 0; r < b; r++) {
            for (int c = 0; c < b; c++) {
                double dense = 0.0;
                for (int m = 0; m < b; m++) {
                    for (int l = 0; l < b; l++) {
                        if (pf >= 0 && pt >= 0) {
                            dense += a_from[r * b + m] * h[(pf * b + m) * count + pt * b + l] * a_to[c * b + l];
                            dense += a_to[r * b + m] * h[(pt * b + m) * count + pf * b + l] * a_from[c * b + l];
                        }
                        if (pf >= 0) {
                            dense += a_from[r * b + m] * h[(pf * b + m) * count + pf * b + l] * a_from[c * b + l];
                        }
                        if (pt >= 0) {
                            dense += a_to[r * b + m] * h[(pt * b + m) * count + pt * b + l] * a_to[c * b + l];
                        }
                    }
                }
                assert_near(by_solve[k * 36 + (uint32_t)(r * b + c)], dense, 1e-8 * scale * 10.0);
                if (status == PGEM_OK) {
                    assert_near(by_inverse[r * b + c], dense, 1e-8 * scale * 10.0);
                }
            }
        }
        /* every edge in the structure meets on the pattern */
        if (linear->edge_offset[k] >= 0) {
            assert_int_equal(status, PGEM_OK);
        }
    }
    pgem_destroy(graph);
}

static void test_solve_2d(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 6; seed++) {
        check_solve(2, 40, 25, seed);
    }
}

static void test_solve_3d(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 6; seed++) {
        check_solve(3, 30, 20, seed);
    }
}

static void test_inverse_2d(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 6; seed++) {
        check_inverse(2, 40, 5 + 8 * (uint32_t)seed, seed);
    }
}

static void test_inverse_3d(void **state)
{
    (void)state;
    for (uint64_t seed = 1; seed <= 6; seed++) {
        check_inverse(3, 30, 4 + 6 * (uint32_t)seed, seed);
    }
}

/* Random block patterns, from a chain (0 loops) to nearly dense (loops several times the
 * poses), small and large, against the dense Cholesky factor. */
static void test_factor_random_patterns(void **state)
{
    (void)state;
    const uint32_t poses_2d[4] = {5, 17, 40, 80}, poses_3d[4] = {4, 11, 25, 40};
    for (uint64_t seed = 1; seed <= 16; seed++) {
        const uint32_t shape = (uint32_t)(seed % 4u);
        const uint32_t density = (uint32_t)(seed % 5u); /* loops per 4 poses: 0 .. 16 */
        check_factor(2, poses_2d[shape], poses_2d[shape] * density * density / 4u, seed);
        check_factor(3, poses_3d[shape], poses_3d[shape] * density * density / 4u, seed + 100u);
    }
}

/* A chain only: the factor is a path and every loop-free marginal still matches. */
static void test_inverse_chain(void **state)
{
    (void)state;
    check_inverse(2, 60, 0, 7);
    check_inverse(3, 35, 0, 8);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_solve_2d),
        cmocka_unit_test(test_solve_3d),
        cmocka_unit_test(test_inverse_2d),
        cmocka_unit_test(test_inverse_3d),
        cmocka_unit_test(test_inverse_chain),
        cmocka_unit_test(test_factor_random_patterns),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
