/* Helpers of the command-line tool: clock, option values, reading, loading and writing graphs
 * and text files, pose-id indexes and sorted id pairs. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

#include "cli.h"
#ifdef PGEM_HAVE_METIS
#include "pgem/metis.h"
#endif
#include "random.h"

double pgem_cli_now(void)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

int pgem_cli_parse_u32(const char *prefix, const char *option, const char *text,
                       uint32_t *value)
{
    char *end = NULL;
    errno = 0;
    unsigned long parsed = text != NULL ? strtoul(text, &end, 10) : 0;
    if (text == NULL || *text == '\0' || *text == '-' || *end != '\0' || errno != 0 ||
        parsed > UINT32_MAX) {
        fprintf(stderr, "%s: %s needs a non-negative integer, got '%s'\n", prefix, option,
                text != NULL ? text : "");
        return 0;
    }
    *value = (uint32_t)parsed;
    return 1;
}

int pgem_cli_parse_at_least(const char *prefix, const char *option, const char *text,
                            uint32_t least, const char *what, uint32_t *value)
{
    if (!pgem_cli_parse_u32(prefix, option, text, value)) {
        return 0;
    }
    if (*value < least) {
        fprintf(stderr, "%s: %s needs at least %u %s, got %u\n", prefix, option, least, what,
                *value);
        return 0;
    }
    return 1;
}

int pgem_cli_parse_number(const char *prefix, const char *option, const char *text, int strict,
                          double *value)
{
    char *end = NULL;
    double parsed = text != NULL ? strtod(text, &end) : -1.0;
    int in_range = strict ? parsed > 0.0 : parsed >= 0.0;
    if (text == NULL || end == text || *end != '\0' || !in_range || !isfinite(parsed)) {
        fprintf(stderr, "%s: %s needs a %s number, got '%s'\n", prefix, option,
                strict ? "positive" : "non-negative", text != NULL ? text : "");
        return 0;
    }
    *value = parsed;
    return 1;
}

/* Progress of a long read, on stderr: one line each time another tenth of the file is read. */
typedef struct pgem_cli_reading {
    const char *prefix;
    const char *path;
    uint64_t size;       /* bytes in the file */
    int tenths_shown;    /* tenths of it already reported */
} pgem_cli_reading_t;

static void pgem_cli_read_progress(uint64_t bytes, unsigned long lines, void *user)
{
    pgem_cli_reading_t *reading = user;
    const int tenths = (int)(bytes * 10u / reading->size);
    if (tenths > reading->tenths_shown && bytes < reading->size) {
        reading->tenths_shown = tenths;
        fprintf(stderr, "%s: reading %s: %d%% (%llu of %llu MiB, %lu lines)\n", reading->prefix,
                reading->path, (int)(bytes * 100u / reading->size),
                (unsigned long long)(bytes >> 20), (unsigned long long)(reading->size >> 20),
                lines);
        fflush(stderr);
    }
}

/* One warning line per self-loop edge the reader left out (the first ten, then a count): the
 * file still solves, and the user learns which lines were not used. */
static void pgem_cli_warn_self_loops(const char *prefix, const char *path,
                                     const pgem_io_graph_t *graph)
{
    enum { SHOWN = 10 };
    for (size_t k = 0; k < graph->self_loop_count && k < SHOWN; k++) {
        const pgem_io_edge_t *edge = &graph->self_loops[k];
        fprintf(stderr, "%s: warning: %s:%lu: edge %llu -> %llu joins a pose to itself and "
                        "constrains nothing: left out of the graph\n", prefix, path, edge->line,
                (unsigned long long)edge->from, (unsigned long long)edge->to);
    }
    if (graph->self_loop_count > SHOWN) {
        fprintf(stderr, "%s: warning: %s: %zu more self-loop edges left out (%zu in all)\n",
                prefix, path, graph->self_loop_count - SHOWN, graph->self_loop_count);
    }
}

