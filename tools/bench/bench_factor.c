/* Benchmark program (built for tools/bench/bench_factor.py, not installed): times pgem's symbolic
 * analysis, numeric factorisation and one Gauss-Newton iteration on a graph file, and writes the
 * same Newton matrix H for a CHOLMOD peer; in its cholmod mode it reads that matrix and times
 * CHOLMOD's analysis and factorisation on it (default orderings and supernodal choice).
 *
 *   pgem-bench-factor pgem FILE [--repeat N] [--threads T] [--matrix H.bin]
 *   pgem-bench-factor cholmod H.bin [--repeat N]
 *
 * Each mode prints one JSON object on stdout. H is built here from the public geometry (the
 * edges' Jacobians at the file's initial estimate, weight 1), numbered by free pose in insertion
 * order (the gauge pose left out, as pgem holds it): the peer orders it itself. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <cholmod.h>

#include "factor_hook.h" /* lib/core/hooks: the stages of a solve one at a time, the factor's figures */
#include "pgem/io.h"
#ifdef PGEM_HAVE_METIS
#include "pgem/metis.h"
#endif
#include "pgem/pgem.h"
#include "pgem/threads.h"

#define BENCH_REPEAT_MAX 100

static double bench_now(void)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

static int bench_compare(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median, min and max of count times (sorted in place). */
static void bench_print_times(const char *name, double *times, int count)
{
    qsort(times, (size_t)count, sizeof *times, bench_compare);
    printf(",\"%s_seconds\":%.6f,\"%s_min\":%.6f,\"%s_max\":%.6f", name, times[count / 2], name,
           times[0], name, times[count - 1]);
}

/* A value of /proc/self/status in bytes (VmHWM, VmRSS), 0 if unreadable. */
static size_t bench_status_bytes(const char *key)
{
    FILE *file = fopen("/proc/self/status", "r");
    char line[256];
    size_t bytes = 0;
    const size_t length = strlen(key);
    while (file != NULL && fgets(line, sizeof line, file) != NULL) {
        if (strncmp(line, key, length) == 0 && line[length] == ':') {
            bytes = (size_t)strtoull(line + length + 1, NULL, 10) * 1024u;
        }
    }
    if (file != NULL) {
        fclose(file);
    }
    return bytes;
}

/* The BLAS library this process mapped (path of the first mapping naming blas), or "". */
static void bench_blas_library(char *out, size_t size)
{
    FILE *file = fopen("/proc/self/maps", "r");
    char line[1024];
    out[0] = '\0';
    while (file != NULL && fgets(line, sizeof line, file) != NULL) {
        char *path = strchr(line, '/');
        if (path != NULL && strstr(path, "blas") != NULL) {
            path[strcspn(path, "\n")] = '\0';
            snprintf(out, size, "%s", path);
            break;
        }
    }
    if (file != NULL) {
        fclose(file);
    }
}

typedef struct bench_args {
    const char *mode;
    const char *input;
    const char *matrix;
    int repeat;
    int threads;
    int matrix_only; /* pgem mode: write the matrix, time nothing */
} bench_args_t;

static int bench_parse(int argc, char **argv, bench_args_t *args)
{
    memset(args, 0, sizeof *args);
    args->repeat = 5;
    args->threads = 1;
    if (argc < 3) {
        return 0;
    }
    args->mode = argv[1];
    args->input = argv[2];
    for (int k = 3; k < argc; k++) {
        const char *value = k + 1 < argc ? argv[k + 1] : NULL;
        if (strcmp(argv[k], "--matrix-only") == 0) {
            args->matrix_only = 1;
            continue;
        }
        if (value == NULL) {
            return 0;
        }
        if (strcmp(argv[k], "--repeat") == 0) {
            args->repeat = atoi(value);
        } else if (strcmp(argv[k], "--threads") == 0) {
            args->threads = atoi(value);
        } else if (strcmp(argv[k], "--matrix") == 0) {
            args->matrix = value;
        } else {
            return 0;
        }
        k++;
    }
    return args->repeat >= 1 && args->repeat <= BENCH_REPEAT_MAX && args->threads >= 1;
}

/* ---------------------------------------------------------------------------------------- */
/* H from the public geometry, as upper-triangle triplets (duplicates summed by the reader). */

typedef struct bench_triplets {
    int32_t *rows;
    int32_t *columns;
    double *values;
    size_t count;
    size_t capacity;
} bench_triplets_t;

static int bench_add(bench_triplets_t *t, int row, int column, double value)
{
    if (row > column) {
        int swap = row;
        row = column;
        column = swap;
    }
    if (t->count == t->capacity) {
        size_t capacity = t->capacity == 0 ? 1024u : 2u * t->capacity;
        int32_t *rows = realloc(t->rows, capacity * sizeof *rows);
        int32_t *columns = rows != NULL ? realloc(t->columns, capacity * sizeof *columns) : NULL;
        double *values = columns != NULL ? realloc(t->values, capacity * sizeof *values) : NULL;
        if (rows != NULL) {
            t->rows = rows;
        }
        if (columns != NULL) {
            t->columns = columns;
        }
        if (values == NULL) {
            return 0;
        }
        t->values = values;
        t->capacity = capacity;
    }
    t->rows[t->count] = row;
    t->columns[t->count] = column;
    t->values[t->count] = value;
    t->count++;
    return 1;
}

/* Adds A^T W B (n x n each, row-major) at block (row_block, column_block), upper part only. */
static int bench_add_block(bench_triplets_t *t, int n, int row_block, int column_block,
                           const double *a, const double *w, const double *b)
{
    for (int r = 0; r < n; r++) {
        for (int c = 0; c < n; c++) {
            double sum = 0.0;
            for (int i = 0; i < n; i++) {
                for (int j = 0; j < n; j++) {
                    sum += a[i * n + r] * w[i * n + j] * b[j * n + c];
                }
            }
            const int row = row_block * n + r, column = column_block * n + c;
            if ((row_block != column_block || r <= c) && !bench_add(t, row, column, sum)) {
                return 0;
            }
        }
    }
    return 1;
}

/* METIS as the analysis's orderer when the build has it, as pgem optimize uses it. */
static void bench_set_orderer(pgem_t *graph)
{
#ifdef PGEM_HAVE_METIS
    (void)pgem_metis_use(graph, PGEM_ORDER_AUTO);
#else
    (void)graph;
#endif
}

/* The free index of every pose (-1: held), as pgem numbers its unknowns before ordering. */
static int bench_free_numbering(const pgem_t *graph, int *free_index)
{
    const uint32_t poses = pgem_pose_count(graph);
    int any_fixed = 0, count = 0;
    for (uint32_t p = 0; p < poses; p++) {
        int fixed = 0;
        (void)pgem_pose_at(graph, p, NULL, NULL, &fixed);
        any_fixed |= fixed;
        free_index[p] = fixed;
    }
    for (uint32_t p = 0; p < poses; p++) {
        const int held = free_index[p] || (!any_fixed && p == 0u);
        free_index[p] = held ? -1 : count++;
    }
    return count;
}

static int bench_build_h(const pgem_t *graph, bench_triplets_t *t, int *order)
{
    const int dimension = pgem_dimension(graph);
    const int n = dimension == 3 ? 6 : 3, pose_size = dimension == 3 ? 7 : 3;
    int *free_index = malloc((size_t)pgem_pose_count(graph) * sizeof *free_index);
    if (free_index == NULL) {
        return 0;
    }
    *order = bench_free_numbering(graph, free_index) * n;
    int ok = 1;
    for (int f = 0; f < *order / n && ok; f++) { /* the diagonal entries, so none is missing */
        for (int c = 0; c < n && ok; c++) {
            ok = bench_add(t, f * n + c, f * n + c, 0.0);
        }
    }
    for (uint32_t k = 0; k < pgem_edge_count(graph) && ok; k++) {
        pgem_edge_view_t edge;
        uint32_t from, to;
        double xi[7], xj[7], e[6], ji[36], jj[36];
        (void)pgem_edge_at(graph, k, &edge);
        (void)pgem_pose_index(graph, edge.from, &from);
        (void)pgem_pose_index(graph, edge.to, &to);
        (void)pgem_pose_at(graph, from, NULL, xi, NULL);
        (void)pgem_pose_at(graph, to, NULL, xj, NULL);
        (void)pose_size;
        if (dimension == 3) {
            pgem_se3_error(xi, xj, edge.measurement, e, ji, jj);
        } else {
            pgem_se2_error(xi, xj, edge.measurement, e, ji, jj);
        }
        const int a = free_index[from], b = free_index[to];
        if (a >= 0) {
            ok = ok && bench_add_block(t, n, a, a, ji, edge.information, ji);
        }
        if (b >= 0) {
            ok = ok && bench_add_block(t, n, b, b, jj, edge.information, jj);
        }
        if (a >= 0 && b >= 0) {
            ok = ok && (a < b ? bench_add_block(t, n, a, b, ji, edge.information, jj)
                              : bench_add_block(t, n, b, a, jj, edge.information, ji));
        }
    }
    free(free_index);
    return ok;
}

static int bench_write_matrix(const char *path, const bench_triplets_t *t, int order)
{
    FILE *file = fopen(path, "wb");
    if (file == NULL) {
        return 0;
    }
    const int64_t header[2] = {order, (int64_t)t->count};
    int ok = fwrite("PGEMH1\n", 1, 8, file) == 8 && fwrite(header, sizeof header, 1, file) == 1 &&
             fwrite(t->rows, sizeof *t->rows, t->count, file) == t->count &&
             fwrite(t->columns, sizeof *t->columns, t->count, file) == t->count &&
             fwrite(t->values, sizeof *t->values, t->count, file) == t->count;
    return fclose(file) == 0 && ok;
}

/* Writes H to path (nothing if NULL) and destroys the instance; 0 on success. */
static int bench_matrix(pgem_t *graph, const char *path)
{
    int status = 0;
    if (path != NULL) {
        bench_triplets_t t = {0};
        int order = 0;
        if (!bench_build_h(graph, &t, &order) || !bench_write_matrix(path, &t, order)) {
            fprintf(stderr, "bench_factor: cannot write %s\n", path);
            status = 1;
        }
        free(t.rows);
        free(t.columns);
        free(t.values);
    }
    pgem_destroy(graph);
    return status;
}

/* ---------------------------------------------------------------------------------------- */
/* pgem mode */

static int bench_load(const char *path, int analyse, uint32_t threads, pgem_t **graph)
{
    pgem_io_graph_t file = {0};
    char message[512];
    int status = pgem_io_read(path, PGEM_FORMAT_AUTO, &file, message, sizeof message);
    if (status != PGEM_OK) {
        fprintf(stderr, "bench_factor: %s\n", message);
        pgem_io_graph_free(&file);
        return status;
    }
    pgem_config_t config;
    pgem_io_config(&file, &config);
    config.threads = threads;
    for (int attempt = 0; attempt < 2; attempt++) {
        status = pgem_create(graph, &config);
        if (status == PGEM_OK) {
            bench_set_orderer(*graph);
            status = pgem_io_load(&file, *graph, message, sizeof message);
        }
        if (status != PGEM_OK || !analyse) {
            break;
        }
        if (status == PGEM_OK) {
            status = pgem_analyze(*graph);
        }
        pgem_memory_stats_t stats;
        pgem_memory_use(*graph, &stats);
        if (attempt == 0 && (status == PGEM_OK || status == PGEM_ERR_FILL_BUDGET)) {
            config.fill_budget = stats.factor_nonzeros; /* the exact size, as the CLI does */
            pgem_destroy(*graph);
            *graph = NULL;
            continue;
        }
        break;
    }
    pgem_io_graph_free(&file);
    if (status != PGEM_OK) {
        fprintf(stderr, "bench_factor: %s: %s\n", path,
                *graph != NULL ? pgem_last_error(*graph) : pgem_io_error_description(status));
    }
    return status;
}

static int bench_pgem(const bench_args_t *args)
{
    pgem_t *graph = NULL;
    if (bench_load(args->input, !args->matrix_only, (uint32_t)args->threads, &graph) != PGEM_OK) {
        pgem_destroy(graph);
        return 1;
    }
    if (args->matrix_only) {
        return bench_matrix(graph, args->matrix);
    }
    pgem_thread_pool_t *pool = NULL;
    if (args->threads > 1) {
        if (pgem_thread_pool_create((uint32_t)args->threads, &pool) != PGEM_OK) {
            fprintf(stderr, "bench_factor: cannot start %d threads\n", args->threads);
            pgem_destroy(graph);
            return 1;
        }
        const pgem_executor_t executor = pgem_thread_pool_executor(pool);
        (void)pgem_set_executor(graph, &executor);
    }
    double analysis[BENCH_REPEAT_MAX], factor_times[BENCH_REPEAT_MAX], iteration[BENCH_REPEAT_MAX];
    for (int r = 0; r < args->repeat; r++) {
        pgem_factor_hook_forget(graph);
        const double start = bench_now();
        (void)pgem_analyze(graph);
        analysis[r] = bench_now() - start;
    }
    (void)pgem_factor_hook_assemble(graph);
    for (int r = 0; r < args->repeat; r++) {
        const double start = bench_now();
        if (pgem_factor_hook_factor(graph) != PGEM_OK) {
            fprintf(stderr, "bench_factor: %s\n", pgem_last_error(graph));
            pgem_set_executor(graph, NULL);
            pgem_thread_pool_destroy(pool);
            pgem_destroy(graph);
            return 1;
        }
        factor_times[r] = bench_now() - start;
    }
    /* one Gauss-Newton iteration from the file's estimate, restored after each */
    const uint32_t poses = pgem_pose_count(graph);
    const int pose_size = pgem_dimension(graph) == 3 ? 7 : 3;
    double *saved = malloc((size_t)poses * (size_t)pose_size * sizeof *saved);
    pgem_solve_options_t options = {0};
    pgem_summary_t summary;
    options.max_iterations = 1;
    for (uint32_t p = 0; saved != NULL && p < poses; p++) {
        (void)pgem_pose_at(graph, p, NULL, saved + (size_t)p * (size_t)pose_size, NULL);
    }
    for (int r = 0; saved != NULL && r < args->repeat; r++) {
        const double start = bench_now();
        (void)pgem_optimize(graph, &options, &summary);
        iteration[r] = bench_now() - start;
        for (uint32_t p = 0; p < poses; p++) {
            pgem_id_t id;
            (void)pgem_pose_at(graph, p, &id, NULL, NULL);
            (void)pgem_set_pose(graph, id, saved + (size_t)p * (size_t)pose_size);
        }
    }
    free(saved);
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    pgem_factor_hook_figures_t factor;
    pgem_factor_hook_figures(graph, &factor);
    printf("{\"mode\":\"pgem\",\"input\":\"%s\",\"poses\":%u,\"edges\":%u,\"unknowns\":%d,"
           "\"factor_nonzeros\":%u,\"exact_nonzeros\":%d,\"flops\":%.6g,"
           "\"executed_multiply_adds\":%.6g,\"supernodes\":%d,\"kernels\":\"%s\","
           "\"ordering\":\"%s\",\"amd_flops\":%.6g,\"nested_flops\":%.6g,\"metis_flops\":%.6g,"
           "\"block_bytes\":%zu,\"threads\":%d",
           args->input, pgem_pose_count(graph), pgem_edge_count(graph),
           factor.unknowns, stats.factor_nonzeros, factor.exact_nonzeros, factor.exact_flops,
           factor.flops, factor.supernodes, factor.kernels,
           strcmp(factor.ordering, "orderer") == 0 ? "metis" : factor.ordering, /* METIS's */
           factor.amd_flops, factor.nested_flops, factor.orderer_flops, stats.block_bytes,
           args->threads);
    bench_print_times("analysis", analysis, args->repeat);
    bench_print_times("factor", factor_times, args->repeat);
    if (saved != NULL) {
        bench_print_times("iteration", iteration, args->repeat);
    }
    printf(",\"peak_rss_bytes\":%zu}\n", bench_status_bytes("VmHWM"));
    (void)pgem_set_executor(graph, NULL);
    pgem_thread_pool_destroy(pool);
    return bench_matrix(graph, args->matrix);
}

/* ---------------------------------------------------------------------------------------- */
/* cholmod mode */

static cholmod_sparse *bench_read_matrix(const char *path, cholmod_common *common)
{
    FILE *file = fopen(path, "rb");
    char magic[8];
    int64_t header[2];
    if (file == NULL || fread(magic, 1, 8, file) != 8 || memcmp(magic, "PGEMH1\n", 8) != 0 ||
        fread(header, sizeof header, 1, file) != 1) {
        if (file != NULL) {
            fclose(file);
        }
        return NULL;
    }
    const size_t order = (size_t)header[0], count = (size_t)header[1];
    cholmod_triplet *t = cholmod_allocate_triplet(order, order, count, 1, CHOLMOD_REAL, common);
    int32_t *rows = malloc(count * sizeof *rows), *columns = malloc(count * sizeof *columns);
    int ok = t != NULL && rows != NULL && columns != NULL &&
             fread(rows, sizeof *rows, count, file) == count &&
             fread(columns, sizeof *columns, count, file) == count &&
             fread(t->x, sizeof(double), count, file) == count;
    fclose(file);
    for (size_t k = 0; ok && k < count; k++) {
        ((int *)t->i)[k] = rows[k];
        ((int *)t->j)[k] = columns[k];
    }
    free(rows);
    free(columns);
    cholmod_sparse *a = NULL;
    if (ok) {
        t->nnz = count;
        a = cholmod_triplet_to_sparse(t, count, common);
    }
    cholmod_free_triplet(&t, common);
    return a;
}

static const char *bench_ordering_name(int ordering)
{
    switch (ordering) {
    case CHOLMOD_NATURAL: return "natural";
    case CHOLMOD_GIVEN: return "given";
    case CHOLMOD_AMD: return "amd";
    case CHOLMOD_METIS: return "metis";
    case CHOLMOD_NESDIS: return "nesdis";
    case CHOLMOD_COLAMD: return "colamd";
    case CHOLMOD_POSTORDERED: return "postordered";
    default: return "unknown";
    }
}

/* Sum of squared column counts of L's exact pattern (the analysis's ColCount). */
static double bench_cholmod_flops(const cholmod_factor *factor)
{
    const int *counts = factor->ColCount;
    double flops = 0.0;
    for (size_t j = 0; j < factor->n; j++) {
        flops += (double)counts[j] * (double)counts[j];
    }
    return flops;
}

static int bench_cholmod(const bench_args_t *args)
{
    cholmod_common common;
    cholmod_start(&common);
    cholmod_sparse *a = bench_read_matrix(args->input, &common);
    if (a == NULL) {
        fprintf(stderr, "bench_factor: cannot read the matrix %s\n", args->input);
        cholmod_finish(&common);
        return 1;
    }
    const size_t rss_before = bench_status_bytes("VmRSS");
    double analysis[BENCH_REPEAT_MAX], factor[BENCH_REPEAT_MAX];
    cholmod_factor *l = NULL;
    for (int r = 0; r < args->repeat; r++) {
        if (l != NULL) {
            cholmod_free_factor(&l, &common);
        }
        const double start = bench_now();
        l = cholmod_analyze(a, &common);
        analysis[r] = bench_now() - start;
    }
    const double flops = l != NULL ? bench_cholmod_flops(l) : 0.0;
    const double lnz = common.lnz;
    for (int r = 0; l != NULL && r < args->repeat; r++) {
        const double start = bench_now();
        cholmod_factorize(a, l, &common);
        factor[r] = bench_now() - start;
    }
    if (l == NULL || common.status != CHOLMOD_OK) {
        fprintf(stderr, "bench_factor: CHOLMOD failed (status %d)\n", common.status);
        cholmod_free_sparse(&a, &common);
        cholmod_finish(&common);
        return 1;
    }
    char blas[512];
    bench_blas_library(blas, sizeof blas);
    printf("{\"mode\":\"cholmod\",\"input\":\"%s\",\"unknowns\":%zu,\"factor_nonzeros\":%.0f,"
           "\"flops\":%.6g,\"ordering\":\"%s\",\"supernodal\":%s,\"blas\":\"%s\"",
           args->input, a->nrow, lnz, flops,
           bench_ordering_name(common.method[common.selected].ordering),
           l->is_super ? "true" : "false", blas);
    bench_print_times("analysis", analysis, args->repeat);
    bench_print_times("factor", factor, args->repeat);
    printf(",\"peak_rss_bytes\":%zu,\"rss_before_bytes\":%zu}\n", bench_status_bytes("VmHWM"),
           rss_before);
    cholmod_free_factor(&l, &common);
    cholmod_free_sparse(&a, &common);
    cholmod_finish(&common);
    return 0;
}

int main(int argc, char **argv)
{
    bench_args_t args;
    if (!bench_parse(argc, argv, &args)) {
        fprintf(stderr, "usage: pgem-bench-factor pgem FILE [--repeat N] [--threads T] "
                        "[--matrix H.bin]\n       pgem-bench-factor cholmod H.bin [--repeat N]\n");
        return 2;
    }
    if (strcmp(args.mode, "pgem") == 0) {
        return bench_pgem(&args);
    }
    if (strcmp(args.mode, "cholmod") == 0) {
        return bench_cholmod(&args);
    }
    fprintf(stderr, "pgem-bench-factor: unknown mode '%s' (pgem or cholmod)\n", args.mode);
    return 2;
}
