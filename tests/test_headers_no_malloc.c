/* With PGEM_NO_MALLOC defined (as the firmware build defines it), the public headers declare
 * no allocating call: this file gives the names pgem_create and pgem_destroy to objects of its
 * own, which does not compile if the headers still declare them as functions. Likewise
 * PGEM_NO_FORMER_NAMES leaves out the getters' former names (pgem_get_pose, ...). */
#define PGEM_NO_MALLOC
#define PGEM_NO_FORMER_NAMES
#include "pgem/pgem.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>

#include <cmocka.h>

static const int pgem_create = 1;
static const int pgem_destroy = 2;
static const int pgem_get_pose = 4;
static const int pgem_get_config = 8;

static void test_no_allocating_calls(void **state)
{
    (void)state;
    static unsigned char block[1u << 16];
    pgem_config_t config = {2, 10, 20, 0, 0, 0};
    pgem_t *instance = NULL;
    assert_int_equal(pgem_create + pgem_destroy + pgem_get_pose + pgem_get_config, 15);
    assert_true(pgem_memory_size(&config) <= sizeof block);
    assert_int_equal(pgem_init(&instance, &config, block, sizeof block), PGEM_OK);
    assert_int_equal(pgem_pose_count(instance), 0);
    assert_int_equal(pgem_resolved_config(instance)->dimension, 2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_no_allocating_calls)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
