/* Shared by fuzz_g2o and fuzz_toro (see fuzz_reader.h). */
#define _POSIX_C_SOURCE 200809L

#include "fuzz_reader.h"

#include <math.h>
#include <string.h>

#include "pgem/pgem.h"

/* ---- streams ------------------------------------------------------------------------------ */

/* A read stream over the bytes (an empty input reads as an empty file: fmemopen refuses
 * size 0). */
static FILE *open_bytes(const uint8_t *data, size_t size)
{
    FILE *stream = size > 0 ? fmemopen((void *)(uintptr_t)data, size, "rb") : fopen("/dev/null", "rb");
    FUZZ_CHECK(stream != NULL);
    return stream;
}

/* Lines in the input as the reader counts them (a last line may lack its LF). */
static unsigned long count_lines(const uint8_t *data, size_t size)
{
    unsigned long lines = 0;
    for (size_t i = 0; i < size; ++i) {
        lines += data[i] == '\n';
    }
    return lines + (size > 0 && data[size - 1] != '\n');
}

/* ---- messages ----------------------------------------------------------------------------- */

/* The message is a C string inside its buffer and starts with "NAME:"; with a line, with
 * "NAME:LINE: " where 1 <= LINE <= lines. */
static void check_message(const char *message, size_t size, const char *name, int with_line,
                          unsigned long lines)
{
    FUZZ_CHECK(memchr(message, '\0', size) != NULL);
    size_t length = strlen(name);
    FUZZ_CHECK(strncmp(message, name, length) == 0 && message[length] == ':');
    if (!with_line) {
        return;
    }
    const char *cursor = message + length + 1;
    unsigned long line = 0;
    FUZZ_CHECK(*cursor >= '1' && *cursor <= '9');
    while (*cursor >= '0' && *cursor <= '9') {
        line = line * 10 + (unsigned long)(*cursor++ - '0');
        FUZZ_CHECK(line <= lines);
    }
    FUZZ_CHECK(cursor[0] == ':' && cursor[1] == ' ' && cursor[2] != '\0');
}

/* ---- the graph as read -------------------------------------------------------------------- */

static int has_pose(const pgem_io_graph_t *graph, pgem_id_t id)
{
    for (size_t i = 0; i < graph->pose_count; ++i) {
        if (graph->poses[i].id == id) {
            return 1;
        }
    }
    return 0;
}

/* The core's magnitude limits hold: a translation's first `axes` values and information. */
static int within_limits(const double *values, size_t count, size_t axes, double limit)
{
    for (size_t i = 0; i < count && i < axes; ++i) {
        if (!(fabs(values[i]) <= limit)) {
            return 0;
        }
    }
    return 1;
}

static int all_finite(const double *values, size_t count)
{
    for (size_t i = 0; i < count; ++i) {
        if (!isfinite(values[i])) {
            return 0;
        }
    }
    return 1;
}

static void check_poses(const pgem_io_graph_t *graph)
{
    const size_t pose_size = (size_t)PGEM_POSE_SIZE(graph->dimension);
    FUZZ_CHECK(graph->chained_poses == 0 || graph->chained_poses == graph->pose_count);
    for (size_t i = 0; i < graph->pose_count; ++i) {
        const pgem_io_pose_t *pose = &graph->poses[i];
        FUZZ_CHECK((pose->line == 0) == (graph->chained_poses > 0));
        FUZZ_CHECK(all_finite(pose->pose, pose_size));
        FUZZ_CHECK(within_limits(pose->pose, pose_size, (size_t)graph->dimension,
                                 PGEM_TRANSLATION_LIMIT));
        if (graph->chained_poses > 0 && graph->dimension == 3) { /* composed unit rotations */
            const double *q = pose->pose + 3;
            FUZZ_CHECK(fabs(sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]) - 1.0) < 1e-6);
        }
        for (size_t j = 0; j < i; ++j) {
            FUZZ_CHECK(graph->poses[j].id != pose->id);
        }
    }
}

