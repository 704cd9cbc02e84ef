/* Fuzz target: the core API driven by a program read from the input. A header chooses the
 * dimension, small capacities, the fill budget and the block's alignment; then each op is one
 * call (add_pose, add_edge, fix_pose, set_pose, optimize, robust_optimize, robust_reset,
 * analyze) with ids, values, information matrices and options taken from the input,
 * including unknown, duplicate and huge ids, NaN, Inf, huge and denormal values, asymmetric
 * and indefinite information. After every call:
 * - the code is one the header documents for that call;
 * - a failed call changed nothing (an optimize left the estimate as it was; a robust solve
 *   the estimate and the graph, its loop weights and prune states included) and left a
 *   message;
 * - a successful call changed what it should: one more pose or edge, the fixed flag, one pose;
 *   a solve left finite poses, the held poses (fixed ones, else the first) unmoved, loop
 *   weights in [0, 1] and odometry at weight 1;
 * - the queries agree with each other, the memory stats stay within the block (and the factor
 *   within the fill budget after a successful analysis), and the call took less than
 *   FUZZ_CALL_SECONDS.
 * With PGEM_FUZZ_TRACE set in the environment, every call, its arguments and its outcome are
 * printed (to turn a found input into a readable regression test). */
#define _POSIX_C_SOURCE 200809L

#include <time.h>

#include "fuzz.h"
#include "fuzz_input.h"
#include "pgem/pgem.h"

#define MAX_POSES 24u
#define MAX_EDGES 48u
#define MAX_OPS 96u
#define ID_RANGE 32u            /* small ids are 0 .. 31: some known, some not */
#define FUZZ_CALL_SECONDS 2.0   /* no call on a graph this small may take longer */

/* ---- reading the program --------------------------------------------------------------- */

/* A pose or measurement; a mode bit normalises a 3D quaternion first, so most 3D values are
 * valid rotations and the solver is reached. */
static void read_pose(fuzz_input_t *in, int dimension, double *pose)
{
    uint8_t mode = fuzz_byte(in);
    for (int k = 0; k < PGEM_POSE_SIZE(dimension); ++k) {
        pose[k] = fuzz_value(in);
    }
    if (dimension == 3 && (mode & 1u)) {
        double *q = pose + 3;
        double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        if (isfinite(norm) && norm > 0.0) {
            for (int k = 0; k < 4; ++k) {
                q[k] /= norm;
            }
        }
    }
}

/* An information matrix: a scaled identity, a diagonal, any n x n values, or a symmetric
 * matrix from its upper triangle. */
static void read_information(fuzz_input_t *in, int dimension, double *information)
{
    const int n = PGEM_TANGENT_SIZE(dimension);
    uint8_t mode = fuzz_byte(in) % 4u;
    memset(information, 0, sizeof(double) * (size_t)(n * n));
    if (mode == 0) {
        double scale = fuzz_value(in);
        for (int i = 0; i < n; ++i) {
            information[i * n + i] = scale;
        }
    } else if (mode == 1) {
        for (int i = 0; i < n; ++i) {
            information[i * n + i] = fuzz_value(in);
        }
    } else if (mode == 2) {
        for (int k = 0; k < n * n; ++k) {
            information[k] = fuzz_value(in);
        }
    } else {
        for (int i = 0; i < n; ++i) {
            for (int j = i; j < n; ++j) {
                information[i * n + j] = information[j * n + i] = fuzz_value(in);
            }
        }
    }
}

/* ---- the graph as the API shows it ----------------------------------------------------- */

typedef struct snapshot {
    uint32_t poses;
    uint32_t edges;
    pgem_id_t id[MAX_POSES];
    double pose[MAX_POSES][PGEM_POSE_SIZE_MAX];
    int fixed[MAX_POSES];
    pgem_edge_view_t edge[MAX_EDGES];
} snapshot_t;

static void take_snapshot(const pgem_t *graph, snapshot_t *s)
{
    memset(s, 0, sizeof *s);
    s->poses = pgem_pose_count(graph);
    s->edges = pgem_edge_count(graph);
    FUZZ_CHECK(s->poses <= MAX_POSES && s->edges <= MAX_EDGES);
    for (uint32_t i = 0; i < s->poses; ++i) {
        FUZZ_CHECK(pgem_pose_at(graph, i, &s->id[i], s->pose[i], &s->fixed[i]) == PGEM_OK);
    }
    for (uint32_t k = 0; k < s->edges; ++k) {
        FUZZ_CHECK(pgem_edge_at(graph, k, &s->edge[k]) == PGEM_OK);
    }
    FUZZ_CHECK(pgem_pose_at(graph, s->poses, NULL, NULL, NULL) == PGEM_ERR_INVALID_ARGUMENT);
    pgem_edge_view_t view;
    FUZZ_CHECK(pgem_edge_at(graph, s->edges, &view) == PGEM_ERR_INVALID_ARGUMENT);
}