int pgem_cli_read_graph(const char *prefix, const char *path, unsigned flags,
                        pgem_io_graph_t *graph)
{
    char message[1024];
    struct stat info;
    pgem_cli_reading_t reading = {prefix, path, 0u, 0};
    /* a file this large takes a second or more: say how far the read is */
    const int show = stat(path, &info) == 0 && S_ISREG(info.st_mode) &&
                     (uint64_t)info.st_size >= PGEM_CLI_PROGRESS_MIN_BYTES;
    reading.size = show ? (uint64_t)info.st_size : 0u;
    pgem_io_read_options_t options;
    memset(&options, 0, sizeof options);
    options.format = PGEM_FORMAT_AUTO;
    options.foreign_ids = (flags & PGEM_CLI_FOREIGN_IDS) != 0u;
    options.progress = show ? pgem_cli_read_progress : NULL;
    options.progress_user = &reading;
    int status = pgem_io_read_with(path, &options, graph, message, sizeof message);
    if (status != PGEM_OK) {
        const int offer = (flags & PGEM_CLI_OFFER_FOREIGN) != 0u && status == PGEM_ERR_UNKNOWN_ID &&
                          strstr(message, "which has no VERTEX line") != NULL;
        fprintf(stderr, "%s: %s%s\n", prefix, message,
                offer ? " (another robot's pose? --foreign-ids sends such edges, and the bridge "
                        "holds them until that pose arrives)"
                      : "");
        return status == PGEM_ERR_IO ? PGEM_EXIT_IO : PGEM_EXIT_FAILURE;
    }
    if ((flags & PGEM_CLI_NEED_POSES) != 0u && graph->pose_count == 0) {
        fprintf(stderr, "%s: %s has no poses\n", prefix, path);
        return PGEM_EXIT_FAILURE;
    }
    if ((flags & PGEM_CLI_LIST_SELF_LOOPS) == 0u) {
        pgem_cli_warn_self_loops(prefix, path, graph);
    }
    if ((flags & PGEM_CLI_WARN_CHAINED) != 0u && graph->chained_poses > 0) {
        fprintf(stderr, "%s: warning: %s has no VERTEX lines; its poses are guesses composed "
                        "along its edges\n", prefix, path);
    }
    return PGEM_EXIT_OK;
}

int pgem_cli_write_graph(const char *prefix, const pgem_io_graph_t *graph, const char *path)
{
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, prefix, path) != 0) {
        return PGEM_EXIT_IO;
    }
    int status = pgem_io_write_stream(file.stream, PGEM_FORMAT_G2O, graph);
    if (status == PGEM_ERR_DIMENSION) { /* a graph no file format holds: nothing to write */
        fprintf(stderr, "%s: %s: the graph has no dimension to write\n", prefix, path);
    }
    return pgem_cli_file_commit(&file, status != PGEM_OK);
}

static int pgem_cli_try_load(const pgem_io_graph_t *file, const pgem_config_t *config,
                             pgem_t **instance, char *message, size_t message_size)
{
    if (file->pose_count > PGEM_MAX_POSES_LIMIT || file->edge_count > PGEM_MAX_EDGES_LIMIT) {
        snprintf(message, message_size, "%s: %zu poses and %zu edges: more than an instance "
                 "holds (at most %u poses and %u edges)", file->source, file->pose_count,
                 file->edge_count, PGEM_MAX_POSES_LIMIT, PGEM_MAX_EDGES_LIMIT);
        return PGEM_ERR_CAPACITY;
    }
    int status = pgem_create(instance, config);
    if (status != PGEM_OK) {
        snprintf(message, message_size, "cannot create an instance: %s",
                 pgem_error_description(status));
        return status;
    }
    status = pgem_io_load(file, *instance, message, message_size);
    if (status != PGEM_OK) {
        pgem_destroy(*instance);
        *instance = NULL;
    }
    return status;
}

