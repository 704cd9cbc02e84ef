/* The core's small dense module (lib/core/common/small.c): Cholesky (strict and raising its
 * pivots), the triangular solve, the quadratic form and the inverse, on 3 x 3 and 6 x 6
 * blocks, against products recomputed here. */
#include "test_util.h"

#include "common/common.h"

/* A symmetric positive definite n x n matrix: B B^T + n I for a fixed B. */
static void definite(int n, double *a)
{
    double b[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    for (int q = 0; q < n * n; q++) {
        b[q] = sin(1.7 * q + 0.3) + (q % (n + 1) == 0 ? 2.0 : 0.0);
    }
    pgem_small_product(b, 0, b, 1, a, n);
    for (int i = 0; i < n; i++) {
        a[i * n + i] += n;
    }
}

static void test_cholesky(void **state)
{
    (void)state;
    for (int n = 1; n <= PGEM_SMALL_MAX; n++) {
        double a[PGEM_SMALL_MAX * PGEM_SMALL_MAX], u[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
        double back[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
        definite(n, a);
        memcpy(u, a, sizeof a);
        assert_int_equal(pgem_small_cholesky(u, n, 0.0, 1), -1);
        for (int i = 0; i < n; i++) {
            assert_true(u[i * n + i] > 0.0);
            for (int j = 0; j < i; j++) {
                assert_true(u[i * n + j] == 0.0); /* the lower triangle cleared */
            }
        }
        pgem_small_product(u, 1, u, 0, back, n); /* U^T U */
        for (int q = 0; q < n * n; q++) {
            assert_near(back[q], a[q], 1e-12 * (1.0 + fabs(a[q])));
        }
    }
}

static void test_cholesky_pivots(void **state)
{
    (void)state;
    double indefinite[4] = {1.0, 2.0, 2.0, 1.0};
    assert_int_equal(pgem_small_cholesky(indefinite, 2, 0.0, 1), 1); /* 1 - 4 < 0 */
    double tiny[4] = {1.0, 0.0, 0.0, 1e-20};
    assert_int_equal(pgem_small_cholesky(tiny, 2, 1e-10, 1), 1); /* not above the floor */
    double infinite[4] = {(double)INFINITY, 0.0, 0.0, 1.0};
    assert_int_equal(pgem_small_cholesky(infinite, 2, 0.0, 1), 0);
    /* not strict: a pivot below `least` is raised to it; a zero root zeroes its row */
    double raised[4] = {0.25, 3.0, 3.0, 9.0};
    assert_int_equal(pgem_small_cholesky(raised, 2, 1.0, 0), -1);
    assert_near(raised[0], 1.0, 0.0);
    assert_near(raised[1], 3.0, 0.0);
    assert_near(raised[3], 1.0, 0.0); /* 9 - 9 = 0, raised to 1 */
    double singular[4] = {0.0, 5.0, 5.0, 4.0};
    assert_int_equal(pgem_small_cholesky(singular, 2, 0.0, 0), -1);
    assert_true(singular[0] == 0.0 && singular[1] == 0.0);
    assert_near(singular[3], 2.0, 0.0);
}

static void test_solve_and_form(void **state)
{
    (void)state;
    for (int n = 1; n <= PGEM_SMALL_MAX; n++) {
        double a[PGEM_SMALL_MAX * PGEM_SMALL_MAX], u[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
        double inverse[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
        double e[PGEM_SMALL_MAX], x[PGEM_SMALL_MAX], ux[PGEM_SMALL_MAX], ainv_e[PGEM_SMALL_MAX];
        definite(n, a);
        memcpy(u, a, sizeof a);
        assert_int_equal(pgem_small_cholesky(u, n, 0.0, 1), -1);
        for (int i = 0; i < n; i++) {
            e[i] = cos(0.9 * i) - 0.2;
            x[i] = e[i];
        }
        pgem_small_upper_solve(u, x, n); /* U x = e */
        pgem_small_apply(u, 0, x, ux, n);
        for (int i = 0; i < n; i++) {
            assert_near(ux[i], e[i], 1e-12);
        }
        assert_int_equal(pgem_small_inverse(a, inverse, n), 1);
        pgem_small_apply(inverse, 0, e, ainv_e, n);
        double form = 0.0;
        for (int i = 0; i < n; i++) {
            form += e[i] * ainv_e[i];
        }
        assert_true(form > 0.0);
        assert_near(pgem_small_form(u, e, n), form, 1e-12 * form);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cholesky),
        cmocka_unit_test(test_cholesky_pivots),
        cmocka_unit_test(test_solve_and_form),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
