/* The public headers compile as plain C99 (this file is built with -std=c99 -Wpedantic). */
#include "pgem/pgem.h"
#include "pgem/io.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>

#include <cmocka.h>

static void test_c99_headers(void **state)
{
    (void)state;
    pgem_config_t config = {3, 10, 20, 0, 0, 0};
    assert_true(pgem_memory_size(&config) > 0);
    assert_int_equal(PGEM_POSE_SIZE(3), 7);
    assert_int_equal(PGEM_TANGENT_SIZE(2), 3);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_c99_headers)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