/* Same poses, fixed flags and edges; weights and prune states only when asked. */
static int same_graph(const snapshot_t *a, const snapshot_t *b, size_t pose_bytes, size_t n,
                      int with_weights)
{
    if (a->poses != b->poses || a->edges != b->edges) {
        return 0;
    }
    for (uint32_t i = 0; i < a->poses; ++i) {
        if (a->id[i] != b->id[i] || a->fixed[i] != b->fixed[i] ||
            memcmp(a->pose[i], b->pose[i], pose_bytes) != 0) {
            return 0;
        }
    }
    for (uint32_t k = 0; k < a->edges; ++k) {
        const pgem_edge_view_t *x = &a->edge[k];
        const pgem_edge_view_t *y = &b->edge[k];
        if (x->from != y->from || x->to != y->to || x->kind != y->kind ||
            memcmp(x->measurement, y->measurement, pose_bytes) != 0 ||
            memcmp(x->information, y->information, n * n * sizeof(double)) != 0) {
            return 0;
        }
        if (with_weights && (memcmp(&x->weight, &y->weight, sizeof x->weight) != 0 ||
                             x->active != y->active)) {
            return 0;
        }
    }
    return 1;
}

/* ---- the state of one run -------------------------------------------------------------- */

typedef struct run {
    pgem_t *graph;
    int dimension;
    size_t pose_bytes;
    size_t n;                 /* tangent size */
    snapshot_t before;
    snapshot_t after;
    int after_solve;          /* the call being checked analyses (optimize, analyze) */
    const char *call;         /* its name, for the trace */
    int trace;                /* PGEM_FUZZ_TRACE set: print every call and its outcome */
    struct timespec started;
} run_t;

static void start_call(run_t *run, const char *call, int solves)
{
    run->after_solve = solves;
    run->call = call;
    take_snapshot(run->graph, &run->before);
    clock_gettime(CLOCK_MONOTONIC, &run->started);
}

/* Checks shared by every call once it returned: time, memory, queries, message. */
static void end_call(run_t *run, int status)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    if (run->trace) {
        fprintf(stderr, "%s: %s %s\n", run->call, pgem_error_name(status),
                pgem_last_error(run->graph));
    }
    double seconds = (double)(now.tv_sec - run->started.tv_sec) +
                     (double)(now.tv_nsec - run->started.tv_nsec) * 1e-9;
    FUZZ_CHECK(seconds < FUZZ_CALL_SECONDS);
    take_snapshot(run->graph, &run->after);

    pgem_memory_stats_t stats;
    pgem_memory_use(run->graph, &stats);
    FUZZ_CHECK(stats.used_bytes <= stats.block_bytes);
    /* after a successful analysis the factor fits its budget (a failed one reports the need) */
    FUZZ_CHECK(status != PGEM_OK || run->after_solve == 0 ||
               stats.factor_nonzeros <= stats.factor_budget);
    FUZZ_CHECK(stats.csparse_pool_peak <= stats.csparse_pool_bytes);

    const char *message = pgem_last_error(run->graph);
    FUZZ_CHECK(memchr(message, '\0', 256) != NULL);
    FUZZ_CHECK(status == PGEM_OK || message[0] != '\0');

    /* every pose is found by its id, at its index, with the estimate pose_at shows */
    for (uint32_t i = 0; i < run->after.poses; ++i) {
        uint32_t index = UINT32_MAX;
        double pose[PGEM_POSE_SIZE_MAX];
        FUZZ_CHECK(pgem_pose_index(run->graph, run->after.id[i], &index) == PGEM_OK && index == i);
        FUZZ_CHECK(pgem_pose(run->graph, run->after.id[i], pose) == PGEM_OK);
        FUZZ_CHECK(memcmp(pose, run->after.pose[i], run->pose_bytes) == 0);
    }
    for (uint32_t k = 0; k < run->after.edges; ++k) {
        double chi2;
        const pgem_edge_view_t *edge = &run->after.edge[k];
        FUZZ_CHECK(pgem_edge_chi2(run->graph, k, &chi2) == PGEM_OK);
        FUZZ_CHECK(edge->weight >= 0.0 && edge->weight <= 1.0);
        if (edge->kind == PGEM_EDGE_ODOMETRY) {
            FUZZ_CHECK(edge->weight == 1.0 && edge->active);
        }
    }
}

