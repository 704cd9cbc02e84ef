/* Helpers for the tests that link the I/O layer (pgem::pgem): read a graph file, load it into a
 * new instance. Include after test_util.h. */
#ifndef PGEM_TEST_IO_UTIL_H
#define PGEM_TEST_IO_UTIL_H

#include "pgem/io.h"
#include "test_util.h"

/* Reads a graph file (format from its content) or fails with the reader's message. */
static inline void test_read_graph(const char *path, pgem_io_graph_t *graph)
{
    char message[1024];
    if (pgem_io_read(path, PGEM_FORMAT_AUTO, graph, message, sizeof message) != PGEM_OK) {
        fail_msg("%s", message);
    }
}

/* A new instance sized for the graph (pgem_io_config) holding it, or fails with the loader's
 * message. */
static inline pgem_t *test_load_graph(const pgem_io_graph_t *graph)
{
    pgem_config_t config;
    pgem_io_config(graph, &config);
    pgem_t *instance = NULL;
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    char message[1024];
    if (pgem_io_load(graph, instance, message, sizeof message) != PGEM_OK) {
        fail_msg("%s", message);
    }
    return instance;
}

/* test_read_graph, then test_load_graph; the file's graph is freed. */
static inline pgem_t *test_load_file(const char *path)
{
    pgem_io_graph_t file = {0};
    test_read_graph(path, &file);
    pgem_t *instance = test_load_graph(&file);
    pgem_io_graph_free(&file);
    return instance;
}

#endif /* PGEM_TEST_IO_UTIL_H */