static void check_edges(const pgem_io_graph_t *graph)
{
    const size_t n = (size_t)PGEM_TANGENT_SIZE(graph->dimension);
    for (size_t e = 0; e < graph->self_loop_count; ++e) {
        FUZZ_CHECK(graph->self_loops[e].from == graph->self_loops[e].to);
        FUZZ_CHECK(graph->self_loops[e].line > 0);
        FUZZ_CHECK(e == 0 || graph->self_loops[e].line > graph->self_loops[e - 1].line);
    }
    for (size_t e = 0; e < graph->edge_count; ++e) {
        const pgem_io_edge_t *edge = &graph->edges[e];
        pgem_id_t gap = edge->from > edge->to ? edge->from - edge->to : edge->to - edge->from;
        FUZZ_CHECK(edge->line > 0);
        FUZZ_CHECK(edge->from != edge->to); /* self-loops are kept apart */
        FUZZ_CHECK(has_pose(graph, edge->from) && has_pose(graph, edge->to));
        /* the first edge between i and i + 1 is odometry, a later one between them a loop */
        FUZZ_CHECK(gap == 1 || edge->kind == PGEM_EDGE_LOOP);
        if (gap == 1) {
            size_t before = 0;
            for (size_t f = 0; f < graph->edge_count; ++f) {
                const pgem_io_edge_t *other = &graph->edges[f];
                before += f != e && other->kind == PGEM_EDGE_ODOMETRY &&
                          ((other->from == edge->from && other->to == edge->to) ||
                           (other->from == edge->to && other->to == edge->from));
            }
            FUZZ_CHECK(edge->kind == PGEM_EDGE_ODOMETRY ? before == 0 : before == 1);
        }
        FUZZ_CHECK(all_finite(edge->measurement, (size_t)PGEM_POSE_SIZE(graph->dimension)));
        FUZZ_CHECK(all_finite(edge->information, n * n));
        FUZZ_CHECK(within_limits(edge->measurement, (size_t)PGEM_POSE_SIZE(graph->dimension),
                                 (size_t)graph->dimension, PGEM_TRANSLATION_LIMIT));
        FUZZ_CHECK(within_limits(edge->information, n * n, n * n, PGEM_INFORMATION_LIMIT));
        for (size_t i = 0; i < n; ++i) {
            for (size_t j = 0; j < i; ++j) {
                FUZZ_CHECK(memcmp(&edge->information[i * n + j], &edge->information[j * n + i],
                                  sizeof(double)) == 0);
            }
        }
    }
}

static void check_graph(const pgem_io_graph_t *graph, pgem_format_t format, const char *name)
{
    FUZZ_CHECK(graph->dimension == 0 || graph->dimension == 2 || graph->dimension == 3);
    if (graph->dimension == 0) {
        FUZZ_CHECK(graph->pose_count == 0 && graph->edge_count == 0 && graph->fixed_count == 0);
    }
    FUZZ_CHECK(format != PGEM_FORMAT_TORO || graph->dimension != 3);
    FUZZ_CHECK(graph->toro_edges == (format == PGEM_FORMAT_TORO ? graph->edge_count : 0));
    FUZZ_CHECK(format == PGEM_FORMAT_TORO || graph->equiv_lines == 0);
    check_poses(graph);
    check_edges(graph);
    for (size_t i = 0; i < graph->fixed_count; ++i) {
        FUZZ_CHECK(has_pose(graph, graph->fixed[i]));
    }
    FUZZ_CHECK(memchr(graph->first_unknown_tag, '\0', sizeof graph->first_unknown_tag) != NULL);
    FUZZ_CHECK((graph->unknown_lines == 0) == (graph->first_unknown_tag[0] == '\0'));
    for (const char *c = graph->first_unknown_tag; *c != '\0'; ++c) {
        FUZZ_CHECK(*c >= 0x20 && *c < 0x7f);
    }
    FUZZ_CHECK(strcmp(graph->source, name) == 0);
}

/* ---- round trips -------------------------------------------------------------------------- */

