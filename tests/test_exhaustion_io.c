/* Memory exhaustion in the file reader (hosted: it reads into heap arrays). Every malloc,
 * calloc and realloc of pgem_io_read_stream is failed in turn (interposed,
 * test_alloc_counters.h) over a g2o file with vertices, edges and FIX lines, a 3D one, and an
 * edge-only one (whose poses the reader composes along a spanning tree): each failure gives
 * PGEM_ERR_OUT_OF_MEMORY with "FILE:LINE: out of memory", leaves the graph empty and leaks
 * nothing; with no fault reached the graph is the one a plain read gives. pgem_io_read, which
 * also opens the file, is swept too: there the fault may hit fopen (a clear "cannot open"). */
#define TEST_ALLOC_FAULTS
#include "test_util.h"

#include "test_io_util.h"

#include "test_alloc_counters.h"

#if !TEST_UNDER_SANITIZER
#define MESSAGE_BYTES 1024

static void temporary_path(char *path, size_t size, const char *name)
{
    const char *dir = getenv("PGEM_TEST_TMP");
    snprintf(path, size, "%s/%s", dir != NULL && dir[0] != '\0' ? dir : "/tmp", name);
}

/* A graph file written from an instance: a 2D ring (poses, odometry, loops, a FIX) or a 3D
 * chain with loops. */
static void write_instance_file(const char *path, int dimension)
{
    pgem_t *graph = test_create(dimension, 60, 240);
    if (dimension == 2) {
        double truth[3 * 60];
        test_ring_2d(graph, 60, 6, 0.02, 0.01, 3, truth);
    } else {
        double information[36], pose[7], z[7];
        test_diagonal_information(6, 100.0, information);
        for (int k = 0; k < 40; k++) {
            const double tangent[6] = {0.5 * k, 0.1 * sin(k), 0.2, 0.02 * k, 0.01, 0.05 * cos(k)};
            pgem_se3_exp(tangent, pose);
            assert_int_equal(pgem_add_pose(graph, (pgem_id_t)k, pose), PGEM_OK);
        }
        const double step[7] = {0.5, 0, 0, 0, 0, 0, 1};
        for (int k = 1; k < 40; k++) {
            assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 1), (pgem_id_t)k, step,
                                           information, PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
            if (k % 8 == 0) {
                memcpy(z, step, sizeof z);
                z[0] = 4.0;
                assert_int_equal(pgem_add_edge(graph, (pgem_id_t)(k - 8), (pgem_id_t)k, z,
                                               information, PGEM_EDGE_LOOP, NULL), PGEM_OK);
            }
        }
    }
    assert_int_equal(pgem_fix_pose(graph, 0, 1), PGEM_OK);
    pgem_io_graph_t file = {0};
    assert_int_equal(pgem_io_from_instance(graph, &file), PGEM_OK);
    char message[MESSAGE_BYTES];
    assert_int_equal(pgem_io_write(path, PGEM_FORMAT_G2O, &file, message, sizeof message), PGEM_OK);
    pgem_io_graph_free(&file);
    pgem_destroy(graph);
}

/* Edges only, ids out of order: the reader makes the poses itself. */
static void write_edge_only_file(const char *path)
{
    FILE *stream = fopen(path, "w");
    assert_non_null(stream);
    for (int k = 1; k < 50; k++) {
        fprintf(stream, "EDGE_SE2 %d %d 1 0 0.1 10 0 0 10 0 10\n", (k * 7) % 50, ((k - 1) * 7) % 50);
    }
    fprintf(stream, "EDGE_SE2 0 21 2 1 0.3 10 0 0 10 0 10\n");
    assert_int_equal(fclose(stream), 0);
}

static int same_graph(const pgem_io_graph_t *a, const pgem_io_graph_t *b)
{
    return a->dimension == b->dimension && a->pose_count == b->pose_count &&
           a->edge_count == b->edge_count && a->fixed_count == b->fixed_count &&
           a->chained_poses == b->chained_poses &&
           memcmp(a->poses, b->poses, a->pose_count * sizeof *a->poses) == 0 &&
           memcmp(a->edges, b->edges, a->edge_count * sizeof *a->edges) == 0 &&
           (a->fixed_count == 0 || memcmp(a->fixed, b->fixed, a->fixed_count * sizeof *a->fixed) == 0);
}