/* The ordering every instance the CLI loads uses (pgem_cli_set_ordering). */
static pgem_order_choice_t pgem_cli_ordering = PGEM_ORDER_AUTO;

int pgem_cli_set_ordering(const char *prefix, const char *text)
{
    static const char *const names[] = {"auto", "amd", "nested", "metis"};
    for (int k = 0; k < 4; k++) {
        if (strcmp(text, names[k]) == 0) {
#ifndef PGEM_HAVE_METIS
            if (k == 3) {
                fprintf(stderr, "%s: --ordering metis: this build has no METIS (libmetis-dev)\n",
                        prefix);
                return 0;
            }
#endif
            pgem_cli_ordering = (pgem_order_choice_t)k;
            return 1;
        }
    }
    fprintf(stderr, "%s: --ordering takes auto, amd, nested or metis, got '%s'\n", prefix, text);
    return 0;
}

/* The CLI's ordering onto instance: METIS as the orderer when the build has it. */
static void pgem_cli_apply_ordering(pgem_t *instance)
{
#ifdef PGEM_HAVE_METIS
    (void)pgem_metis_use(instance, pgem_cli_ordering);
#else
    (void)pgem_set_ordering(instance, pgem_cli_ordering, NULL);
#endif
}

/* pgem_analyze, timed into *seconds. */
static int pgem_cli_analyze(pgem_t *instance, double *seconds)
{
    double start = pgem_cli_now();
    int status = pgem_analyze(instance);
    *seconds = pgem_cli_now() - start;
    return status;
}

int pgem_cli_load_quietly(const pgem_io_graph_t *file, const char *path, uint32_t threads,
                          pgem_t **instance, double *analysis_seconds, char *message,
                          size_t message_size)
{
    double seconds = 0.0, more = 0.0;
    if (analysis_seconds != NULL) {
        *analysis_seconds = 0.0;
    }
    /* The factor's size is known only after the ordering: a probe instance with a factor of
     * one nonzero is loaded and asked what it needs (pgem_fill_needed), then copied, ordering
     * included, into one of exactly that budget, whose analysis is then symbolic only. */
    pgem_config_t config;
    pgem_io_config(file, &config);
    config.threads = threads;
    pgem_config_t probe_config = config;
    probe_config.fill_budget = 1u;
    pgem_t *probe = NULL;
    int status = pgem_cli_try_load(file, &probe_config, &probe, message, message_size);
    if (status != PGEM_OK || pgem_edge_count(probe) == 0u) {
        *instance = probe;
        return status;
    }
    pgem_cli_apply_ordering(probe);
    if (file->pose_count >= PGEM_CLI_ANALYSIS_NOTICE_POSES) {
        fprintf(stderr, "pgem: ordering and analysing %zu poses and %zu edges...\n",
                file->pose_count, file->edge_count);
    }
    uint32_t nonzeros = 0u;
    const double start = pgem_cli_now();
    status = pgem_fill_needed(probe, &nonzeros);
    seconds = pgem_cli_now() - start;
    if (status == PGEM_OK && nonzeros > probe_config.fill_budget) {
        config.fill_budget = nonzeros;
        status = pgem_create(instance, &config);
        if (status != PGEM_OK) {
            snprintf(message, message_size, "cannot create an instance for a factor of %u "
                     "nonzeros: %s", nonzeros, pgem_error_description(status));
            *instance = NULL;
            pgem_destroy(probe);
            return status;
        }
        pgem_cli_apply_ordering(*instance);
        status = pgem_copy(*instance, probe);
        if (status == PGEM_OK) {
            status = pgem_cli_analyze(*instance, &more);
        }
        pgem_destroy(probe);
    } else {
        *instance = probe; /* analysed within its budget, or its failure is reported with it */
    }
    if (analysis_seconds != NULL) {
        *analysis_seconds = seconds + more;
    }
    if (status != PGEM_OK && *instance != NULL) {
        snprintf(message, message_size, "%s%s%s", path != NULL ? path : "",
                 path != NULL ? ": " : "", pgem_last_error(*instance));
    }
    return status;
}