/* Same poses, edges and (when the format writes them) FIX ids, bit for bit. */
static void check_same_graph(const pgem_io_graph_t *a, const pgem_io_graph_t *b, int with_fixed)
{
    const size_t pose_bytes = sizeof(double) * (size_t)PGEM_POSE_SIZE(a->dimension);
    const size_t n = (size_t)PGEM_TANGENT_SIZE(a->dimension);
    /* a graph without poses is written as an empty file, which reads as dimension 0 */
    FUZZ_CHECK(a->dimension == b->dimension || (a->pose_count == 0 && b->dimension == 0));
    FUZZ_CHECK(a->pose_count == b->pose_count && a->edge_count == b->edge_count);
    for (size_t i = 0; i < a->pose_count; ++i) {
        FUZZ_CHECK(a->poses[i].id == b->poses[i].id);
        FUZZ_CHECK(memcmp(a->poses[i].pose, b->poses[i].pose, pose_bytes) == 0);
    }
    for (size_t e = 0; e < a->edge_count; ++e) {
        const pgem_io_edge_t *x = &a->edges[e];
        const pgem_io_edge_t *y = &b->edges[e];
        FUZZ_CHECK(x->from == y->from && x->to == y->to && x->kind == y->kind);
        FUZZ_CHECK(memcmp(x->measurement, y->measurement, pose_bytes) == 0);
        FUZZ_CHECK(memcmp(x->information, y->information, n * n * sizeof(double)) == 0);
    }
    if (with_fixed) {
        FUZZ_CHECK(a->fixed_count == b->fixed_count);
        for (size_t i = 0; i < a->fixed_count; ++i) {
            FUZZ_CHECK(a->fixed[i] == b->fixed[i]);
        }
    }
}

/* Writes graph in format to memory, reads it back and compares. */
static void check_round_trip(const pgem_io_graph_t *graph, pgem_format_t format)
{
    char *text = NULL;
    size_t length = 0;
    FILE *out = open_memstream(&text, &length);
    FUZZ_CHECK(out != NULL);
    int status = pgem_io_write_stream(out, format, graph);
    FUZZ_CHECK(fclose(out) == 0);
    FUZZ_CHECK(status == PGEM_OK);
    FILE *in = open_bytes((const uint8_t *)text, length);
    pgem_io_graph_t back;
    char message[512];
    status = pgem_io_read_stream(in, "round-trip", format, &back, message, sizeof message);
    fclose(in);
    if (status != PGEM_OK) {
        fprintf(stderr, "written graph does not read back: %s\n", message);
    }
    FUZZ_CHECK(status == PGEM_OK);
    check_same_graph(graph, &back, format != PGEM_FORMAT_TORO);
    pgem_io_graph_free(&back);
    free(text);
}

/* ---- load and solve ----------------------------------------------------------------------- */

typedef struct estimate {
    double *poses;
    size_t bytes;
} estimate_t;

static estimate_t save_estimate(const pgem_t *instance)
{
    const uint32_t count = pgem_pose_count(instance);
    const size_t pose_size = (size_t)PGEM_POSE_SIZE(pgem_dimension(instance));
    estimate_t saved = {NULL, (count > 0 ? count : 1) * pose_size * sizeof(double)};
    saved.poses = calloc(1, saved.bytes);
    FUZZ_CHECK(saved.poses != NULL);
    for (uint32_t i = 0; i < count; ++i) {
        FUZZ_CHECK(pgem_pose_at(instance, i, NULL, saved.poses + i * pose_size, NULL) == PGEM_OK);
    }
    return saved;
}

static int same_estimate(const pgem_t *instance, const estimate_t *saved)
{
    estimate_t now = save_estimate(instance);
    int same = memcmp(now.poses, saved->poses, saved->bytes) == 0;
    free(now.poses);
    return same;
}

static int estimate_finite(const pgem_t *instance)
{
    estimate_t now = save_estimate(instance);
    int finite = all_finite(now.poses, now.bytes / sizeof(double));
    free(now.poses);
    return finite;
}

static int solve_failure(int status)
{
    return status == PGEM_ERR_NOT_POSITIVE_DEFINITE || status == PGEM_ERR_NUMERIC ||
           status == PGEM_ERR_FILL_BUDGET || status == PGEM_ERR_EMPTY;
}

/* A solve either succeeds with a finite estimate or fails leaving the estimate as it was. */
static void check_solve_outcome(const pgem_t *instance, int status, const estimate_t *before)
{
    FUZZ_CHECK(status == PGEM_OK || solve_failure(status));
    if (status == PGEM_OK) {
        FUZZ_CHECK(estimate_finite(instance));
    } else {
        FUZZ_CHECK(same_estimate(instance, before));
        FUZZ_CHECK(pgem_last_error(instance)[0] != '\0');
    }
}

