/* Tests of pgem I/O: g2o / TORO reading, writing, error messages, chain guess and datasets. */
#define _GNU_SOURCE /* fopencookie: streams that never end */

#include "test_io_util.h"

#define PI 3.14159265358979323846

/* ---------------------------------------------------------------- helpers: files and text */

static const char *temp_dir(void)
{
    const char *dir = getenv("PGEM_TEST_TMP");
    return dir != NULL && dir[0] != '\0' ? dir : "/tmp";
}

static void temp_path(char *out, size_t size, const char *name)
{
    snprintf(out, size, "%s/test_io_%s", temp_dir(), name);
}

static void write_bytes(const char *path, const char *bytes, size_t length)
{
    FILE *file = fopen(path, "wb");
    assert_non_null(file);
    assert_int_equal(fwrite(bytes, 1, length, file), length);
    assert_int_equal(fclose(file), 0);
}

/* Writes text to a temp file called name and reads it back with format. */
static int read_text_as(const char *name, const char *text, pgem_format_t format,
                        pgem_io_graph_t *graph, char *message, size_t message_size)
{
    char path[512];
    temp_path(path, sizeof path, name);
    write_bytes(path, text, strlen(text));
    return pgem_io_read(path, format, graph, message, message_size);
}

static int read_text(const char *name, const char *text, pgem_io_graph_t *graph, char *message,
                     size_t message_size)
{
    return read_text_as(name, text, PGEM_FORMAT_AUTO, graph, message, message_size);
}

/* read_text_as for text that must be accepted: fails with the reader's message otherwise. */
static void read_ok_as(const char *name, const char *text, pgem_format_t format,
                       pgem_io_graph_t *graph)
{
    char message[512];
    int status = read_text_as(name, text, format, graph, message, sizeof message);
    if (status != PGEM_OK) {
        fail_msg("%s: status %d (%s): %s", name, status, pgem_io_error_name(status), message);
    }
}

static void read_ok(const char *name, const char *text, pgem_io_graph_t *graph)
{
    read_ok_as(name, text, PGEM_FORMAT_AUTO, graph);
}

static void assert_graph_empty(const pgem_io_graph_t *graph)
{
    assert_int_equal(graph->dimension, 0);
    assert_null(graph->poses);
    assert_null(graph->edges);
    assert_null(graph->fixed);
    assert_int_equal(graph->pose_count, 0);
    assert_int_equal(graph->edge_count, 0);
    assert_int_equal(graph->fixed_count, 0);
}

/* Reads text and checks the error code and that the message holds both fragments. */
static void expect_error(const char *name, const char *text, int code, const char *where,
                         const char *what)
{
    pgem_io_graph_t graph;
    char message[512];
    int status = read_text(name, text, &graph, message, sizeof message);
    if (status != code) {
        fail_msg("%s: status %d (%s), expected %d; message \"%s\"", name, status,
                 pgem_io_error_name(status), code, message);
    }
    assert_contains(message, where);
    assert_contains(message, what);
    assert_graph_empty(&graph);
}

/* ---------------------------------------------------------------- helpers: graphs in memory */

static void graph_init(pgem_io_graph_t *graph, int dimension, size_t poses, size_t edges)
{
    memset(graph, 0, sizeof *graph);
    graph->dimension = dimension;
    graph->poses = (pgem_io_pose_t *)calloc(poses, sizeof *graph->poses);
    graph->edges = (pgem_io_edge_t *)calloc(edges, sizeof *graph->edges);
    graph->fixed = (pgem_id_t *)calloc(4, sizeof *graph->fixed);
    assert_non_null(graph->poses);
    assert_non_null(graph->edges);
    assert_non_null(graph->fixed);
    graph->pose_capacity = poses;
    graph->edge_capacity = edges;
    graph->fixed_capacity = 4;
}

static void add_pose(pgem_io_graph_t *graph, pgem_id_t id, const double *values)
{
    pgem_io_pose_t *pose = &graph->poses[graph->pose_count++];
    pose->id = id;
    memcpy(pose->pose, values, sizeof(double) * (size_t)PGEM_POSE_SIZE(graph->dimension));
}

/* An edge whose information has a distinct value in every upper cell (kept symmetric). */
static void add_edge(pgem_io_graph_t *graph, pgem_id_t from, pgem_id_t to, const double *z,
                     double scale)
{
    pgem_io_edge_t *edge = &graph->edges[graph->edge_count++];
    size_t n = (size_t)PGEM_TANGENT_SIZE(graph->dimension);
    size_t r;
    size_t c;
    edge->from = from;
    edge->to = to;
    edge->kind = (from > to ? from - to : to - from) == 1 ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP;
    memcpy(edge->measurement, z, sizeof(double) * (size_t)PGEM_POSE_SIZE(graph->dimension));
    for (r = 0; r < n; ++r) {
        for (c = r; c < n; ++c) {
            double value = r == c ? 1000.0 * scale + (double)r / 7.0
                                  : scale * (double)(10 * r + c) / 3.0;
            edge->information[r * n + c] = value;
            edge->information[c * n + r] = value;
        }
    }
}

static void assert_bits_equal(const double *a, const double *b, size_t count)
{
    size_t i;
    for (i = 0; i < count; ++i) {
        if (memcmp(&a[i], &b[i], sizeof(double)) != 0) {
            fail_msg("value %lu differs: %.17g vs %.17g", (unsigned long)i, a[i], b[i]);
        }
    }
}

/* Same poses, edges and kinds, every double equal to the bit. */
static void assert_graphs_identical(const pgem_io_graph_t *a, const pgem_io_graph_t *b)
{
    size_t pose_size = (size_t)PGEM_POSE_SIZE(a->dimension);
    size_t n = (size_t)PGEM_TANGENT_SIZE(a->dimension);
    size_t i;
    assert_int_equal(a->dimension, b->dimension);
    assert_int_equal(a->pose_count, b->pose_count);
    assert_int_equal(a->edge_count, b->edge_count);
    for (i = 0; i < a->pose_count; ++i) {
        assert_true(a->poses[i].id == b->poses[i].id);
        assert_bits_equal(a->poses[i].pose, b->poses[i].pose, pose_size);
    }
    for (i = 0; i < a->edge_count; ++i) {
        assert_true(a->edges[i].from == b->edges[i].from);
        assert_true(a->edges[i].to == b->edges[i].to);
        assert_int_equal(a->edges[i].kind, b->edges[i].kind);
        assert_bits_equal(a->edges[i].measurement, b->edges[i].measurement, pose_size);
        assert_bits_equal(a->edges[i].information, b->edges[i].information, n * n);
    }
}

/* The whole content of a file (caller frees). */
static char *slurp(const char *path, size_t *length)
{
    FILE *file = fopen(path, "rb");
    char *text;
    long size;
    assert_non_null(file);
    assert_int_equal(fseek(file, 0, SEEK_END), 0);
    size = ftell(file);
    assert_true(size >= 0);
    rewind(file);
    text = (char *)malloc((size_t)size + 1);
    assert_non_null(text);
    assert_int_equal(fread(text, 1, (size_t)size, file), (size_t)size);
    text[size] = '\0';
    fclose(file);
    *length = (size_t)size;
    return text;
}

/* Writes graph in format, reads it back, checks it is identical, then checks that writing the
 * copy gives the same bytes. */
static void round_trip(const pgem_io_graph_t *graph, pgem_format_t format, const char *name)
{
    char path[512];
    char path2[600];
    char message[512];
    pgem_io_graph_t copy;
    char *first;
    char *second;
    size_t first_length;
    size_t second_length;
    temp_path(path, sizeof path, name);
    assert_int_equal(pgem_io_write(path, format, graph, message, sizeof message), PGEM_OK);
    assert_int_equal(pgem_io_read(path, format, &copy, message, sizeof message), PGEM_OK);
    assert_graphs_identical(graph, &copy);
    assert_int_equal(copy.unknown_lines, 0);
    snprintf(path2, sizeof path2, "%s.again", path);
    assert_int_equal(pgem_io_write(path2, format, &copy, message, sizeof message), PGEM_OK);
    first = slurp(path, &first_length);
    second = slurp(path2, &second_length);
    assert_int_equal(first_length, second_length);
    assert_memory_equal(first, second, first_length);
    free(first);
    free(second);
    pgem_io_graph_free(&copy);
}

/* ---------------------------------------------------------------- round trips */

static void test_round_trip_g2o_2d(void **state)
{
    pgem_io_graph_t graph;
    pgem_io_graph_t copy;
    char path[512];
    char message[512];
    const double p0[3] = {1.0 / 3.0, -0.0, 4.9406564584124654e-324};
    const double p1[3] = {-1e8, -2.5e-17, 1e300}; /* the translation limit; angles have none */
    const double p2[3] = {-123456.789012345678, 0.1, -3.0};
    const double z0[3] = {0.1 + 0.2, 1.0 / 7.0, 7.0}; /* unwrapped angle kept as written */
    const double z1[3] = {-1e-5, 2.0 / 3.0, -PI};
    (void)state;
    graph_init(&graph, 2, 3, 2);
    add_pose(&graph, 0, p0);
    add_pose(&graph, 1, p1);
    add_pose(&graph, UINT64_MAX, p2);
    add_edge(&graph, 0, 1, z0, 1.0);
    add_edge(&graph, UINT64_MAX, 0, z1, 3.3); /* ids differ by "1" modulo 2^64: a loop */
    assert_int_equal(graph.edges[1].kind, PGEM_EDGE_LOOP);
    graph.fixed[graph.fixed_count++] = 1;
    round_trip(&graph, PGEM_FORMAT_G2O, "rt2d.g2o");
    temp_path(path, sizeof path, "rt2d.g2o");
    assert_int_equal(pgem_io_read(path, PGEM_FORMAT_AUTO, &copy, message, sizeof message),
                     PGEM_OK);
    assert_int_equal(copy.fixed_count, 1);
    assert_true(copy.fixed[0] == 1);
    assert_int_equal(copy.edges[1].kind, PGEM_EDGE_LOOP);
    assert_int_equal(copy.edges[0].line, 5); /* 3 vertices, 1 FIX, then the edges */
    pgem_io_graph_free(&copy);
    pgem_io_graph_free(&graph);
}