int pgem_cli_load(const pgem_io_graph_t *file, const char *path, uint32_t threads,
                  pgem_t **instance, double *analysis_seconds)
{
    char message[1024];
    int status = pgem_cli_load_quietly(file, path, threads, instance, analysis_seconds, message,
                                       sizeof message);
    if (status != PGEM_OK) {
        fprintf(stderr, "pgem: %s\n", message);
    }
    return status;
}

/* The instance's edges into `file`, the graph it was loaded from (the same edges in the same
 * order, as the instance holds them: 3D measurements normalised), in place. */
int pgem_cli_refill_edges(const pgem_t *instance, pgem_io_graph_t *file)
{
    if (file == NULL || file->dimension != pgem_dimension(instance) ||
        file->edge_count != pgem_edge_count(instance)) {
        return 0;
    }
    for (uint32_t i = 0; i < pgem_edge_count(instance); i++) {
        pgem_io_edge_t *edge = &file->edges[i];
        pgem_edge_view_t view;
        if (pgem_edge_at(instance, i, &view) != PGEM_OK) {
            return 0;
        }
        edge->from = view.from;
        edge->to = view.to;
        edge->kind = view.kind;
        memcpy(edge->measurement, view.measurement, sizeof edge->measurement);
        memcpy(edge->information, view.information, sizeof edge->information);
    }
    return 1;
}

/* The instance's graph into `file`, in place of a fresh copy: what pgem_io_from_instance would
 * make, without allocating and touching as much memory again (City10000: 6.7 ms). 0 if it
 * does not fit. */
static int pgem_cli_refill(const pgem_t *instance, pgem_io_graph_t *file)
{
    if (file == NULL || file->pose_count != pgem_pose_count(instance) ||
        !pgem_cli_refill_edges(instance, file)) {
        return 0;
    }
    file->fixed_count = 0;
    for (uint32_t i = 0; i < pgem_pose_count(instance); i++) {
        pgem_io_pose_t *pose = &file->poses[i];
        int fixed = 0;
        if (pgem_pose_at(instance, i, &pose->id, pose->pose, &fixed) != PGEM_OK ||
            (fixed && file->fixed_count == file->fixed_capacity)) {
            return 0;
        }
        if (fixed) {
            file->fixed[file->fixed_count++] = pose->id;
        }
    }
    return 1;
}

/* The poses (and FIX lines) of graph, then the edge lines already formatted, written whole or
 * not at all (pgem_cli_file_t). */
static int pgem_cli_write_poses_then(const pgem_io_graph_t *graph, const char *path,
                                     const char *edge_text, size_t edge_bytes)
{
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, "pgem", path) != 0) {
        return PGEM_EXIT_IO;
    }
    static char buffer[1u << 18]; /* as pgem_io_write's: one write call per 256 KiB */
    (void)setvbuf(file.stream, buffer, _IOFBF, sizeof buffer);
    pgem_io_graph_t poses = *graph;
    poses.edge_count = 0;
    int failed = pgem_io_write_stream(file.stream, PGEM_FORMAT_G2O, &poses) != PGEM_OK;
    failed = failed || fwrite(edge_text, 1, edge_bytes, file.stream) != edge_bytes;
    return pgem_cli_file_commit(&file, failed);
}

int pgem_cli_write(const pgem_t *instance, pgem_io_graph_t *file, const char *path,
                   const char *edge_text, size_t edge_bytes)
{
    if (pgem_cli_refill(instance, file)) {
        return edge_text != NULL ? pgem_cli_write_poses_then(file, path, edge_text, edge_bytes)
                                 : pgem_cli_write_graph("pgem", file, path);
    }
    pgem_io_graph_t out = {0};
    int status = pgem_io_from_instance(instance, &out);
    if (status == PGEM_OK) {
        status = pgem_cli_write_graph("pgem", &out, path);
    } else {
        fprintf(stderr, "pgem: cannot copy the graph for writing: %s\n", pgem_io_error_description(status));
        status = PGEM_EXIT_IO;
    }
    pgem_io_graph_free(&out);
    return status;
}