static int one_of(int status, const int *codes, size_t count)
{
    for (size_t i = 0; i < count; ++i) {
        if (status == codes[i]) {
            return 1;
        }
    }
    return 0;
}

#define ONE_OF(status, ...)                                                   \
    one_of(status, (const int[]){PGEM_OK, __VA_ARGS__},                       \
           sizeof((const int[]){PGEM_OK, __VA_ARGS__}) / sizeof(int))

/* The trace of a call's arguments: a label and values. */
static void trace_values(const run_t *run, const char *label, const double *values, size_t count)
{
    if (!run->trace) {
        return;
    }
    fprintf(stderr, "  %s", label);
    for (size_t k = 0; k < count; ++k) {
        fprintf(stderr, " %.17g", values[k]);
    }
    fputc('\n', stderr);
}

/* A failed call changed nothing. */
static void check_unchanged(const run_t *run, int with_weights)
{
    FUZZ_CHECK(same_graph(&run->before, &run->after, run->pose_bytes, run->n, with_weights));
}

/* ---- the calls -------------------------------------------------------------------------- */

/* The id and the pose of an add_pose or set_pose call, traced. */
static pgem_id_t read_id_and_pose(run_t *run, fuzz_input_t *in, double *pose)
{
    pgem_id_t id = fuzz_id(in, ID_RANGE);
    read_pose(in, run->dimension, pose);
    if (run->trace) {
        fprintf(stderr, "  id %llu\n", (unsigned long long)id);
    }
    trace_values(run, "pose", pose, run->pose_bytes / sizeof(double));
    return id;
}

static void op_add_pose(run_t *run, fuzz_input_t *in)
{
    double pose[PGEM_POSE_SIZE_MAX];
    pgem_id_t id = read_id_and_pose(run, in, pose);
    start_call(run, "add_pose", 0);
    int status = pgem_add_pose(run->graph, id, pose);
    end_call(run, status);
    FUZZ_CHECK(ONE_OF(status, PGEM_ERR_CAPACITY, PGEM_ERR_DUPLICATE_ID, PGEM_ERR_NOT_FINITE,
                      PGEM_ERR_OUT_OF_RANGE, PGEM_ERR_ROTATION));
    if (status != PGEM_OK) {
        check_unchanged(run, 1);
        return;
    }
    uint32_t last = run->before.poses;
    FUZZ_CHECK(run->after.poses == last + 1 && run->after.id[last] == id);
    FUZZ_CHECK(run->after.fixed[last] == 0);
    run->after.poses = last; /* the rest is as before */
    check_unchanged(run, 1);
}