static int empty_graph(const pgem_io_graph_t *graph)
{
    return graph->pose_count == 0 && graph->edge_count == 0 && graph->fixed_count == 0 &&
           graph->poses == NULL && graph->edges == NULL && graph->fixed == NULL;
}

/* Fails every allocation of a read in turn. from_path: pgem_io_read (opens the file inside the
 * sweep); else pgem_io_read_stream on a stream opened and buffered beforehand. */
static long sweep_read(const char *path, const char *label, int from_path)
{
    static char stream_buffer[1 << 16];
    pgem_io_graph_t reference = {0}, graph = {0};
    char message[MESSAGE_BYTES], expected[600];
    test_read_graph(path, &reference);
    assert_true(reference.edge_count > 0);
    snprintf(expected, sizeof expected, "%s:", path);
    long points = 0, open_failures = 0, absorbed = 0;
    for (long k = 0;; k++) {
        FILE *stream = NULL;
        if (!from_path) {
            stream = fopen(path, "rb");
            assert_non_null(stream);
            /* the stream's buffer is ours, so stdio allocates nothing inside the sweep */
            assert_int_equal(setvbuf(stream, stream_buffer, _IOFBF, sizeof stream_buffer), 0);
        }
        const long allocated = allocations, released = releases;
        alloc_fault_arm(k);
        const int status = from_path
                               ? pgem_io_read(path, PGEM_FORMAT_AUTO, &graph, message, sizeof message)
                               : pgem_io_read_stream(stream, path, PGEM_FORMAT_AUTO, &graph, message,
                                                     sizeof message);
        const long seen = alloc_fault_seen;
        alloc_fault_arm(-1);
        const long taken = allocations - allocated, given_back = releases - released;
        if (stream != NULL) {
            fclose(stream);
        }
        if (seen <= k) { /* nothing left to fail */
            assert_int_equal(status, PGEM_OK);
            assert_true(same_graph(&graph, &reference));
            pgem_io_graph_free(&graph);
            break;
        }
        points++;
        if (status == PGEM_OK && from_path) {
            /* stdio's buffer, allocated at the first read: without it glibc reads unbuffered */
            assert_true(same_graph(&graph, &reference));
            pgem_io_graph_free(&graph);
            absorbed++;
            continue;
        }
        if (status == PGEM_ERR_IO && from_path) { /* fopen's own allocation */
            assert_contains(message, "cannot open");
            open_failures++;
        } else {
            if (status != PGEM_ERR_OUT_OF_MEMORY) {
                fail_msg("%s, fault %ld: %s (%s)", label, k, pgem_io_error_name(status), message);
            }
            assert_contains(message, expected);
            assert_contains(message, "out of memory");
        }
        assert_true(empty_graph(&graph));
        /* nothing kept: every block the read took is given back */
        if (taken != given_back) {
            fail_msg("%s, fault %ld: %ld allocations, %ld releases", label, k, taken, given_back);
        }
    }
    assert_true(points > 0);
    print_message("%s (%s): %ld allocations failed in turn (%ld inside fopen, %ld stdio did "
                  "without)\n",
                  label, from_path ? "pgem_io_read" : "pgem_io_read_stream", points, open_failures,
                  absorbed);
    pgem_io_graph_free(&reference);
    return points;
}

static void test_reader_sweep(void **state)
{
    (void)state;
    char path[512];
    long total = 0;
    temporary_path(path, sizeof path, "exhaustion_2d.g2o");
    write_instance_file(path, 2);
    total += sweep_read(path, "2D g2o, FIX", 0);
    total += sweep_read(path, "2D g2o, FIX", 1);
    temporary_path(path, sizeof path, "exhaustion_3d.g2o");
    write_instance_file(path, 3);
    total += sweep_read(path, "3D g2o", 0);
    temporary_path(path, sizeof path, "exhaustion_edges.g2o");
    write_edge_only_file(path);
    total += sweep_read(path, "2D edges only", 0);
    print_message("reader: %ld fault points\n", total);
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_reader_sweep)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
#else
static void test_skipped_under_sanitizer(void **state)
{
    (void)state;
    print_message("skipped: AddressSanitizer owns malloc, so this build cannot fail the reader's "
                  "allocations; the plain build runs this test\n");
    skip();
}

int main(void)
{
    const struct CMUnitTest tests[] = {cmocka_unit_test(test_skipped_under_sanitizer)};
    return cmocka_run_group_tests(tests, NULL, NULL);
}
#endif