double pgem_cli_quat_check(double *q, int *refused)
{
    const double norm = pgem_quat_normalize(q);
    *refused = !(fabs(norm - 1.0) <= PGEM_CLI_QUAT_TOLERANCE);
    return norm;
}

int pgem_cli_parse_kernel(const char *prefix, const char *text, pgem_kernel_t *kernel)
{
    static const pgem_kernel_t kernels[] = {PGEM_KERNEL_NONE, PGEM_KERNEL_EM, PGEM_KERNEL_CAUCHY,
                                            PGEM_KERNEL_HUBER, PGEM_KERNEL_DCS};
    for (size_t k = 0; text != NULL && k < sizeof kernels / sizeof kernels[0]; k++) {
        if (strcmp(text, pgem_kernel_name(kernels[k])) == 0) {
            *kernel = kernels[k];
            return 1;
        }
    }
    fprintf(stderr, "%s: --robust takes em, cauchy, huber, dcs or none (got '%s')\n", prefix,
            text != NULL ? text : "");
    return 0;
}

int pgem_cli_write_weights(const pgem_t *instance, const char *path)
{
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, "pgem", path) != 0) {
        return -1;
    }
    int failed = pgem_io_write_weights(file.stream, instance) != PGEM_OK;
    return pgem_cli_file_commit(&file, failed) == PGEM_EXIT_OK ? 0 : -1;
}

double pgem_cli_uniform(uint64_t *state)
{
    return pgem_random_uniform(state);
}

double pgem_cli_gaussian(uint64_t *state)
{
    return pgem_random_gaussian(state);
}

void pgem_cli_random_pose(uint64_t *rng, int dimension, double *measurement)
{
    for (int d = 0; d < 3; d++) {
        measurement[d] = 20.0 * pgem_cli_uniform(rng) - 10.0;
    }
    if (dimension == 2) {
        measurement[2] = pgem_wrap_angle(6.283185307179586 * pgem_cli_uniform(rng));
        return;
    }
    double q[4], norm = 0.0;
    do { /* uniform on the unit 3-sphere by rejection */
        norm = 0.0;
        for (int d = 0; d < 4; d++) {
            q[d] = 2.0 * pgem_cli_uniform(rng) - 1.0;
            norm += q[d] * q[d];
        }
    } while (norm > 1.0 || norm < 1e-6);
    pgem_quat_normalize(q);
    memcpy(measurement + 3, q, sizeof q);
}

static int pgem_cli_compare_pairs(const void *a, const void *b)
{
    const pgem_cli_pair_t *x = a, *y = b;
    if (x->from != y->from) {
        return (x->from > y->from) - (x->from < y->from);
    }
    if (x->to != y->to) {
        return (x->to > y->to) - (x->to < y->to);
    }
    return (x->index > y->index) - (x->index < y->index);
}

void pgem_cli_sort_pairs(pgem_cli_pair_t *pairs, size_t count)
{
    if (count > 1u) {
        qsort(pairs, count, sizeof *pairs, pgem_cli_compare_pairs);
    }
}

size_t pgem_cli_pair_run_end(const pgem_cli_pair_t *pairs, size_t count, size_t first,
                             pgem_id_t from, pgem_id_t to)
{
    while (first < count && pairs[first].from == from && pairs[first].to == to) {
        first++;
    }
    return first;
}

const char *pgem_cli_number(char *out, size_t size, double value, int decimals)
{
    snprintf(out, size, fabs(value) < 1e15 || !isfinite(value) ? "%.*f" : "%.*e", decimals,
             value);
    return out;
}

const char *pgem_cli_plural(size_t count)
{
    return count == 1u ? "" : "s";
}