static void op_add_edge(run_t *run, fuzz_input_t *in)
{
    pgem_id_t from = fuzz_id(in, ID_RANGE);
    pgem_id_t to = fuzz_id(in, ID_RANGE);
    uint8_t kind_byte = fuzz_byte(in);
    int kind = kind_byte < 0xF0u ? kind_byte & 1 : (int)(int8_t)kind_byte;
    double measurement[PGEM_POSE_SIZE_MAX];
    double information[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    read_pose(in, run->dimension, measurement);
    read_information(in, run->dimension, information);
    uint32_t index = UINT32_MAX;
    if (run->trace) {
        fprintf(stderr, "  %llu -> %llu kind %d\n", (unsigned long long)from,
                (unsigned long long)to, kind);
    }
    trace_values(run, "measurement", measurement, run->pose_bytes / sizeof(double));
    trace_values(run, "information", information, run->n * run->n);
    start_call(run, "add_edge", 0);
    int status = pgem_add_edge(run->graph, from, to, measurement, information,
                               (pgem_edge_kind_t)kind, &index);
    end_call(run, status);
    FUZZ_CHECK(ONE_OF(status, PGEM_ERR_CAPACITY, PGEM_ERR_UNKNOWN_ID, PGEM_ERR_SELF_LOOP,
                      PGEM_ERR_NOT_FINITE, PGEM_ERR_OUT_OF_RANGE, PGEM_ERR_INFORMATION,
                      PGEM_ERR_ROTATION, PGEM_ERR_INVALID_ARGUMENT));
    if (status != PGEM_OK) {
        FUZZ_CHECK(index == UINT32_MAX);
        check_unchanged(run, 1);
        return;
    }
    uint32_t last = run->before.edges;
    const pgem_edge_view_t *edge = &run->after.edge[last];
    FUZZ_CHECK(index == last && run->after.edges == last + 1);
    FUZZ_CHECK(edge->from == from && edge->to == to && (int)edge->kind == kind);
    FUZZ_CHECK(memcmp(edge->information, information, run->n * run->n * sizeof(double)) == 0);
    FUZZ_CHECK(edge->weight == 1.0 && edge->active);
    run->after.edges = last;
    check_unchanged(run, 1);
}

static void op_fix_pose(run_t *run, fuzz_input_t *in)
{
    pgem_id_t id = fuzz_id(in, ID_RANGE);
    int fixed = fuzz_byte(in) & 1;
    if (run->trace) {
        fprintf(stderr, "  id %llu fixed %d\n", (unsigned long long)id, fixed);
    }
    start_call(run, "fix_pose", 0);
    int status = pgem_fix_pose(run->graph, id, fixed);
    end_call(run, status);
    FUZZ_CHECK(ONE_OF(status, PGEM_ERR_UNKNOWN_ID));
    if (status == PGEM_OK) {
        uint32_t index = 0;
        FUZZ_CHECK(pgem_pose_index(run->graph, id, &index) == PGEM_OK);
        FUZZ_CHECK(run->after.fixed[index] == fixed);
        run->after.fixed[index] = run->before.fixed[index];
    }
    check_unchanged(run, 1);
}

static void op_set_pose(run_t *run, fuzz_input_t *in)
{
    double pose[PGEM_POSE_SIZE_MAX];
    pgem_id_t id = read_id_and_pose(run, in, pose);
    start_call(run, "set_pose", 0);
    int status = pgem_set_pose(run->graph, id, pose);
    end_call(run, status);
    FUZZ_CHECK(ONE_OF(status, PGEM_ERR_UNKNOWN_ID, PGEM_ERR_NOT_FINITE, PGEM_ERR_OUT_OF_RANGE,
                      PGEM_ERR_ROTATION));
    if (status == PGEM_OK) {
        uint32_t index = 0;
        FUZZ_CHECK(pgem_pose_index(run->graph, id, &index) == PGEM_OK);
        memcpy(run->after.pose[index], run->before.pose[index], run->pose_bytes);
    }
    check_unchanged(run, 1);
}

/* After a successful solve: finite poses, and the held ones (the fixed poses, or the first
 * pose when none is fixed) exactly where they were. */
static void check_solved(const run_t *run)
{
    int any_fixed = 0;
    for (uint32_t i = 0; i < run->after.poses; ++i) {
        for (size_t k = 0; k < run->pose_bytes / sizeof(double); ++k) {
            FUZZ_CHECK(isfinite(run->after.pose[i][k]));
        }
        any_fixed |= run->after.fixed[i];
        if (run->after.fixed[i]) {
            FUZZ_CHECK(memcmp(run->after.pose[i], run->before.pose[i], run->pose_bytes) == 0);
        }
    }
    if (!any_fixed && run->after.poses > 0) {
        FUZZ_CHECK(memcmp(run->after.pose[0], run->before.pose[0], run->pose_bytes) == 0);
    }
}

/* The iteration callback: checks what it is shown and stops after `stop_at` iterations. */
typedef struct watcher {
    uint32_t calls;
    uint32_t stop_at;   /* 0: never */
} watcher_t;

static int on_iteration(const pgem_iteration_t *iteration, void *user)
{
    watcher_t *watcher = user;
    watcher->calls++;
    FUZZ_CHECK(iteration->accepted == 0 || iteration->accepted == 1);
    FUZZ_CHECK(iteration->lambda >= 0.0);
    return watcher->stop_at != 0 && iteration->iteration >= watcher->stop_at;
}

static int on_round(const pgem_robust_progress_t *progress, void *user)
{
    watcher_t *watcher = user;
    watcher->calls++;
    FUZZ_CHECK(progress->round >= 1);
    return watcher->stop_at != 0 && progress->round >= watcher->stop_at;
}

/* A positive option value from the input, or 0 (the default) when it is not a finite one:
 * options are drawn from their documented ranges. */
static double read_positive(fuzz_input_t *in)
{
    double value = fabs(fuzz_value(in));
    return isfinite(value) ? value : 0.0;
}

/* A tolerance: 0 (the default), negative (disabled) or a positive value from the input. */
static double read_tolerance(fuzz_input_t *in)
{
    uint8_t choice = fuzz_byte(in) % 4u;
    return choice == 0 ? 0.0 : choice == 1 ? -1.0 : read_positive(in) * 1e-6;
}

static void read_solve_options(fuzz_input_t *in, pgem_solve_options_t *options,
                               watcher_t *watcher)
{
    memset(options, 0, sizeof *options);
    uint8_t method = fuzz_byte(in);
    options->method = (pgem_method_t)(method < 0xF0u ? method & 1 : 2 + (method & 1));
    options->max_iterations = 1u + fuzz_byte(in) % 12u;
    options->relative_chi2_tolerance = read_tolerance(in);
    options->step_tolerance = read_tolerance(in);
    options->initial_lambda = read_positive(in);
    uint8_t stop = fuzz_byte(in) % 8u;
    if (stop > 0) {
        watcher->stop_at = stop - 1u; /* 0: watch, never stop */
        options->on_iteration = on_iteration;
        options->user = watcher;
    }
}

static void trace_solve_options(const run_t *run, const pgem_solve_options_t *options,
                                const watcher_t *watcher)
{
    if (run->trace) {
        fprintf(stderr, "  method %d max_iterations %u tolerances %.17g %.17g lambda %.17g "
                        "stop %s%u\n", (int)options->method, (unsigned)options->max_iterations,
                options->relative_chi2_tolerance, options->step_tolerance,
                options->initial_lambda, options->on_iteration ? "at " : "none ",
                (unsigned)watcher->stop_at);
    }
}

static void op_optimize(run_t *run, fuzz_input_t *in)
{
    pgem_solve_options_t options;
    watcher_t watcher = {0, 0};
    read_solve_options(in, &options, &watcher);
    trace_solve_options(run, &options, &watcher);
    pgem_summary_t summary;
    start_call(run, "optimize", 1);
    int status = pgem_optimize(run->graph, &options, &summary);
    end_call(run, status);
    FUZZ_CHECK(ONE_OF(status, PGEM_ERR_NOT_POSITIVE_DEFINITE, PGEM_ERR_NUMERIC,
                      PGEM_ERR_FILL_BUDGET, PGEM_ERR_EMPTY, PGEM_ERR_OUT_OF_MEMORY,
                      PGEM_ERR_INVALID_ARGUMENT));
    FUZZ_CHECK(watcher.calls <= options.max_iterations);
    if (status != PGEM_OK) {
        FUZZ_CHECK(status == PGEM_ERR_INVALID_ARGUMENT || summary.usable == 0);
        check_unchanged(run, 1);
        return;
    }
    FUZZ_CHECK(options.method == PGEM_GAUSS_NEWTON || options.method == PGEM_LEVENBERG_MARQUARDT);
    FUZZ_CHECK(summary.usable == 1);
    FUZZ_CHECK(summary.termination >= PGEM_TERM_CHI2_CONVERGED &&
               summary.termination <= PGEM_TERM_NO_PROGRESS);
    FUZZ_CHECK(summary.iterations <= options.max_iterations);
    FUZZ_CHECK(isfinite(summary.final_chi2));
    check_solved(run);
    /* only the estimate moves */
    memcpy(run->after.pose, run->before.pose, sizeof run->after.pose);
    check_unchanged(run, 1);
}

static void read_robust_options(fuzz_input_t *in, pgem_robust_options_t *options,
                                watcher_t *watcher)
{
    memset(options, 0, sizeof *options);
    uint8_t kernel = fuzz_byte(in);
    options->kernel = (pgem_kernel_t)(kernel < 0xF0u ? (int)(kernel % 5u) : (int)(int8_t)kernel);
    options->scale = fuzz_byte(in) & 1u ? read_positive(in) : 0.0;
    options->prune_threshold = (double)(fuzz_byte(in) % 8u) * 0.05;
    options->weight_tolerance = (double)(fuzz_byte(in) % 4u) * 0.01;
    options->m_step_iterations = fuzz_byte(in) % 3u;
    options->max_em_iterations = 1u + fuzz_byte(in) % 4u;
    options->max_rounds = 1u + fuzz_byte(in) % 4u;
    uint8_t flags = fuzz_byte(in);
    options->restart = flags & 1u;
    options->literal = (flags >> 1) & 1u;
    options->gate = (flags & 4u) ? read_positive(in) : 0.0;
    options->dormant_threshold = (flags & 8u) ? -1.0 : (flags & 16u) ? 0.05 : 0.0;
    if (flags & 32u) {
        watcher->stop_at = 1u + fuzz_byte(in) % 3u;
        options->on_round = on_round;
        options->user = watcher;
    }
}

static void op_robust(run_t *run, fuzz_input_t *in)
{
    pgem_robust_options_t options;
    pgem_solve_options_t solve;
    watcher_t round_watcher = {0, 0};
    watcher_t iteration_watcher = {0, 0};
    read_robust_options(in, &options, &round_watcher);
    read_solve_options(in, &solve, &iteration_watcher);
    solve.method = PGEM_GAUSS_NEWTON;
    if (run->trace) {
        fprintf(stderr, "  kernel %d scale %.17g prune %g tolerance %g m-step %u em %u rounds %u "
                        "restart %d literal %d gate %.17g dormant %g\n",
                (int)options.kernel, options.scale, options.prune_threshold,
                options.weight_tolerance, (unsigned)options.m_step_iterations,
                (unsigned)options.max_em_iterations, (unsigned)options.max_rounds,
                options.restart, options.literal, options.gate, options.dormant_threshold);
    }
    trace_solve_options(run, &solve, &iteration_watcher);
    pgem_robust_summary_t summary;
    start_call(run, "robust_optimize", 1);
    int status = pgem_robust_optimize(run->graph, &options, &solve, &summary);
    end_call(run, status);
    FUZZ_CHECK(ONE_OF(status, PGEM_ERR_NOT_POSITIVE_DEFINITE, PGEM_ERR_NUMERIC,
                      PGEM_ERR_FILL_BUDGET, PGEM_ERR_EMPTY, PGEM_ERR_OUT_OF_MEMORY,
                      PGEM_ERR_INVALID_ARGUMENT));
    if (status != PGEM_OK) {
        FUZZ_CHECK(summary.usable == 0);
        check_unchanged(run, 1); /* weights and prune states too (robust.h) */
        return;
    }
    FUZZ_CHECK(summary.usable == 1 && summary.pruned <= summary.loops);
    FUZZ_CHECK(isfinite(summary.final_chi2));
    check_solved(run);
    memcpy(run->after.pose, run->before.pose, sizeof run->after.pose);
    check_unchanged(run, 0);
}

static void op_robust_reset(run_t *run)
{
    start_call(run, "robust_reset", 0);
    pgem_robust_reset(run->graph);
    end_call(run, PGEM_OK);
    for (uint32_t k = 0; k < run->after.edges; ++k) {
        FUZZ_CHECK(run->after.edge[k].weight == 1.0 && run->after.edge[k].active);
    }
    check_unchanged(run, 0);
}

static void op_analyze(run_t *run)
{
    start_call(run, "analyze", 1);
    int status = pgem_analyze(run->graph);
    end_call(run, status);
    FUZZ_CHECK(ONE_OF(status, PGEM_ERR_FILL_BUDGET, PGEM_ERR_EMPTY, PGEM_ERR_OUT_OF_MEMORY,
                      PGEM_ERR_NOT_POSITIVE_DEFINITE));
    check_unchanged(run, 1);
}

/* ---- entry ------------------------------------------------------------------------------ */

enum {
    OP_ADD_POSE = 0, OP_ADD_POSE_TOO, OP_ADD_EDGE, OP_ADD_EDGE_TOO, OP_FIX, OP_OPTIMIZE,
    OP_ROBUST, OP_SET_POSE, OP_ROBUST_RESET, OP_ANALYZE, OP_COUNT
};

/* Header: dimension and max_poses, max_edges, fill_budget (0: the default), block offset. */
static pgem_config_t read_config(fuzz_input_t *in, size_t *offset)
{
    pgem_config_t config;
    memset(&config, 0, sizeof config);
    uint8_t b = fuzz_byte(in);
    config.dimension = (b & 1u) ? 3 : 2;
    config.max_poses = 1u + (uint32_t)(b >> 1) % MAX_POSES;
    config.max_edges = 1u + (uint32_t)fuzz_byte(in) % MAX_EDGES;
    config.fill_budget = (uint32_t)fuzz_byte(in) * 8u;
    *offset = fuzz_byte(in) % 16u;
    return config;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_input_t in = {data, size, 0};
    size_t offset = 0;
    pgem_config_t config = read_config(&in, &offset);
    size_t bytes = pgem_memory_size(&config);
    FUZZ_CHECK(bytes > 0);
    unsigned char *block = malloc(bytes + offset);
    FUZZ_CHECK(block != NULL);
    run_t run;
    memset(&run, 0, sizeof run);
    FUZZ_CHECK(pgem_init(&run.graph, &config, block + offset, bytes - 1) ==
               PGEM_ERR_BUFFER_TOO_SMALL);
    FUZZ_CHECK(pgem_init(&run.graph, &config, block + offset, bytes) == PGEM_OK);
    run.dimension = config.dimension;
    run.pose_bytes = sizeof(double) * (size_t)PGEM_POSE_SIZE(config.dimension);
    run.n = (size_t)PGEM_TANGENT_SIZE(config.dimension);
    run.trace = getenv("PGEM_FUZZ_TRACE") != NULL;
    for (unsigned op = 0; op < MAX_OPS && fuzz_more(&in); ++op) {
        switch (fuzz_byte(&in) % OP_COUNT) {
        case OP_ADD_POSE:
        case OP_ADD_POSE_TOO: op_add_pose(&run, &in); break;
        case OP_ADD_EDGE:
        case OP_ADD_EDGE_TOO: op_add_edge(&run, &in); break;
        case OP_FIX: op_fix_pose(&run, &in); break;
        case OP_OPTIMIZE: op_optimize(&run, &in); break;
        case OP_ROBUST: op_robust(&run, &in); break;
        case OP_SET_POSE: op_set_pose(&run, &in); break;
        case OP_ROBUST_RESET: op_robust_reset(&run); break;
        default: op_analyze(&run); break;
        }
    }
    free(block);
    return 0;
}

/* ---- seeds: a few programs ---------------------------------------------------------------- */

static void put_pose(fuzz_output_t *out, int dimension, const double *pose)
{
    fuzz_put(out, 1); /* normalise a quaternion */
    for (int k = 0; k < PGEM_POSE_SIZE(dimension); ++k) {
        fuzz_put_value(out, pose[k]);
    }
}

static void put_add_pose(fuzz_output_t *out, int dimension, uint64_t id, double x, double y)
{
    double pose[PGEM_POSE_SIZE_MAX] = {x, y, 0.0, 0.0, 0.0, 0.0, 1.0};
    if (dimension == 2) {
        pose[2] = 0.25 * x;
    }
    fuzz_put(out, OP_ADD_POSE);
    fuzz_put_id(out, id);
    put_pose(out, dimension, pose);
}

static void put_add_edge(fuzz_output_t *out, int dimension, uint64_t from, uint64_t to,
                         double dx, double dy, double information)
{
    double measurement[PGEM_POSE_SIZE_MAX] = {dx, dy, 0.0, 0.0, 0.0, 0.0, 1.0};
    fuzz_put(out, OP_ADD_EDGE);
    fuzz_put_id(out, from);
    fuzz_put_id(out, to);
    fuzz_put(out, (from > to ? from - to : to - from) == 1 ? 0 : 1);
    put_pose(out, dimension, measurement);
    fuzz_put(out, 0); /* scaled identity */
    fuzz_put_value(out, information);
}

/* optimize: method, iterations, both tolerances default, lambda 0 (default), no callback */
static void put_optimize(fuzz_output_t *out, uint8_t method, uint8_t iterations)
{
    const uint8_t bytes[] = {OP_OPTIMIZE, method, iterations, 0, 0, FUZZ_GRID(0.0), 0};
    for (size_t i = 0; i < sizeof bytes; ++i) {
        fuzz_put(out, bytes[i]);
    }
}

/* robust: kernel, default scale and thresholds, 1 M-step, 2 E/M iterations, 3 rounds */
static void put_robust(fuzz_output_t *out, uint8_t kernel, uint8_t flags)
{
    const uint8_t bytes[] = {OP_ROBUST, kernel, 0, 0, 0, 1, 1, 2, flags,
                             0, 8, 0, 0, FUZZ_GRID(0.0), 0};
    for (size_t i = 0; i < sizeof bytes; ++i) {
        fuzz_put(out, bytes[i]);
    }
}

/* A square walk of 8 poses with odometry, two true loop closures and one false one. */
static void seed_walk(fuzz_output_t *out, int dimension)
{
    static const double corners[8][2] = {{0, 0}, {1, 0}, {2, 0}, {2, 1},
                                         {2, 2}, {1, 2}, {0, 2}, {0, 1}};
    fuzz_put(out, (uint8_t)((dimension == 3) | (23u << 1)));
    fuzz_put(out, 31);
    fuzz_put(out, 0);
    fuzz_put(out, 0);
    for (uint64_t i = 0; i < 8; ++i) {
        put_add_pose(out, dimension, i, corners[i][0] + 0.0625, corners[i][1]);
    }
    for (uint64_t i = 0; i + 1 < 8; ++i) {
        put_add_edge(out, dimension, i, i + 1, corners[i + 1][0] - corners[i][0],
                     corners[i + 1][1] - corners[i][1], 4.0);
    }
    put_add_edge(out, dimension, 7, 0, 0, -1, 2.0);
    put_add_edge(out, dimension, 0, 4, 2, 2, 2.0);
    put_add_edge(out, dimension, 1, 6, 5, -3, 2.0); /* false */
    fuzz_put(out, OP_FIX);
    fuzz_put_id(out, 0);
    fuzz_put(out, 1);
    put_optimize(out, 0, 5);
    put_optimize(out, 1, 5);
    put_robust(out, 1, 0);     /* EM */
    put_robust(out, 1, 2 | 1); /* EM as published, restarting */
    fuzz_put(out, OP_ROBUST_RESET);
    put_robust(out, 2, 0);     /* Cauchy */
    put_robust(out, 4, 8);     /* DCS */
    fuzz_put(out, OP_ANALYZE);
}

/* Every refusal: duplicate, unknown and huge ids, a self-loop, NaN, an indefinite and an
 * asymmetric information, a bad kind, then capacity (2 poses, 1 edge). */
static void seed_refusals(fuzz_output_t *out)
{
    static const uint8_t program[] = {
        2, 0, 0, 0,                                             /* 2D, 2 poses, 1 edge */
        OP_ADD_POSE, 1, 0, 112, 112, 112,                       /* pose 1 */
        OP_ADD_POSE, 1, 0, 112, 112, 112,                       /* duplicate */
        OP_ADD_POSE, 0xF0, 0, 112, 0xE0, 112,                   /* NaN, id UINT64_MAX */
        OP_ADD_POSE, 2, 0, 128, 112, 0xE8,                      /* pose 2, theta 1e300 */
        OP_ADD_POSE, 3, 0, 112, 112, 112,                       /* capacity */
        OP_ADD_EDGE, 1, 1, 0, 0, 128, 112, 112, 0, 128,         /* self-loop */
        OP_ADD_EDGE, 1, 9, 0, 0, 128, 112, 112, 0, 128,         /* unknown id */
        OP_ADD_EDGE, 1, 2, 0, 0, 128, 112, 112, 1, 128, 96, 128, /* indefinite */
        OP_ADD_EDGE, 1, 2, 0, 0, 128, 112, 112, 2, 128, 120, 112, 112, 128, 112, 112, 112, 128,
        OP_ADD_EDGE, 1, 2, 0xF7, 0, 128, 112, 112, 0, 128,      /* kind -9 */
        OP_ADD_EDGE, 1, 2, 0, 0, 128, 112, 112, 0, 128,         /* accepted */
        OP_ADD_EDGE, 2, 1, 0, 0, 96, 112, 112, 0, 128,          /* capacity */
        OP_FIX, 7, 1,                                           /* unknown id */
        OP_SET_POSE, 2, 0, 0xE1, 112, 112,                      /* Inf */
        OP_OPTIMIZE, 0xF0, 3, 0, 0, 112, 0,                     /* unknown method */
        OP_ROBUST, 0xF9, 0, 0, 0, 0, 1, 1, 0, 0, 3, 0, 0, 112, 0, /* unknown kernel */
        OP_OPTIMIZE, 0, 3, 0, 0, 112, 3,                        /* stopped after 2 */
    };
    for (size_t i = 0; i < sizeof program; ++i) {
        fuzz_put(out, program[i]);
    }
}

/* A 3D chain under a fill budget too small for its factor, then with no edges left to add. */
static void seed_fill_budget(fuzz_output_t *out)
{
    fuzz_put(out, (uint8_t)(1u | (5u << 1)));
    fuzz_put(out, 7);
    fuzz_put(out, 4); /* 32 nonzeros */
    fuzz_put(out, 3);
    for (uint64_t i = 0; i < 6; ++i) {
        put_add_pose(out, 3, i, (double)i, 0.0);
    }
    for (uint64_t i = 0; i + 1 < 6; ++i) {
        put_add_edge(out, 3, i, i + 1, 1.0, 0.0, 1.0);
    }
    put_add_edge(out, 3, 5, 0, -5.0, 0.0, 1.0);
    put_optimize(out, 1, 3);
    fuzz_put(out, OP_ANALYZE);
}

size_t fuzz_seed(unsigned index, uint8_t *buffer, size_t capacity)
{
    fuzz_output_t out = {buffer, 0, capacity};
    switch (index) {
    case 0: seed_walk(&out, 2); break;
    case 1: seed_walk(&out, 3); break;
    case 2: seed_refusals(&out); break;
    case 3: seed_fill_budget(&out); break;
    default: return 0;
    }
    FUZZ_CHECK(out.size <= capacity);
    return out.size;
}