static void test_round_trip_g2o_3d(void **state)
{
    pgem_io_graph_t graph;
    const double p0[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
    const double p1[7] = {1.0 / 3.0, -2.0 / 7.0, 1e-9, 0.1, 0.2, 0.3, 0.92736184954957036};
    const double p2[7] = {5.0, 6.0, 7.0, 0.5, -0.5, 0.5, 0.5000001}; /* slightly off unit */
    const double z[7] = {0.3, -0.1, 0.7, 0.01, -0.02, 0.03, 0.99931};
    (void)state;
    graph_init(&graph, 3, 3, 2);
    add_pose(&graph, 8430738502437568512ULL, p0);
    add_pose(&graph, 8430738502437568513ULL, p1);
    add_pose(&graph, 7, p2);
    add_edge(&graph, 8430738502437568512ULL, 8430738502437568513ULL, z, 1.0);
    add_edge(&graph, 7, 8430738502437568512ULL, z, 0.25);
    graph.fixed[graph.fixed_count++] = 7;
    graph.fixed[graph.fixed_count++] = 8430738502437568512ULL;
    round_trip(&graph, PGEM_FORMAT_G2O, "rt3d.g2o");
    round_trip(&graph, PGEM_FORMAT_AUTO, "rt3d_auto.g2o");
    pgem_io_graph_free(&graph);
}

static void test_round_trip_toro(void **state)
{
    pgem_io_graph_t graph;
    pgem_io_graph_t copy;
    char path[512];
    char message[512];
    const double p0[3] = {0.0, 0.0, 0.0};
    const double p1[3] = {0.99559500000000004, 0.083720400000000003, 0.0146728};
    const double z[3] = {1.0 / 3.0, -1.0 / 9.0, 2.5};
    (void)state;
    graph_init(&graph, 2, 2, 2);
    add_pose(&graph, 0, p0);
    add_pose(&graph, 1, p1);
    add_edge(&graph, 1, 0, z, 2.0);
    add_edge(&graph, 0, 1, z, 0.5);
    graph.edges[1].kind = PGEM_EDGE_LOOP; /* a second edge between 0 and 1 reads as a loop */
    graph.fixed[graph.fixed_count++] = 0;
    temp_path(path, sizeof path, "rt.graph");
    assert_int_equal(pgem_io_write(path, PGEM_FORMAT_TORO, &graph, message, sizeof message),
                     PGEM_OK);
    assert_int_equal(pgem_io_read(path, PGEM_FORMAT_TORO, &copy, message, sizeof message),
                     PGEM_OK);
    assert_graphs_identical(&graph, &copy);
    assert_int_equal(copy.fixed_count, 0); /* TORO cannot say a pose is fixed */
    pgem_io_graph_free(&copy);
    graph.fixed_count = 0;
    round_trip(&graph, PGEM_FORMAT_TORO, "rt2.graph");
    pgem_io_graph_free(&graph);
}

static void test_write_toro_3d_is_dimension_error(void **state)
{
    pgem_io_graph_t graph;
    char path[512];
    char message[512];
    const double p0[7] = {0, 0, 0, 0, 0, 0, 1};
    (void)state;
    graph_init(&graph, 3, 1, 1);
    add_pose(&graph, 0, p0);
    temp_path(path, sizeof path, "toro3d.graph");
    assert_int_equal(pgem_io_write(path, PGEM_FORMAT_TORO, &graph, message, sizeof message),
                     PGEM_ERR_DIMENSION);
    assert_contains(message, "toro3d.graph");
    assert_int_equal(pgem_io_write_stream(stdout, PGEM_FORMAT_TORO, &graph), PGEM_ERR_DIMENSION);
    pgem_io_graph_free(&graph);
}

static void test_write_stream_text(void **state)
{
    pgem_io_graph_t graph;
    char *text = NULL;
    size_t length = 0;
    FILE *stream;
    const double p0[3] = {0.5, -1.0, 0.25};
    const double z[3] = {1.0, 0.0, 0.0};
    (void)state;
    graph_init(&graph, 2, 2, 1);
    add_pose(&graph, 3, p0);
    add_pose(&graph, 4, p0);
    add_edge(&graph, 3, 4, z, 1.0);
    graph.edges[0].information[1] = graph.edges[0].information[3] = 12.0;
    graph.edges[0].information[2] = graph.edges[0].information[6] = 13.0;
    graph.edges[0].information[5] = graph.edges[0].information[7] = 23.0;
    graph.edges[0].information[0] = 11.0;
    graph.edges[0].information[4] = 22.0;
    graph.edges[0].information[8] = 33.0;
    stream = open_memstream(&text, &length);
    assert_non_null(stream);
    assert_int_equal(pgem_io_write_stream(stream, PGEM_FORMAT_G2O, &graph), PGEM_OK);
    assert_int_equal(pgem_io_write_stream(stream, PGEM_FORMAT_TORO, &graph), PGEM_OK);
    fclose(stream);
    assert_string_equal(text, "VERTEX_SE2 3 0.5 -1 0.25\n"
                              "VERTEX_SE2 4 0.5 -1 0.25\n"
                              "EDGE_SE2 3 4 1 0 0 11 12 13 22 23 33\n"
                              "VERTEX2 3 0.5 -1 0.25\n"
                              "VERTEX2 4 0.5 -1 0.25\n"
                              "EDGE2 3 4 1 0 0 11 12 22 33 13 23\n");
    free(text);
    pgem_io_graph_free(&graph);
}

/* ---------------------------------------------------------------- information order */

static void test_information_order_toro_vs_g2o(void **state)
{
    pgem_io_graph_t g2o;
    pgem_io_graph_t toro;
    size_t k;
    (void)state;
    read_ok("order.g2o",
            "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n"
            "EDGE_SE2 0 1 1 2 3 11 12 13 22 23 33\n", &g2o);
    read_ok("order.graph",
            "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\n"
            "EDGE2 0 1 1 2 3 11 12 22 33 13 23\n", &toro);
    assert_graphs_identical(&g2o, &toro);
    {
        const double expected[9] = {11, 12, 13, 12, 22, 23, 13, 23, 33};
        for (k = 0; k < 9; ++k) {
            assert_true(g2o.edges[0].information[k] == expected[k]);
        }
    }
    pgem_io_graph_free(&g2o);
    pgem_io_graph_free(&toro);
}

static void test_information_order_3d(void **state)
{
    pgem_io_graph_t graph;
    size_t r;
    size_t c;
    double k = 1.0;
    (void)state;
    read_ok("order3d.g2o",
            "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
            "VERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n"
            "EDGE_SE3:QUAT 0 1 1 2 3 0 0 0 1 1 2 3 4 5 6 7 8 9 10 11 12 13 14 "
            "15 16 17 18 19 20 21\n", &graph);
    assert_int_equal(graph.dimension, 3);
    for (r = 0; r < 6; ++r) {
        for (c = r; c < 6; ++c) {
            assert_true(graph.edges[0].information[r * 6 + c] == k);
            assert_true(graph.edges[0].information[c * 6 + r] == k);
            k += 1.0;
        }
    }
    assert_true(graph.edges[0].measurement[6] == 1.0);
    assert_true(graph.edges[0].measurement[2] == 3.0);
    pgem_io_graph_free(&graph);
}

/* ---------------------------------------------------------------- bad input */

#define HEAD2 "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n"
#define INFO2 " 1 0 0 1 0 1"

static void test_error_field_count(void **state)
{
    (void)state;
    expect_error("few.g2o", HEAD2 "VERTEX_SE2 2 1 0\n", PGEM_ERR_PARSE, "few.g2o:3:",
                 "VERTEX_SE2 has 3 fields, expected 4 (field 4 (th) is missing)");
    expect_error("many.g2o", HEAD2 "EDGE_SE2 0 1 1 0 0" INFO2 " 9\n", PGEM_ERR_PARSE,
                 "many.g2o:3:", "EDGE_SE2 has 12 fields, expected 11 (field 12 '9' is extra)");
    expect_error("few3d.g2o", "VERTEX_SE3:QUAT 0 0 0 0 0 0 1\n", PGEM_ERR_PARSE, "few3d.g2o:1:",
                 "field 8 (qw) is missing");
    expect_error("toro_few.graph",
                 "VERTEX2 0 0 0 0\nVERTEX2 1 0 0 0\n\nEDGE2 0 1 1 0 0 1 0 1 1 0\n", PGEM_ERR_PARSE,
                 "toro_few.graph:4:", "field 11 (Iyt) is missing");
    expect_error("fix_empty.g2o", HEAD2 "FIX\n", PGEM_ERR_PARSE, "fix_empty.g2o:3:",
                 "FIX has 0 fields");
    expect_error("fix_many.g2o",
                 HEAD2 "FIX 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25 "
                       "26 27 28 29 30 31\n",
                 PGEM_ERR_PARSE, "fix_many.g2o:3:", "FIX has 32 ids, at most 31 per line");
    expect_error("long_edge.g2o",
                 "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nEDGE_SE3:QUAT 0 1 1 2 3 0 0 0 1 1 2 3 4 5 6 7 "
                 "8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24\n",
                 PGEM_ERR_PARSE, "long_edge.g2o:2:", "EDGE_SE3:QUAT has 33 fields, expected 30");
}

static void test_error_numbers(void **state)
{
    (void)state;
    expect_error("nan.g2o", HEAD2 "EDGE_SE2 0 1 1 0 nan" INFO2 "\n", PGEM_ERR_PARSE,
                 "nan.g2o:3: EDGE_SE2 field 5 (dth) is not a finite number", "nan.g2o");
    expect_error("inf.g2o", HEAD2 "# comment\nEDGE_SE2 0 1 1 0 0 -Inf 0 0 1 0 1\n",
                 PGEM_ERR_PARSE, "inf.g2o:4:", "EDGE_SE2 field 6 (I11) is not a finite number");
    expect_error("huge.g2o", "VERTEX_SE2 0 1e999 0 0\n", PGEM_ERR_PARSE, "huge.g2o:1:",
                 "field 2 (x) is not a finite number");
    expect_error("junk.g2o", HEAD2 "EDGE_SE2 0 1 1.0x 0 0" INFO2 "\n", PGEM_ERR_PARSE,
                 "junk.g2o:3:", "EDGE_SE2 field 3 (dx) is not a number: '1.0x'");
    expect_error("comma.graph", "VERTEX2 0 0,5 0 0\n", PGEM_ERR_PARSE, "comma.graph:1:",
                 "VERTEX2 field 2 (x) is not a number: '0,5'");
    expect_error("quat.g2o", "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 NAN\n", PGEM_ERR_PARSE,
                 "quat.g2o:1:", "VERTEX_SE3:QUAT field 8 (qw) is not a finite number");
    expect_error("toro_info.graph",
                 "VERTEX2 0 0 0 0\nVERTEX2 1 0 0 0\nEDGE2 0 1 1 0 0 1 0 1 1 x 0\n", PGEM_ERR_PARSE,
                 "toro_info.graph:3:", "EDGE2 field 10 (Ixt) is not a number");
}

/* Issue 17: a loop closure with dx = 1e160 was read and loaded, and every solve of the graph
 * then failed with an infinite chi2. Numbers beyond the core's magnitude limits are refused by
 * the reader, naming the field; the limits themselves are read. */
static void test_error_magnitudes(void **state)
{
    pgem_io_graph_t graph;
    (void)state;
    expect_error("far_loop.g2o", HEAD2 "EDGE_SE2 0 1 1 0 0" INFO2 "\nEDGE_SE2 1 0 1e160 0 0" INFO2 "\n",
                 PGEM_ERR_OUT_OF_RANGE, "far_loop.g2o:4:",
                 "EDGE_SE2 field 3 (dx) is 1e160, beyond the translation limit (at most 1e8 m, "
                 "PGEM_TRANSLATION_LIMIT)");
    expect_error("far_pose.g2o", "VERTEX_SE2 0 0 -1.5e8 0\n", PGEM_ERR_OUT_OF_RANGE,
                 "far_pose.g2o:1:", "VERTEX_SE2 field 3 (y) is -1.5e8, beyond the translation");
    expect_error("far_3d.g2o", "VERTEX_SE3:QUAT 0 0 0 1e300 0 0 0 1\n", PGEM_ERR_OUT_OF_RANGE,
                 "far_3d.g2o:1:", "VERTEX_SE3:QUAT field 4 (z) is 1e300");
    expect_error("strong.g2o", HEAD2 "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 2e15\n", PGEM_ERR_OUT_OF_RANGE,
                 "strong.g2o:3:", "EDGE_SE2 field 11 (I33) is 2e15, beyond the information limit "
                 "(at most 1e15, PGEM_INFORMATION_LIMIT)");
    expect_error("strong.graph", "VERTEX2 0 0 0 0\nVERTEX2 1 0 0 0\nEDGE2 0 1 1 0 0 1 0 1 1 -1e16 0\n",
                 PGEM_ERR_OUT_OF_RANGE, "strong.graph:3:", "EDGE2 field 10 (Ixt) is -1e16");
    read_ok("limits.g2o", HEAD2 "EDGE_SE2 0 1 1e8 -1e8 1e300 1e15 -1e15 0 1e15 0 1e15\n", &graph);
    assert_int_equal(graph.edge_count, 1);
    pgem_io_graph_free(&graph);
}

static void test_error_ids(void **state)
{
    (void)state;
    expect_error("negid.g2o", "VERTEX_SE2 -1 0 0 0\n", PGEM_ERR_PARSE, "negid.g2o:1:",
                 "VERTEX_SE2 field 1 (id) is not an unsigned 64-bit id: '-1'");
    expect_error("plusid.g2o", HEAD2 "EDGE_SE2 0 +1 1 0 0" INFO2 "\n", PGEM_ERR_PARSE,
                 "plusid.g2o:3:", "field 2 (j) is not an unsigned 64-bit id: '+1'");
    expect_error("bigid.g2o", "VERTEX_SE2 18446744073709551616 0 0 0\n", PGEM_ERR_PARSE,
                 "bigid.g2o:1:", "field 1 (id) is not an unsigned 64-bit id");
    expect_error("hexid.g2o", "VERTEX_SE2 0x10 0 0 0\n", PGEM_ERR_PARSE, "hexid.g2o:1:",
                 "'0x10'");
    expect_error("floatid.g2o", "VERTEX_SE2 1.0 0 0 0\n", PGEM_ERR_PARSE, "floatid.g2o:1:",
                 "'1.0'");
    expect_error("fixid.g2o", HEAD2 "FIX 0 x\n", PGEM_ERR_PARSE, "fixid.g2o:3:",
                 "FIX field 2 (id) is not an unsigned 64-bit id: 'x'");
}

static void test_error_dimension(void **state)
{
    (void)state;
    expect_error("dim.g2o", "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE2 1 0 0 0\n",
                 PGEM_ERR_DIMENSION, "dim.g2o:2:", "VERTEX_SE2 is a 2D line but the file is 3D");
    expect_error("dim2.g2o", HEAD2 "\nEDGE_SE3:QUAT 0 1 0 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 "
                 "0 0 1 0 0 1 0 1\n",
                 PGEM_ERR_DIMENSION, "dim2.g2o:4:", "decided by line 1");
    expect_error("dim3.g2o", "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nEDGE2 0 1 0 0 0 1 0 1 1 0 0\n",
                 PGEM_ERR_DIMENSION, "dim3.g2o:2:", "EDGE2 is a 2D line");
}

static void test_error_duplicate_and_unknown_ids(void **state)
{
    (void)state;
    expect_error("dup.g2o", "VERTEX_SE2 5 0 0 0\nVERTEX_SE2 6 0 0 0\nVERTEX_SE2 5 1 1 1\n"
                            "VERTEX_SE2 6 1 1 1\n",
                 PGEM_ERR_DUPLICATE_ID, "dup.g2o:3:", "duplicate VERTEX id 5 (first on line 1)");
    expect_error("dup64.g2o", "VERTEX_SE2 18446744073709551615 0 0 0\nVERTEX_SE2 1 0 0 0\n"
                              "VERTEX_SE2 18446744073709551615 0 0 0\n",
                 PGEM_ERR_DUPLICATE_ID, "dup64.g2o:3:", "id 18446744073709551615");
    expect_error("unknown.g2o", HEAD2 "EDGE_SE2 0 1 1 0 0" INFO2 "\nEDGE_SE2 1 7 1 0 0" INFO2
                                "\nEDGE_SE2 9 0 1 0 0" INFO2 "\n",
                 PGEM_ERR_UNKNOWN_ID, "unknown.g2o:4:", "names id 7, which has no VERTEX line");
    expect_error("unknown_from.g2o", HEAD2 "EDGE_SE2 3 1 1 0 0" INFO2 "\n", PGEM_ERR_UNKNOWN_ID,
                 "unknown_from.g2o:3:", "edge 3 -> 1 names id 3");
    /* an edge before the VERTEX lines it names is fine; an edge-only file gets chained poses,
     * but one VERTEX line makes every other id unknown */
    expect_error("partial.g2o", "EDGE_SE2 0 1 1 0 0" INFO2 "\nVERTEX_SE2 0 0 0 0\n",
                 PGEM_ERR_UNKNOWN_ID, "partial.g2o:1:", "names id 1");
    expect_error("fix_unknown.g2o", HEAD2 "FIX 1\nFIX 9\n", PGEM_ERR_UNKNOWN_ID,
                 "fix_unknown.g2o:4:", "FIX names id 9");
    expect_error("fix_only.g2o", "FIX 0\n", PGEM_ERR_UNKNOWN_ID, "fix_only.g2o:1:", "id 0");
    expect_error("fix_chain.g2o", "EDGE_SE2 0 1 1 0 0" INFO2 "\nFIX 2\n", PGEM_ERR_UNKNOWN_ID,
                 "fix_chain.g2o:2:", "FIX names id 2");
}

/* A file whose line 2 has length bytes (a comment), then a vertex. */
static int read_long_line(size_t length, const char *line_end, pgem_io_graph_t *graph,
                          char *message, size_t message_size)
{
    const char *head = "VERTEX_SE2 0 0 0 0\n";
    const char *tail = "VERTEX_SE2 1 0 0 0\n";
    size_t total = strlen(head) + length + strlen(line_end) + strlen(tail);
    char *text = (char *)malloc(total + 1);
    char path[512];
    int status;
    assert_non_null(text);
    strcpy(text, head);
    memset(text + strlen(head), 'x', length);
    text[strlen(head)] = '#';
    strcpy(text + strlen(head) + length, line_end);
    strcat(text, tail);
    temp_path(path, sizeof path, "long.g2o");
    write_bytes(path, text, total);
    free(text);
    status = pgem_io_read(path, PGEM_FORMAT_AUTO, graph, message, message_size);
    return status;
}

static void test_error_long_line(void **state)
{
    pgem_io_graph_t graph;
    char message[512];
    (void)state;
    assert_int_equal(read_long_line(65536, "\n", &graph, message, sizeof message), PGEM_OK);
    assert_int_equal(graph.pose_count, 2);
    pgem_io_graph_free(&graph);
    assert_int_equal(read_long_line(65536, "\r\n", &graph, message, sizeof message), PGEM_OK);
    assert_int_equal(graph.pose_count, 2);
    pgem_io_graph_free(&graph);
    assert_int_equal(read_long_line(65537, "\n", &graph, message, sizeof message),
                     PGEM_ERR_PARSE);
    assert_contains(message, "long.g2o:2: line is longer than 65536 bytes");
    assert_graph_empty(&graph);
    assert_int_equal(read_long_line(65537, "\r\n", &graph, message, sizeof message),
                     PGEM_ERR_PARSE);
    assert_contains(message, "long.g2o:2: line is longer than 65536 bytes");
    assert_graph_empty(&graph);
    assert_int_equal(read_long_line(1000000, "", &graph, message, sizeof message),
                     PGEM_ERR_PARSE);
    assert_contains(message, "long.g2o:2:");
    assert_graph_empty(&graph);
}

/* A stream that never ends: every read gets `fill` bytes, up to `limit` in all (then the end,
 * so a reader that reads to the end still finishes); `served` counts what was handed out. */
typedef struct endless {
    char fill;
    size_t served;
    size_t limit;
} endless_t;

static ssize_t endless_read(void *cookie, char *buffer, size_t size)
{
    endless_t *endless = (endless_t *)cookie;
    size_t left = endless->limit - endless->served;
    size_t given = size < left ? size : left;
    memset(buffer, endless->fill, given);
    endless->served += given;
    return (ssize_t)given;
}

/* Reads an endless stream of `fill` bytes; returns the status, *served the bytes it took. */
static int read_endless(char fill, size_t *served, char *message, size_t message_size)
{
    endless_t endless = {fill, 0, (size_t)64 << 20};
    cookie_io_functions_t functions = {endless_read, NULL, NULL, NULL};
    pgem_io_graph_t graph;
    FILE *stream = fopencookie(&endless, "r", functions);
    assert_non_null(stream);
    int status = pgem_io_read_stream(stream, "endless", PGEM_FORMAT_AUTO, &graph, message,
                                     message_size);
    fclose(stream);
    assert_graph_empty(&graph);
    *served = endless.served;
    return status;
}

/* A line with no end (a pipe, /dev/zero) is refused as soon as it is known to be too long or
 * to hold a NUL, not read to its end first (before: 64 MiB here, forever from /dev/zero). */
static void test_endless_line_stops_at_the_limit(void **state)
{
    char message[512];
    size_t served = 0;
    (void)state;
    assert_int_equal(read_endless('x', &served, message, sizeof message), PGEM_ERR_PARSE);
    assert_contains(message, "endless:1: line is longer than 65536 bytes");
    assert_true(served <= (size_t)4 << 16); /* the reader's chunks plus stdio's buffer */
    assert_int_equal(read_endless('\0', &served, message, sizeof message), PGEM_ERR_PARSE);
    assert_contains(message, "endless:1: line contains a NUL byte");
    assert_true(served <= (size_t)4 << 16);
}

static void test_error_nul_and_missing_file(void **state)
{
    pgem_io_graph_t graph;
    char message[512];
    char path[512];
    const char text[] = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0\0 0 0\n";
    (void)state;
    temp_path(path, sizeof path, "nul.g2o");
    write_bytes(path, text, sizeof text - 1);
    assert_int_equal(pgem_io_read(path, PGEM_FORMAT_AUTO, &graph, message, sizeof message),
                     PGEM_ERR_PARSE);
    assert_contains(message, "nul.g2o:2: line contains a NUL byte");
    assert_graph_empty(&graph);
    temp_path(path, sizeof path, "does_not_exist.g2o");
    remove(path);
    assert_int_equal(pgem_io_read(path, PGEM_FORMAT_AUTO, &graph, message, sizeof message),
                     PGEM_ERR_IO);
    assert_contains(message, "does_not_exist.g2o: cannot open");
    assert_graph_empty(&graph);
    assert_int_equal(pgem_io_read(NULL, PGEM_FORMAT_AUTO, &graph, message, sizeof message),
                     PGEM_ERR_INVALID_ARGUMENT);
    /* a NULL message buffer is allowed */
    assert_int_equal(pgem_io_read(path, PGEM_FORMAT_AUTO, &graph, NULL, 0), PGEM_ERR_IO);
}

static void test_empty_and_garbage(void **state)
{
    pgem_io_graph_t graph;
    char message[512];
    char path[512];
    char garbage[8192];
    unsigned long seed = 12345;
    size_t i;
    int round;
    (void)state;
    assert_int_equal(read_text("empty.g2o", "", &graph, message, sizeof message), PGEM_OK);
    assert_graph_empty(&graph);
    assert_string_equal(message, "");
    pgem_io_graph_free(&graph);
    read_ok("blank.g2o", "\n\n# only a comment\r\n  \t \n", &graph);
    assert_graph_empty(&graph);
    temp_path(path, sizeof path, "garbage.bin");
    for (round = 0; round < 20; ++round) {
        for (i = 0; i < sizeof garbage; ++i) {
            seed = seed * 1103515245ul + 12345ul;
            garbage[i] = (char)((seed >> 16) & 0xff);
            if (round % 2 == 1 && garbage[i] == '\0') {
                garbage[i] = 'E'; /* odd rounds: no NUL bytes, so every line is tokenised */
            }
        }
        write_bytes(path, garbage, sizeof garbage);
        {
            int status = pgem_io_read(path, PGEM_FORMAT_AUTO, &graph, message, sizeof message);
            if (status != PGEM_OK) {
                assert_contains(message, "garbage.bin:");
                assert_graph_empty(&graph);
            } else {
                assert_int_equal(graph.pose_count, 0);
                assert_true(graph.unknown_lines > 0);
            }
            pgem_io_graph_free(&graph);
        }
    }
}

static void test_read_stream(void **state)
{
    pgem_io_graph_t graph;
    char message[512];
    char text[] = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 0 0 0 0\n";
    FILE *stream = fmemopen(text, strlen(text), "r");
    (void)state;
    assert_non_null(stream);
    assert_int_equal(pgem_io_read_stream(stream, NULL, PGEM_FORMAT_AUTO, &graph, message,
                                         sizeof message),
                     PGEM_ERR_DUPLICATE_ID);
    assert_string_equal(message, "(stream):2: duplicate VERTEX id 0 (first on line 1)");
    assert_graph_empty(&graph);
    fclose(stream);
    stream = fmemopen(text, strlen(text) - 19, "r");
    assert_non_null(stream);
    assert_int_equal(pgem_io_read_stream(stream, "memory", PGEM_FORMAT_G2O, &graph, message,
                                         sizeof message),
                     PGEM_OK);
    assert_int_equal(graph.pose_count, 1);
    assert_string_equal(graph.source, "memory");
    fclose(stream);
    pgem_io_graph_free(&graph);
    pgem_io_graph_free(&graph); /* freeing twice is harmless: the graph is zeroed */
    pgem_io_graph_free(NULL);
}

/* ---------------------------------------------------------------- accepted variants */

static void test_crlf_tabs_comments(void **state)
{
    pgem_io_graph_t graph;
    (void)state;
    read_ok("crlf.g2o",
            "# header comment\r\n\r\n  # indented comment\r\n"
            "VERTEX_SE2\t0\t1.5  2 0.25\r\n \t\r\n"
            "VERTEX_SE2 1 0 0 0  \t\r\n"
            "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\r\n"
            "FIX 0 1", &graph);
    assert_int_equal(graph.pose_count, 2);
    assert_int_equal(graph.edge_count, 1);
    assert_int_equal(graph.poses[0].line, 4);
    assert_true(graph.poses[0].pose[0] == 1.5);
    assert_true(graph.poses[0].pose[2] == 0.25);
    assert_int_equal(graph.edges[0].line, 7);
    assert_int_equal(graph.fixed_count, 2);
    assert_int_equal(graph.unknown_lines, 0);
    assert_int_equal(graph.chained_poses, 0);
    assert_contains(graph.source, "crlf.g2o");
    pgem_io_graph_free(&graph);
}

static void test_unknown_tags_and_equiv(void **state)
{
    pgem_io_graph_t graph;
    (void)state;
    read_ok("tags.graph",
            "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEQUIV 0 1\n"
            "VERTEX3 2 0 0 0 0 0 0\nPOINT 4 1 2\nEDGE2 1 0 1 0 0 1 0 1 1 0 0\n"
            "EQUIV 1 0\nvertex_se2 9 0 0 0\n", &graph);
    assert_int_equal(graph.pose_count, 2);
    assert_int_equal(graph.edge_count, 1);
    assert_int_equal(graph.equiv_lines, 2);
    assert_int_equal(graph.unknown_lines, 3);
    assert_string_equal(graph.first_unknown_tag, "VERTEX3");
    assert_int_equal(graph.first_unknown_line, 4);
    pgem_io_graph_free(&graph);
    /* with an explicit format, the other format's tags are unknown */
    read_ok_as("g2o_as_toro.g2o", HEAD2 "FIX 0\n", PGEM_FORMAT_TORO, &graph);
    assert_int_equal(graph.pose_count, 0);
    assert_int_equal(graph.unknown_lines, 3);
    assert_string_equal(graph.first_unknown_tag, "VERTEX_SE2");
    pgem_io_graph_free(&graph);
    read_ok_as("toro_as_g2o.graph", "VERTEX2 0 0 0 0\nEQUIV 0 1\n", PGEM_FORMAT_G2O, &graph);
    assert_int_equal(graph.unknown_lines, 2);
    assert_int_equal(graph.equiv_lines, 0);
    pgem_io_graph_free(&graph);
    /* an overlong, unprintable tag is cut and sanitised */
    read_ok("weird_tag.g2o",
            "A\x01\x7f" "BCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 1 2\n", &graph);
    assert_string_equal(graph.first_unknown_tag, "A??BCDEFGHIJKLMNOPQRSTUVWXYZ012");
    pgem_io_graph_free(&graph);
}

static void test_edge_kinds(void **state)
{
    pgem_io_graph_t graph;
    (void)state;
    read_ok("kinds.g2o",
            "EDGE_SE2 0 1 1 0 0" INFO2 "\nEDGE_SE2 2 1 1 0 0" INFO2
            "\nEDGE_SE2 0 2 1 0 0" INFO2 "\nEDGE_SE2 18446744073709551615 0 "
            "1 0 0" INFO2 "\nEDGE_SE2 0 18446744073709551615 1 0 0" INFO2
            "\nEDGE_SE2 18446744073709551615 18446744073709551614 1 0 0" INFO2
            "\n", &graph);
    assert_int_equal(graph.edge_count, 6);
    assert_int_equal(graph.edges[0].kind, PGEM_EDGE_ODOMETRY);
    assert_int_equal(graph.edges[1].kind, PGEM_EDGE_ODOMETRY);
    assert_true(graph.edges[1].from == 2 && graph.edges[1].to == 1); /* kept as written */
    assert_int_equal(graph.edges[2].kind, PGEM_EDGE_LOOP);
    assert_int_equal(graph.edges[3].kind, PGEM_EDGE_LOOP);
    assert_int_equal(graph.edges[4].kind, PGEM_EDGE_LOOP);
    assert_int_equal(graph.edges[5].kind, PGEM_EDGE_ODOMETRY);
    pgem_io_graph_free(&graph);
}

/* Between ids i and i+1 the first edge in file order is odometry and later ones are loop
 * closures; the writer puts a pair's odometry first, so a loop closure between consecutive
 * poses keeps its kind through a write and a read (it used to come back as odometry). */
static void test_consecutive_loop_kinds(void **state)
{
    static const pgem_id_t pairs[5][2] = {{1, 2}, {0, 1}, {1, 2}, {2, 3}, {3, 0}};
    static const pgem_edge_kind_t kinds[5] = {PGEM_EDGE_LOOP, PGEM_EDGE_ODOMETRY,
                                              PGEM_EDGE_ODOMETRY, PGEM_EDGE_ODOMETRY,
                                              PGEM_EDGE_LOOP};
    const double information[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const double step[3] = {1, 0, 0};
    pgem_config_t config = {2, 4, 5, 0, 0, 0};
    pgem_io_graph_t graph;
    pgem_io_graph_t copy;
    pgem_t *instance = NULL;
    char path[512];
    char message[512];
    size_t k;
    (void)state;
    read_ok("repeat.g2o",
            "EDGE_SE2 0 1 1 0 0" INFO2 "\nEDGE_SE2 1 0 -1 0 0" INFO2 "\nEDGE_SE2 1 2 1 0 0" INFO2
            "\nEDGE_SE2 0 1 1 0 0" INFO2 "\n", &graph);
    assert_int_equal(graph.edges[0].kind, PGEM_EDGE_ODOMETRY);
    assert_int_equal(graph.edges[1].kind, PGEM_EDGE_LOOP);
    assert_int_equal(graph.edges[2].kind, PGEM_EDGE_ODOMETRY);
    assert_int_equal(graph.edges[3].kind, PGEM_EDGE_LOOP);
    pgem_io_graph_free(&graph);

    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    for (k = 0; k < 4; ++k) {
        const double pose[3] = {(double)k, 0, 0};
        assert_int_equal(pgem_add_pose(instance, (pgem_id_t)k, pose), PGEM_OK);
    }
    for (k = 0; k < 5; ++k) { /* the loop 1 -> 2 before the odometry 1 -> 2 */
        assert_int_equal(pgem_add_edge(instance, pairs[k][0], pairs[k][1], step, information,
                                       kinds[k], NULL),
                         PGEM_OK);
    }
    assert_int_equal(pgem_io_from_instance(instance, &graph), PGEM_OK);
    temp_path(path, sizeof path, "consecutive_loop.g2o");
    assert_int_equal(pgem_io_write(path, PGEM_FORMAT_G2O, &graph, message, sizeof message),
                     PGEM_OK);
    assert_int_equal(pgem_io_read(path, PGEM_FORMAT_G2O, &copy, message, sizeof message),
                     PGEM_OK);
    assert_int_equal(copy.edge_count, 5);
    for (k = 0; k < 5; ++k) { /* the odometry 1 -> 2 took the loop's place, and back */
        const size_t from = k == 0 ? 2 : k == 2 ? 0 : k;
        assert_true(copy.edges[k].from == graph.edges[from].from &&
                    copy.edges[k].to == graph.edges[from].to);
        assert_int_equal(copy.edges[k].kind, graph.edges[from].kind);
    }
    pgem_io_graph_free(&copy);
    pgem_io_graph_free(&graph);
    pgem_destroy(instance);
}

/* A UTF-8 byte order mark at the start is skipped: without that, the first line's tag was
 * unknown and the line silently left out (an edge-only file lost its first edge). */
static void test_byte_order_mark(void **state)
{
    pgem_io_graph_t graph;
    (void)state;
    read_ok("bom.g2o", "\xEF\xBB\xBFVERTEX_SE2 0 0 0 0\r\nVERTEX_SE2 1 1 0 0\r\n"
                       "EDGE_SE2 0 1 1 0 0" INFO2 "\r\n", &graph);
    assert_int_equal(graph.pose_count, 2);
    assert_int_equal(graph.edge_count, 1);
    assert_int_equal(graph.unknown_lines, 0);
    assert_int_equal(graph.poses[0].line, 1);
    pgem_io_graph_free(&graph);
    read_ok("bom_edges.g2o", "\xEF\xBB\xBF" "EDGE_SE2 0 1 1 0 0" INFO2 "\nEDGE_SE2 1 2 1 0 0" INFO2
                             "\n", &graph);
    assert_int_equal(graph.edge_count, 2);
    assert_int_equal(graph.pose_count, 3);
    assert_int_equal(graph.unknown_lines, 0);
    pgem_io_graph_free(&graph);
    /* only at the start of the file: elsewhere it is part of an (unknown) tag */
    read_ok("bom_late.g2o", HEAD2 "\xEF\xBB\xBFVERTEX_SE2 2 0 0 0\n", &graph);
    assert_int_equal(graph.pose_count, 2);
    assert_int_equal(graph.unknown_lines, 1);
    assert_int_equal(graph.first_unknown_line, 3);
    pgem_io_graph_free(&graph);
}

/* Ids at the top of the 64-bit range are ordinary ids (none is reserved); one past is refused. */
static void test_ids_near_two_to_the_64(void **state)
{
    pgem_io_graph_t graph;
    pgem_io_graph_t copy;
    const pgem_id_t ids[] = {UINT64_C(9223372036854775807), UINT64_C(9223372036854775808),
                             UINT64_C(18446744073709551614), UINT64_C(18446744073709551615), 0};
    (void)state;
    read_ok("top_ids.g2o",
            "VERTEX_SE2 9223372036854775807 0 0 0\nVERTEX_SE2 9223372036854775808 1 0 0\n"
            "VERTEX_SE2 18446744073709551614 2 0 0\nVERTEX_SE2 18446744073709551615 3 0 0\n"
            "VERTEX_SE2 0 4 0 0\n"
            "EDGE_SE2 9223372036854775807 9223372036854775808 1 0 0" INFO2 "\n"
            "EDGE_SE2 18446744073709551614 18446744073709551615 1 0 0" INFO2 "\n"
            "EDGE_SE2 18446744073709551615 0 1 0 0" INFO2 "\n"
            "EDGE_SE2 9223372036854775808 18446744073709551614 1 0 0" INFO2 "\n",
            &graph);
    assert_int_equal(graph.pose_count, 5);
    for (size_t k = 0; k < 5; ++k) {
        assert_true(graph.poses[k].id == ids[k]);
    }
    assert_int_equal(graph.edges[0].kind, PGEM_EDGE_ODOMETRY);
    assert_int_equal(graph.edges[1].kind, PGEM_EDGE_ODOMETRY);
    assert_int_equal(graph.edges[2].kind, PGEM_EDGE_LOOP); /* 2^64 - 1 and 0: no wrap-around */
    assert_int_equal(graph.edges[3].kind, PGEM_EDGE_LOOP);
    pgem_t *instance = test_load_graph(&graph);
    assert_int_equal(pgem_io_from_instance(instance, &copy), PGEM_OK);
    for (size_t k = 0; k < 5; ++k) {
        assert_true(copy.poses[k].id == ids[k]);
    }
    round_trip(&copy, PGEM_FORMAT_G2O, "top_ids_out.g2o");
    pgem_io_graph_free(&copy);
    pgem_destroy(instance);
    pgem_io_graph_free(&graph);
    expect_error("past_top.g2o", "EDGE_SE2 0 18446744073709551616 1 0 0" INFO2 "\n",
                 PGEM_ERR_PARSE, "past_top.g2o:1:",
                 "EDGE_SE2 field 2 (j) is not an unsigned 64-bit id: '18446744073709551616'");
    expect_error("neg_edge.g2o", "EDGE_SE2 -9223372036854775808 1 1 0 0" INFO2 "\n",
                 PGEM_ERR_PARSE, "neg_edge.g2o:1:",
                 "EDGE_SE2 field 1 (i) is not an unsigned 64-bit id: '-9223372036854775808'");
}

/* Lines of every length, so that line ends fall at every position of the reader's chunks. */
static void test_lines_across_chunks(void **state)
{
    enum { POSES = 3000 };
    size_t capacity = (size_t)POSES * 400u;
    char *text = (char *)malloc(capacity);
    size_t used = 0;
    pgem_io_graph_t graph;
    (void)state;
    assert_non_null(text);
    for (int k = 0; k < POSES; ++k) {
        used += (size_t)snprintf(text + used, capacity - used, "%*sVERTEX_SE2 %d %d.5 0 0%s\n",
                                 (k * 37) % 311, "", k, k, k % 3 == 0 ? "\r" : "");
    }
    read_ok("chunks.g2o", text, &graph);
    free(text);
    assert_int_equal(graph.pose_count, POSES);
    for (int k = 0; k < POSES; ++k) {
        assert_true(graph.poses[k].id == (pgem_id_t)k);
        assert_true(graph.poses[k].pose[0] == k + 0.5);
        assert_int_equal(graph.poses[k].line, (unsigned long)k + 1u);
    }
    pgem_io_graph_free(&graph);
}

/* ---------------------------------------------------------------- chain guess */

static void test_chain_2d(void **state)
{
    pgem_io_graph_t graph;
    (void)state;
    /* the loop 0-2 comes first but odometry wins; 2 -> 1 is walked backwards; 10-11 is a
     * separate component (identity); 1 -> 5 is the loop that reaches 5, then 5-6 is odometry */
    read_ok("chain.g2o",
            "EDGE_SE2 0 2 5 0 0" INFO2 "\n"
            "EDGE_SE2 0 1 1 0 1.5707963267948966" INFO2 "\n"
            "EDGE_SE2 2 1 1 0 -1.5707963267948966" INFO2 "\n"
            "EDGE_SE2 10 11 3 0 0" INFO2 "\n"
            "EDGE_SE2 6 5 0 2 0" INFO2 "\n"
            "EDGE_SE2 1 5 0 1 0" INFO2 "\n", &graph);
    assert_int_equal(graph.dimension, 2);
    assert_int_equal(graph.pose_count, 7);
    assert_int_equal(graph.chained_poses, 7);
    {
        const pgem_id_t ids[7] = {0, 1, 2, 5, 6, 10, 11};
        size_t i;
        for (i = 0; i < 7; ++i) {
            assert_true(graph.poses[i].id == ids[i]);
            assert_int_equal(graph.poses[i].line, 0);
        }
    }
    assert_near(graph.poses[0].pose[0], 0.0, 0.0);
    assert_near(graph.poses[1].pose[0], 1.0, 1e-12);
    assert_near(graph.poses[1].pose[1], 0.0, 1e-12);
    assert_near(graph.poses[1].pose[2], PI / 2, 1e-12);
    /* pose2 = pose1 * (1, 0, -pi/2)^-1 = (2, 0, pi) */
    assert_near(graph.poses[2].pose[0], 2.0, 1e-12);
    assert_near(graph.poses[2].pose[1], 0.0, 1e-12);
    assert_near(fabs(graph.poses[2].pose[2]), PI, 1e-12);
    /* pose5 = pose1 * (0, 1, 0) = (0, 0, pi/2); pose6 = pose5 * (0, 2, 0)^-1 = (2, 0, pi/2) */
    assert_near(graph.poses[3].pose[0], 0.0, 1e-12);
    assert_near(graph.poses[3].pose[1], 0.0, 1e-12);
    assert_near(graph.poses[4].pose[0], 2.0, 1e-12);
    assert_near(graph.poses[4].pose[1], 0.0, 1e-12);
    assert_near(graph.poses[4].pose[2], PI / 2, 1e-12);
    /* the disconnected component stays at the identity */
    assert_true(graph.poses[5].pose[0] == 0.0 && graph.poses[6].pose[0] == 0.0);
    pgem_io_graph_free(&graph);
}

static void test_chain_3d(void **state)
{
    pgem_io_graph_t graph;
    const double h = 0.70710678118654752;
    (void)state;
    /* 0 -> 1: forward 1 and a 90 degree yaw (quaternion written at twice unit length);
     * 2 -> 1 walked backwards: pose2 = pose1 * (0 0 1)^-1 */
    read_ok("chain3d.g2o",
            "EDGE_SE3:QUAT 0 1 1 0 0 0 0 1.4142135623730951 "
            "1.4142135623730951 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\n"
            "EDGE_SE3:QUAT 2 1 0 0 1 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 "
            "1 0 0 1 0 1\n", &graph);
    assert_int_equal(graph.dimension, 3);
    assert_int_equal(graph.chained_poses, 3);
    assert_true(graph.poses[0].pose[6] == 1.0);
    assert_near(graph.poses[1].pose[0], 1.0, 1e-12);
    assert_near(graph.poses[1].pose[5], h, 1e-12);
    assert_near(graph.poses[1].pose[6], h, 1e-12);
    assert_near(graph.poses[2].pose[0], 1.0, 1e-12);
    assert_near(graph.poses[2].pose[1], 0.0, 1e-12);
    assert_near(graph.poses[2].pose[2], -1.0, 1e-12);
    assert_near(fabs(graph.poses[2].pose[5]), h, 1e-12);
    assert_near(fabs(graph.poses[2].pose[6]), h, 1e-12);
    /* the measurement is kept as read */
    assert_true(graph.edges[0].measurement[6] == 1.4142135623730951);
    pgem_io_graph_free(&graph);
}

/* Found by fuzzing (tests/fuzz/fuzz_g2o): in an edge-only file, measurements near the double
 * range composed into a pose guess of Inf; the read succeeded with it, the load then failed on
 * a pose no line wrote, and writing the graph gave "inf", which does not read back. */
static void test_chain_guess_not_finite(void **state)
{
    (void)state;
    /* each measurement within the translation limit, their sum beyond it */
    expect_error("chain_inf.g2o",
                 "EDGE_SE2 0 1 9e7 0 0" INFO2 "\nEDGE_SE2 1 2 9e7 0 0" INFO2 "\n",
                 PGEM_ERR_OUT_OF_RANGE, "chain_inf.g2o:2:",
                 "edge 1 -> 2: the pose guessed for id 2 by composing the measurements from "
                 "id 1 is beyond the translation limit");
    /* walked backwards: pose(from) = pose(to) * z^-1 */
    expect_error("chain_inf_back.g2o",
                 "EDGE_SE2 9 0 -9e7 0 0" INFO2 "\nEDGE_SE2 10 9 -9e7 0 0" INFO2 "\n",
                 PGEM_ERR_OUT_OF_RANGE, "chain_inf_back.g2o:2:",
                 "edge 10 -> 9: the pose guessed for id 10 by composing the measurements from "
                 "id 9 is beyond the translation limit");
    /* 1e308 twice was the overflow this test was written for: the reader refuses 1e308 now */
    expect_error("chain_overflow.g2o", "EDGE_SE2 0 1 1e308 0 0" INFO2 "\n", PGEM_ERR_OUT_OF_RANGE,
                 "chain_overflow.g2o:1:", "EDGE_SE2 field 3 (dx) is 1e308, beyond the "
                 "translation limit (at most 1e8 m, PGEM_TRANSLATION_LIMIT)");
}

/* Found by fuzzing: a measurement quaternion too large to normalise (its norm overflows)
 * became a zero rotation in the guess, so loading failed on a pose no line wrote; now the
 * guess keeps the identity rotation and the load names the edge's own line. */
static void test_chain_guess_huge_quaternion(void **state)
{
    pgem_io_graph_t graph;
    char message[512];
    (void)state;
    read_ok("chain_huge_q.g2o",
            "EDGE_SE3:QUAT 0 1 1 0 0 1e200 1e200 0 1e200 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 "
            "1\n", &graph);
    assert_int_equal(graph.chained_poses, 2);
    assert_true(graph.poses[1].pose[0] == 1.0);
    assert_true(graph.poses[1].pose[3] == 0.0 && graph.poses[1].pose[6] == 1.0);
    pgem_config_t config;
    pgem_io_config(&graph, &config);
    pgem_t *instance = NULL;
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    assert_int_equal(pgem_io_load(&graph, instance, message, sizeof message), PGEM_ERR_ROTATION);
    assert_contains(message, "chain_huge_q.g2o:1: measurement: quaternion (qx qy qz qw) norm is not "
                             "within 1% of 1 (edge 0 -> 1)");
    pgem_destroy(instance);
    pgem_io_graph_free(&graph);
}

/* ---------------------------------------------------------------- datasets */

typedef struct dataset {
    const char *file;      /* under PGEM_DATASETS */
    int dimension;
    size_t poses;
    size_t edges;
    size_t equiv;
    size_t chained;
} dataset_t;

static const dataset_t datasets[] = {
    {"2d/manhattanOlson3500.g2o", 2, 3500, 5598, 0, 0},
    {"2d/manhattanOlson3500_g2o-version.g2o", 2, 3500, 5598, 0, 0},
    {"2d/input_M3500_g2o.g2o", 2, 3500, 5453, 0, 0},
    {"2d/manhattan.g2o", 2, 3500, 5453, 0, 3500},
    {"2d/M3500.txt", 2, 3500, 5453, 0, 0},
    {"2d/intel.g2o", 2, 943, 1837, 0, 0},
    {"2d/intel_SE-Sync.g2o", 2, 1728, 2512, 0, 0},
    {"2d/input_INTEL_g2o.g2o", 2, 1228, 1483, 0, 0},
    {"2d/city10000.g2o", 2, 10000, 20687, 0, 0},
    {"2d/input_MITb_g2o.g2o", 2, 808, 827, 0, 0},
    {"2d/pose2example.txt", 2, 11, 12, 0, 0},
    {"2d/noisyToyGraph.txt", 2, 4, 5, 0, 0},
    {"2d/w100.graph", 2, 100, 300, 40, 0},
    {"3d/sphere2500.g2o", 3, 2500, 4949, 0, 0},
    {"3d/smallGrid3D.g2o", 3, 125, 297, 0, 0},
    {"3d/tinyGrid3D.g2o", 3, 9, 11, 0, 0},
    {"3d/pose3example.txt", 3, 5, 6, 0, 0},
    {"3d/pose3example-grid.txt", 3, 27, 44, 0, 0},
    {"3d/toyExample.g2o", 3, 5, 6, 0, 0},
    {"3d/Klaus3.g2o", 3, 3, 3, 0, 0},
    {"3d/ordered.g2o", 3, 140, 153, 0, 0},
    {"3d/unordered.g2o", 3, 140, 153, 0, 0},
    {"3d/robot_a.g2o", 3, 50, 52, 0, 0},
    {"3d/robot_b.g2o", 3, 42, 43, 0, 0},
};

#define DATASET_COUNT (sizeof datasets / sizeof datasets[0])

/* Reads a dataset file (its path below the datasets folder) or fails with the reader's message. */
static void read_dataset(const char *dir, const char *file, pgem_io_graph_t *graph)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    test_read_graph(path, graph);
}

static void check_dataset_counts(const dataset_t *set, const pgem_io_graph_t *graph)
{
    size_t odometry = 0;
    size_t i;
    if (graph->pose_count != set->poses || graph->edge_count != set->edges) {
        fail_msg("%s: %lu poses %lu edges, expected %lu / %lu", set->file,
                 (unsigned long)graph->pose_count, (unsigned long)graph->edge_count,
                 (unsigned long)set->poses, (unsigned long)set->edges);
    }
    assert_int_equal(graph->dimension, set->dimension);
    assert_int_equal(graph->equiv_lines, set->equiv);
    assert_int_equal(graph->chained_poses, set->chained);
    assert_int_equal(graph->unknown_lines, 0);
    for (i = 0; i < graph->edge_count; ++i) {
        odometry += graph->edges[i].kind == PGEM_EDGE_ODOMETRY;
    }
    assert_true(odometry > 0);
}

static void test_datasets_read(void **state)
{
    const char *dir = test_datasets_dir("2d/w100.graph");
    size_t i;
    (void)state;
    if (dir == NULL) {
        skip();
    }
    for (i = 0; i < DATASET_COUNT; ++i) {
        pgem_io_graph_t graph;
        read_dataset(dir, datasets[i].file, &graph);
        check_dataset_counts(&datasets[i], &graph);
        round_trip(&graph, PGEM_FORMAT_G2O, "dataset.g2o");
        if (graph.dimension == 2) {
            round_trip(&graph, PGEM_FORMAT_TORO, "dataset.graph");
        }
        pgem_io_graph_free(&graph);
    }
}

static const pgem_io_pose_t *find_pose(const pgem_io_graph_t *graph, pgem_id_t id)
{
    size_t i;
    for (i = 0; i < graph->pose_count; ++i) {
        if (graph->poses[i].id == id) {
            return &graph->poses[i];
        }
    }
    return NULL;
}

static void test_datasets_details(void **state)
{
    const char *dir = test_datasets_dir("2d/w100.graph");
    pgem_io_graph_t graph;
    size_t i;
    size_t backwards = 0;
    (void)state;
    if (dir == NULL) {
        skip();
    }
    /* Kimera: 64-bit GTSAM symbol keys */
    read_dataset(dir, "3d/robot_a.g2o", &graph);
    assert_true(graph.poses[0].id == 6989586621679009792ULL);
    pgem_io_graph_free(&graph);
    read_dataset(dir, "3d/ordered.g2o", &graph);
    assert_non_null(find_pose(&graph, 8430738502437568512ULL));
    assert_non_null(find_pose(&graph, 8430738502437568514ULL));
    pgem_io_graph_free(&graph);
    /* w100: every edge written newer to older, 99 of them odometry */
    read_dataset(dir, "2d/w100.graph", &graph);
    for (i = 0; i < graph.edge_count; ++i) {
        backwards += graph.edges[i].from > graph.edges[i].to;
    }
    assert_int_equal(backwards, 300);
    assert_true(graph.edges[0].from == 1 && graph.edges[0].to == 0);
    pgem_io_graph_free(&graph);
    /* manhattan.g2o (edge-only) chained along odometry: same guess as composing edges 0..1 */
    read_dataset(dir, "2d/manhattan.g2o", &graph);
    assert_true(graph.poses[0].id == 0 && graph.poses[3499].id == 3499);
    {
        double expected[3];
        pgem_se2_compose(graph.poses[0].pose, graph.edges[0].measurement, expected);
        assert_true(graph.edges[0].from == 0 && graph.edges[0].to == 1);
        assert_near(graph.poses[1].pose[0], expected[0], 1e-12);
        assert_near(graph.poses[1].pose[1], expected[1], 1e-12);
        assert_near(graph.poses[1].pose[0], 1.03039, 1e-12);
    }
    pgem_io_graph_free(&graph);
}

/* ---------------------------------------------------------------- core instance */

static pgem_t *load_graph(const pgem_io_graph_t *graph)
{
    pgem_config_t config;
    pgem_t *instance;
    pgem_io_config(graph, &config);
    assert_int_equal(config.max_poses, graph->pose_count > 0 ? graph->pose_count : 1);
    assert_int_equal(config.max_edges, graph->edge_count > 0 ? graph->edge_count : 1);
    assert_int_equal(config.fill_budget, 0);
    instance = test_load_graph(graph);
    assert_int_equal(pgem_pose_count(instance), graph->pose_count);
    assert_int_equal(pgem_edge_count(instance), graph->edge_count);
    return instance;
}

/* The instance's copy matches the file graph (angles wrapped, quaternions normalised). */
static void assert_graphs_close(const pgem_io_graph_t *file, const pgem_io_graph_t *copy)
{
    size_t pose_size = (size_t)PGEM_POSE_SIZE(file->dimension);
    size_t i;
    size_t k;
    assert_int_equal(file->pose_count, copy->pose_count);
    assert_int_equal(file->edge_count, copy->edge_count);
    for (i = 0; i < file->pose_count; ++i) {
        assert_true(file->poses[i].id == copy->poses[i].id);
        for (k = 0; k < pose_size; ++k) {
            double a = file->poses[i].pose[k];
            double b = copy->poses[i].pose[k];
            if (file->dimension == 2 && k == 2) {
                a = pgem_wrap_angle(a - b);
                b = 0.0;
            }
            assert_near(a, b, 1e-6 * (1.0 + fabs(b)));
        }
    }
    for (i = 0; i < file->edge_count; ++i) {
        assert_true(file->edges[i].from == copy->edges[i].from);
        assert_true(file->edges[i].to == copy->edges[i].to);
        assert_int_equal(file->edges[i].kind, copy->edges[i].kind);
        assert_memory_equal(file->edges[i].information, copy->edges[i].information,
                            sizeof file->edges[i].information);
    }
}

static void test_load_and_from_instance(void **state)
{
    const char *dir = test_datasets_dir("2d/w100.graph");
    const char *const picks[] = {"2d/input_M3500_g2o.g2o", "2d/manhattan.g2o", "2d/w100.graph",
                                 "3d/sphere2500.g2o", "3d/ordered.g2o", "3d/robot_a.g2o"};
    size_t p;
    (void)state;
    if (dir == NULL) {
        skip();
    }
    for (p = 0; p < sizeof picks / sizeof picks[0]; ++p) {
        pgem_io_graph_t graph;
        pgem_io_graph_t copy;
        pgem_t *instance;
        read_dataset(dir, picks[p], &graph);
        instance = load_graph(&graph);
        assert_int_equal(pgem_io_from_instance(instance, &copy), PGEM_OK);
        assert_graphs_close(&graph, &copy);
        round_trip(&copy, PGEM_FORMAT_G2O, "instance.g2o");
        pgem_io_graph_free(&copy);
        pgem_destroy(instance);
        pgem_io_graph_free(&graph);
    }
}

static void test_load_small_with_fix(void **state)
{
    pgem_io_graph_t graph;
    pgem_io_graph_t copy;
    pgem_t *instance;
    int fixed = 0;
    pgem_id_t id = 0;
    (void)state;
    read_ok("fix.g2o", HEAD2 "VERTEX_SE2 2 2 0 0\nFIX 1\n"
                       "EDGE_SE2 0 1 1 0 0" INFO2 "\nEDGE_SE2 2 0 -2 0 0" INFO2
                       "\n", &graph);
    instance = load_graph(&graph);
    assert_int_equal(pgem_pose_at(instance, 1, &id, NULL, &fixed), PGEM_OK);
    assert_true(id == 1);
    assert_int_equal(fixed, 1);
    assert_int_equal(pgem_io_from_instance(instance, &copy), PGEM_OK);
    assert_graphs_identical(&graph, &copy);
    assert_int_equal(copy.fixed_count, 1);
    assert_true(copy.fixed[0] == 1);
    assert_string_equal(copy.source, "");
    round_trip(&copy, PGEM_FORMAT_G2O, "fix_rt.g2o");
    pgem_io_graph_free(&copy);
    pgem_destroy(instance);
    pgem_io_graph_free(&graph);
}

/* Reading succeeds, loading fails in the core: the message names file, line and core text. */
static void expect_load_error(const char *name, const char *text, int code, const char *where)
{
    pgem_io_graph_t graph;
    pgem_config_t config;
    pgem_t *instance = NULL;
    char message[512];
    read_ok(name, text, &graph);
    pgem_io_config(&graph, &config);
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    assert_int_equal(pgem_io_load(&graph, instance, message, sizeof message), code);
    assert_contains(message, where);
    assert_contains(message, pgem_last_error(instance));
    assert_true(strlen(pgem_last_error(instance)) > 0);
    pgem_destroy(instance);
    pgem_io_graph_free(&graph);
}

/* A self-loop constrains nothing: the reader keeps it (with its line) out of the edges, so the
 * file loads and solves; the core still refuses one through its API. */
static void test_self_loops_left_out(void **state)
{
    pgem_io_graph_t graph;
    pgem_config_t config;
    pgem_t *instance = NULL;
    char message[512];
    const double z[3] = {0.0, 0.0, 0.0};
    const double info[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    (void)state;
    read_ok("self.g2o",
            HEAD2 "EDGE_SE2 1 1 0 0 0" INFO2 "\nEDGE_SE2 0 1 1 0 0" INFO2
                  "\nEDGE_SE2 0 0 0.5 0 0" INFO2 "\n",
            &graph);
    assert_int_equal(graph.edge_count, 1);
    assert_int_equal(graph.edges[0].from, 0);
    assert_int_equal(graph.edges[0].to, 1);
    assert_int_equal(graph.edges[0].line, 4);
    assert_int_equal(graph.self_loop_count, 2);
    assert_int_equal(graph.self_loops[0].from, 1);
    assert_int_equal(graph.self_loops[0].to, 1);
    assert_int_equal(graph.self_loops[0].line, 3);
    assert_int_equal(graph.self_loops[1].from, 0);
    assert_int_equal(graph.self_loops[1].line, 5);
    assert_true(graph.self_loops[1].measurement[0] == 0.5);
    pgem_io_config(&graph, &config);
    assert_int_equal(config.max_edges, 1);
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    assert_int_equal(pgem_io_load(&graph, instance, message, sizeof message), PGEM_OK);
    assert_int_equal(pgem_edge_count(instance), 1);
    pgem_destroy(instance);
    pgem_io_graph_free(&graph);
    assert_null(graph.self_loops);
    /* the core's own check is unchanged */
    config.max_edges = 2;
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    assert_int_equal(pgem_add_pose(instance, 1, z), PGEM_OK);
    assert_int_equal(pgem_add_edge(instance, 1, 1, z, info, PGEM_EDGE_LOOP, NULL),
                     PGEM_ERR_SELF_LOOP);
    pgem_destroy(instance);
}

/* One robot's file of a team: with foreign_ids an edge naming another robot's pose is kept and
 * counted (a sender streams it); loading such a graph is refused with nothing added. */
static void test_foreign_ids(void **state)
{
    const char *text = HEAD2 "EDGE_SE2 0 1 1 0 0" INFO2 "\nEDGE_SE2 1 1000005 0 0 0" INFO2
                             "\nEDGE_SE2 2000007 0 0 0 0" INFO2 "\n";
    pgem_io_graph_t graph;
    pgem_config_t config;
    pgem_t *instance = NULL;
    char message[512], path[512];
    pgem_io_read_options_t options;
    (void)state;
    temp_path(path, sizeof path, "robot.g2o");
    write_bytes(path, text, strlen(text));
    /* without the option: refused, naming the id */
    assert_int_equal(pgem_io_read_with(path, NULL, &graph, message, sizeof message),
                     PGEM_ERR_UNKNOWN_ID);
    assert_non_null(strstr(message, "names id 1000005, which has no VERTEX line"));
    memset(&options, 0, sizeof options);
    options.foreign_ids = 1;
    assert_int_equal(pgem_io_read_with(path, &options, &graph, message, sizeof message), PGEM_OK);
    assert_int_equal(graph.pose_count, 2);
    assert_int_equal(graph.edge_count, 3);
    assert_int_equal(graph.foreign_edges, 2);
    assert_int_equal(graph.first_foreign_line, 4);
    assert_int_equal(graph.edges[1].to, 1000005u);
    pgem_io_config(&graph, &config);
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    assert_int_equal(pgem_io_load(&graph, instance, message, sizeof message), PGEM_ERR_UNKNOWN_ID);
    assert_non_null(strstr(message, "robot.g2o:4: 2 edges name an id with no pose"));
    assert_int_equal(pgem_pose_count(instance), 0);
    assert_int_equal(pgem_edge_count(instance), 0);
    pgem_destroy(instance);
    pgem_io_graph_free(&graph);
}

static void test_load_errors(void **state)
{
    pgem_io_graph_t graph;
    pgem_config_t config;
    pgem_t *instance = NULL;
    char message[512];
    (void)state;
    expect_load_error("bad_info.g2o", HEAD2 "\nEDGE_SE2 0 1 1 0 0 1 0 0 -1 0 1\n",
                      PGEM_ERR_INFORMATION, "bad_info.g2o:4: information is not positive "
                      "definite (pivot 1 is not positive) (edge 0 -> 1)");
    expect_load_error("bad_quat.g2o",
                      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 0 0 0 0 0 0 1.05\n",
                      PGEM_ERR_ROTATION, "bad_quat.g2o:2: pose: quaternion (qx qy qz qw) norm is "
                      "not within 1% of 1 (pose id 1)");
    expect_load_error("zero_info.g2o", HEAD2 "EDGE_SE2 0 1 1 0 0 0 0 0 0 0 0\n",
                      PGEM_ERR_INFORMATION,
                      "zero_info.g2o:3: information is not positive definite "
                      "(pivot 0 is not positive) (edge 0 -> 1)");
    expect_load_error("indefinite.g2o", HEAD2 "EDGE_SE2 0 1 1 0 0 1 2 0 1 0 1\n",
                      PGEM_ERR_INFORMATION, "(pivot 1 is not positive)");
    expect_load_error("neg_info_3d.g2o",
                      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n"
                      "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 -1\n",
                      PGEM_ERR_INFORMATION, "neg_info_3d.g2o:3: information is not "
                      "positive definite (pivot 5 is not positive) (edge 0 -> 1)");
    /* a graph larger than the instance's room: refused before anything is added */
    read_ok("too_big.g2o", HEAD2 "VERTEX_SE2 2 0 0 0\nEDGE_SE2 0 1 1 0 0" INFO2 "\n", &graph);
    memset(&config, 0, sizeof config);
    config.dimension = 2;
    config.max_poses = 2;
    config.max_edges = 4;
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    assert_int_equal(pgem_io_load(&graph, instance, message, sizeof message), PGEM_ERR_CAPACITY);
    assert_contains(message, "too_big.g2o: 3 poses do not fit: the instance has room for 2 more "
                             "(max_poses = 2)");
    assert_int_equal(pgem_pose_count(instance), 0);
    pgem_destroy(instance);
    config.max_poses = 8;
    config.max_edges = 1;
    const double pose[3] = {0, 0, 0};
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    assert_int_equal(pgem_add_pose(instance, 9, pose), PGEM_OK);
    assert_int_equal(pgem_add_pose(instance, 8, pose), PGEM_OK);
    assert_int_equal(pgem_add_edge(instance, 9, 8, pose, graph.edges[0].information,
                                   PGEM_EDGE_ODOMETRY, NULL), PGEM_OK);
    assert_int_equal(pgem_io_load(&graph, instance, message, sizeof message), PGEM_ERR_CAPACITY);
    assert_contains(message, "too_big.g2o: 1 edges do not fit: the instance has room for 0 "
                             "more (max_edges = 1)");
    assert_int_equal(pgem_pose_count(instance), 2);
    pgem_destroy(instance);
    pgem_io_graph_free(&graph);
    /* a 3D graph into a 2D instance */
    read_ok("dim_load.g2o", "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n", &graph);
    memset(&config, 0, sizeof config);
    config.dimension = 2;
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    assert_int_equal(pgem_io_load(&graph, instance, message, sizeof message),
                     PGEM_ERR_DIMENSION);
    assert_contains(message, "dim_load.g2o: the graph is 3D but the instance is 2D");
    pgem_destroy(instance);
    pgem_io_graph_free(&graph);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip_g2o_2d),
        cmocka_unit_test(test_round_trip_g2o_3d),
        cmocka_unit_test(test_round_trip_toro),
        cmocka_unit_test(test_write_toro_3d_is_dimension_error),
        cmocka_unit_test(test_write_stream_text),
        cmocka_unit_test(test_information_order_toro_vs_g2o),
        cmocka_unit_test(test_information_order_3d),
        cmocka_unit_test(test_error_field_count),
        cmocka_unit_test(test_error_numbers),
        cmocka_unit_test(test_error_magnitudes),
        cmocka_unit_test(test_error_ids),
        cmocka_unit_test(test_error_dimension),
        cmocka_unit_test(test_error_duplicate_and_unknown_ids),
        cmocka_unit_test(test_error_long_line),
        cmocka_unit_test(test_endless_line_stops_at_the_limit),
        cmocka_unit_test(test_error_nul_and_missing_file),
        cmocka_unit_test(test_empty_and_garbage),
        cmocka_unit_test(test_read_stream),
        cmocka_unit_test(test_crlf_tabs_comments),
        cmocka_unit_test(test_unknown_tags_and_equiv),
        cmocka_unit_test(test_edge_kinds),
        cmocka_unit_test(test_consecutive_loop_kinds),
        cmocka_unit_test(test_byte_order_mark),
        cmocka_unit_test(test_ids_near_two_to_the_64),
        cmocka_unit_test(test_lines_across_chunks),
        cmocka_unit_test(test_chain_2d),
        cmocka_unit_test(test_chain_3d),
        cmocka_unit_test(test_chain_guess_not_finite),
        cmocka_unit_test(test_chain_guess_huge_quaternion),
        cmocka_unit_test(test_datasets_read),
        cmocka_unit_test(test_datasets_details),
        cmocka_unit_test(test_load_and_from_instance),
        cmocka_unit_test(test_load_small_with_fix),
        cmocka_unit_test(test_load_errors),
        cmocka_unit_test(test_self_loops_left_out),
        cmocka_unit_test(test_foreign_ids),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
