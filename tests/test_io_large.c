/* A graph file of about 1 GiB (a small graph, then comment lines, then its last edge): the read
 * is correct, names the right line when the last line is cut short, reports progress, and its
 * memory does not grow with the file. Needs about 1.1 GiB of free disk in PGEM_TEST_TMP;
 * without it the test says so and skips. */
#define _POSIX_C_SOURCE 200809L

#include <sys/resource.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include "test_io_util.h"

#define PADDING_LINES 1048576u  /* comment lines of PADDING_LINE_BYTES: 1 GiB */
#define PADDING_LINE_BYTES 1024u
#define HEAD "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n"
#define HEAD_LINES 4u
#define LAST "EDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\n"
#define FILE_BYTES ((uint64_t)(sizeof HEAD - 1) + (uint64_t)PADDING_LINES * PADDING_LINE_BYTES + \
                    (uint64_t)(sizeof LAST - 1))

/* How much more than the file the disk must have free (other tests write there too). */
#define SPARE_BYTES (UINT64_C(64) << 20)

static char path[4096];

/* Peak resident memory of the process so far, in bytes. */
static uint64_t peak_rss(void)
{
    struct rusage usage;
    assert_int_equal(getrusage(RUSAGE_SELF, &usage), 0);
    return (uint64_t)usage.ru_maxrss * 1024u;
}

static int write_large_file(void **state)
{
    (void)state;
    const char *dir = getenv("PGEM_TEST_TMP");
    snprintf(path, sizeof path, "%s/test_io_large.g2o", dir != NULL && dir[0] != '\0' ? dir : "/tmp");
    struct statvfs disk;
    char *folder = strdup(path);
    assert_non_null(folder);
    *strrchr(folder, '/') = '\0';
    const int known = statvfs(folder, &disk) == 0;
    free(folder);
    if (known && (uint64_t)disk.f_bavail * disk.f_frsize < FILE_BYTES + SPARE_BYTES) {
        print_message("test_io_large: skipped: %llu MiB free next to %s, %llu MiB needed\n",
                      (unsigned long long)((uint64_t)disk.f_bavail * disk.f_frsize >> 20), path,
                      (unsigned long long)((FILE_BYTES + SPARE_BYTES) >> 20));
        path[0] = '\0';
        return 0;
    }
    static char block[PADDING_LINE_BYTES * 1024u];
    for (size_t line = 0; line < 1024u; line++) {
        char *text = block + line * PADDING_LINE_BYTES;
        memset(text, 'x', PADDING_LINE_BYTES - 1u);
        text[0] = '#';
        text[PADDING_LINE_BYTES - 1u] = '\n';
    }
    FILE *file = fopen(path, "wb");
    assert_non_null(file);
    assert_int_equal(fwrite(HEAD, 1, sizeof HEAD - 1, file), sizeof HEAD - 1);
    for (unsigned k = 0; k < PADDING_LINES / 1024u; k++) {
        assert_int_equal(fwrite(block, 1, sizeof block, file), sizeof block);
    }
    assert_int_equal(fwrite(LAST, 1, sizeof LAST - 1, file), sizeof LAST - 1);
    assert_int_equal(fclose(file), 0);
    return 0;
}

static int remove_large_file(void **state)
{
    (void)state;
    if (path[0] != '\0') {
        remove(path);
    }
    return 0;
}

/* What the progress callback saw. */
typedef struct progress_log {
    unsigned calls;
    uint64_t last_bytes;
    unsigned long last_lines;
    int increasing;
} progress_log_t;

static void log_progress(uint64_t bytes, unsigned long lines, void *user)
{
    progress_log_t *log = user;
    log->increasing &= bytes > log->last_bytes && lines > log->last_lines;
    log->calls++;
    log->last_bytes = bytes;
    log->last_lines = lines;
}

static void test_large_file_reads_in_bounded_memory(void **state)
{
    (void)state;
    if (path[0] == '\0') {
        skip();
    }
    const uint64_t before = peak_rss();
    pgem_io_graph_t graph;
    char message[512];
    progress_log_t log = {0, 0, 0, 1};
    assert_int_equal(pgem_io_read_progress(path, PGEM_FORMAT_AUTO, &graph, message, sizeof message,
                                           log_progress, &log),
                     PGEM_OK);
    assert_int_equal(graph.pose_count, 3);
    assert_int_equal(graph.edge_count, 2);
    assert_int_equal(graph.edges[1].line, HEAD_LINES + PADDING_LINES + 1u);
    assert_true(graph.edges[1].from == 1 && graph.edges[1].to == 2);
    assert_true(graph.edges[1].information[8] == 1.0);
    pgem_io_graph_free(&graph);
    /* one call per 16 MiB read, bytes and lines growing */
    assert_int_equal(log.calls, (unsigned)(FILE_BYTES / PGEM_IO_PROGRESS_BYTES));
    assert_true(log.increasing);
    assert_true(log.last_bytes >= FILE_BYTES - PGEM_IO_PROGRESS_BYTES && log.last_bytes <= FILE_BYTES);
    /* the read holds one line and one chunk, not the file */
    const uint64_t growth = peak_rss() - before;
    print_message("1 GiB read: peak resident memory grew by %llu KiB\n",
                  (unsigned long long)(growth >> 10));
    assert_true(growth < (UINT64_C(16) << 20));
}

/* The same file with its last line cut short: the error names that line, past a million. */
static void test_large_file_truncated_last_line(void **state)
{
    (void)state;
    if (path[0] == '\0') {
        skip();
    }
    assert_int_equal(truncate(path, (off_t)(FILE_BYTES - 3u)), 0); /* " 1\n" cut off */
    pgem_io_graph_t graph;
    char message[512];
    assert_int_equal(pgem_io_read(path, PGEM_FORMAT_AUTO, &graph, message, sizeof message),
                     PGEM_ERR_PARSE);
    char expected[4200];
    snprintf(expected, sizeof expected,
             "%s:%u: EDGE_SE2 has 10 fields, expected 11 (field 11 (I33) is missing)", path,
             HEAD_LINES + PADDING_LINES + 1u);
    assert_string_equal(message, expected);
    assert_int_equal(graph.pose_count, 0);
    assert_null(graph.poses);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_large_file_reads_in_bounded_memory),
        cmocka_unit_test(test_large_file_truncated_last_line),
    };
    return cmocka_run_group_tests(tests, write_large_file, remove_large_file);
}