/* A short plain solve (the method chosen by the input), then a short EM solve. */
static void solve_briefly(pgem_t *instance, pgem_method_t method)
{
    pgem_solve_options_t options;
    memset(&options, 0, sizeof options);
    options.method = method;
    options.max_iterations = 3;
    estimate_t before = save_estimate(instance);
    check_solve_outcome(instance, pgem_optimize(instance, &options, NULL), &before);
    free(before.poses);

    pgem_robust_options_t robust;
    memset(&robust, 0, sizeof robust);
    robust.kernel = PGEM_KERNEL_EM;
    robust.max_rounds = 2;
    robust.max_em_iterations = 2;
    options.method = PGEM_GAUSS_NEWTON;
    before = save_estimate(instance);
    check_solve_outcome(instance, pgem_robust_optimize(instance, &robust, &options, NULL),
                        &before);
    free(before.poses);
}

static int load_failure(int status)
{
    /* what the core may refuse in a well-formed file: values the reader does not judge */
    return status == PGEM_ERR_ROTATION || status == PGEM_ERR_INFORMATION ||
           status == PGEM_ERR_SELF_LOOP;
}

/* The solved instance written as g2o reads back as the same graph. */
static void check_instance_round_trip(const pgem_t *instance)
{
    pgem_io_graph_t graph;
    FUZZ_CHECK(pgem_io_from_instance(instance, &graph) == PGEM_OK);
    FUZZ_CHECK(graph.pose_count == pgem_pose_count(instance));
    FUZZ_CHECK(graph.edge_count == pgem_edge_count(instance));
    check_round_trip(&graph, PGEM_FORMAT_G2O);
    pgem_io_graph_free(&graph);
}

static void load_and_solve(const pgem_io_graph_t *graph, pgem_method_t method)
{
    pgem_config_t config;
    pgem_io_config(graph, &config);
    if (config.max_poses > FUZZ_READER_MAX_POSES || config.max_edges > FUZZ_READER_MAX_EDGES) {
        return; /* bounded: one input must not take seconds */
    }
    pgem_t *instance = NULL;
    FUZZ_CHECK(pgem_create(&instance, &config) == PGEM_OK);
    char message[512];
    memset(message, 0x5A, sizeof message);
    int status = pgem_io_load(graph, instance, message, sizeof message);
    if (status != PGEM_OK) {
        if (!load_failure(status)) {
            fprintf(stderr, "load: %s: %s\n", pgem_error_name(status), message);
        }
        FUZZ_CHECK(load_failure(status));
        check_message(message, sizeof message, graph->source, 0, 0);
    } else {
        FUZZ_CHECK(pgem_pose_count(instance) == graph->pose_count);
        FUZZ_CHECK(pgem_edge_count(instance) == graph->edge_count);
        solve_briefly(instance, method);
        check_instance_round_trip(instance);
    }
    pgem_destroy(instance);
}

/* ---- entry -------------------------------------------------------------------------------- */

static int error_has_line(int status)
{
    return status == PGEM_ERR_PARSE || status == PGEM_ERR_DIMENSION ||
           status == PGEM_ERR_DUPLICATE_ID || status == PGEM_ERR_UNKNOWN_ID ||
           status == PGEM_ERR_OUT_OF_RANGE;
}

void fuzz_reader_run(const uint8_t *data, size_t size, pgem_format_t format, const char *name)
{
    FILE *stream = open_bytes(data, size);
    pgem_io_graph_t graph;
    char message[512];
    memset(message, 0x5A, sizeof message);
    int status = pgem_io_read_stream(stream, name, format, &graph, message, sizeof message);
    fclose(stream);
    if (status != PGEM_OK) {
        FUZZ_CHECK(error_has_line(status));
        check_message(message, sizeof message, name, 1, count_lines(data, size));
        FUZZ_CHECK(graph.pose_count == 0 && graph.edge_count == 0 && graph.fixed_count == 0);
        FUZZ_CHECK(graph.poses == NULL && graph.edges == NULL && graph.fixed == NULL);
        return;
    }
    FUZZ_CHECK(message[0] == '\0');
    check_graph(&graph, format, name);
    check_round_trip(&graph, format);
    load_and_solve(&graph, size % 2 == 0 ? PGEM_GAUSS_NEWTON : PGEM_LEVENBERG_MARQUARDT);
    pgem_io_graph_free(&graph);
}

size_t fuzz_reader_seed(const char *const *seeds, unsigned count, unsigned index,
                        uint8_t *buffer, size_t capacity)
{
    if (index >= count) {
        return 0;
    }
    size_t length = strlen(seeds[index]);
    FUZZ_CHECK(length > 0 && length <= capacity);
    memcpy(buffer, seeds[index], length);
    return length;
}
