// The public headers compile as C++ (built with -std=c++17 -Wpedantic) and link from C++.
#include "pgem/pgem.h"
#include "pgem/io.h"

#include <cstdarg>
#include <cstddef>
#include <csetjmp>
#include <cstdint>

extern "C" {
#include <cmocka.h> // cmocka 1.1 has no C++ guards of its own
}

static void test_cpp_headers(void **)
{
    pgem_config_t config{};
    config.dimension = 2;
    config.max_poses = 8;
    pgem_t *graph = nullptr;
    assert_int_equal(pgem_create(&graph, &config), PGEM_OK);
    const double pose[3] = {1.0, 2.0, 0.5};
    assert_int_equal(pgem_add_pose(graph, 5u, pose), PGEM_OK);
    assert_int_equal(pgem_pose_count(graph), 1u);
    pgem_destroy(graph);
}

int main()
{
    const CMUnitTest tests[] = {cmocka_unit_test(test_cpp_headers)};
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
