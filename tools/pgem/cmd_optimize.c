/* pgem optimize: read a graph, run Gauss-Newton or Levenberg-Marquardt, print progress and a
 * summary, write the result. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "covariances.h"
#include "write_ahead.h"

/* Command-line choices of one optimize run. */
typedef struct pgem_optimize_args {
    const char *input;           /* graph file to read */
    const char *output;          /* g2o file to write (NULL: none) */
    pgem_method_t method;        /* gn or lm */
    uint32_t max_iterations;     /* 0: library default */
    int quiet;                   /* no per-iteration lines */
    int json;                    /* summary as one JSON object on stdout */
    pgem_robust_options_t robust; /* --robust and its parameters */
    const char *weights;         /* per-loop weights file (NULL: none) */
    const char *covariances;     /* per-pose covariances file (NULL: none) */
    double covariance_seconds;   /* the factor and the sparse inverse of --covariances */
    uint32_t threads;            /* factorisation workers (0: the machine's, up to 8) */
    double analysis_seconds;     /* the symbolic analysis run while loading (not in the solve) */
} pgem_optimize_args_t;

/* What the progress callback needs. */
typedef struct pgem_optimize_progress {
    FILE *out;       /* where progress lines go */
    double start;    /* clock at the start of the solve */
    int quiet;       /* print nothing */
    double shown;    /* clock of the last factorisation progress line (0: none yet) */
} pgem_optimize_progress_t;

/* A factorisation progress line once a solve has run this long, then at most this often. */
#define PGEM_PROGRESS_AFTER_SECONDS 3.0
#define PGEM_PROGRESS_EVERY_SECONDS 2.0

static void pgem_optimize_help(FILE *out, const void *context)
{
    (void)context;
    fprintf(out,
            "usage: pgem optimize IN [-o OUT.g2o] [--solver gn|lm] [--max-iterations N]\n"
            "                        [--robust em|cauchy|huber|dcs|none] [--robust-scale C]\n"
            "                        [--prune-threshold T] [--m-step-iterations N] [--restart]\n"
            "                        [--max-em-iterations N] [--gate X] [--literal]\n"
            "                        [--dormant-threshold D|off] [--distance innovation|point]\n"
            "                        [--odometry-inflation K] [--predictable-rotation R]\n"
            "                        [--frames on|off] [--weights FILE] [--covariances FILE]\n"
            "                        [--threads N] [--ordering O] [--quiet]\n"
            "                        [--json]\n"
            "\n"
            "Reads a g2o (VERTEX_SE2/EDGE_SE2, VERTEX_SE3:QUAT/EDGE_SE3:QUAT, FIX) or TORO 2D\n"
            "(VERTEX2/EDGE2) graph, optimizes it from its own initial estimate and prints one\n"
            "line per iteration (iteration, chi2, step norm, seconds) and a summary.\n"
            "\n"
            "  -o OUT.g2o          write the optimized graph (g2o)\n"
            "  --solver gn|lm      Gauss-Newton (default) or Levenberg-Marquardt\n"
            "  --max-iterations N  iteration limit (default 100; with --robust, of the final\n"
            "                      solve at weight 1)\n"
            "  --robust KERNEL     weight loop closures: em (Lee et al. EM with pruning),\n"
            "                      cauchy, huber, dcs (IRLS), none (default)\n"
            "  --robust-scale C    kernel scale: Cauchy c, Huber k, DCS phi (default 1)\n"
            "  --prune-threshold T EM: prune loops whose weight falls below T (default 0.01)\n"
            "  --m-step-iterations N  Gauss-Newton iterations per M-step (default 1)\n"
            "  --max-em-iterations N  EM: E/M iterations per pruning round (default 5;\n"
            "                      --literal: 100)\n"
            "  --gate X            EM: chi2 of the final consistency test (default: 99.9%%\n"
            "                      chi-square quantile, 16.27 in 2D, 22.46 in 3D)\n"
            "  --restart           EM: restart from the initial estimate after pruning\n"
            "  --dormant-threshold D|off  EM: a loop weighing less than D gets no place in\n"
            "                      the factor; conjugate gradients add its coupling back, so\n"
            "                      the result is the same, only faster with many false loops\n"
            "                      (default T/100; off: every loop in the factor)\n"
            "  --distance D        EM: innovation (default: after the paper's first rounds,\n"
            "                      each loop is tested against what the rest of the map\n"
            "                      predicts for it, the map's covariance included) or point\n"
            "                      (the paper: chi2 under the current estimate throughout)\n"
            "  --odometry-inflation K  innovation: the map's covariance counts K times, an\n"
            "                      allowance for optimistic odometry covariances (default 4)\n"
            "  --predictable-rotation R  innovation: a loop is tested by its innovation when\n"
            "                      the map predicts its rotation to R radians (default 0.1),\n"
            "                      else by its chi2 under the estimate\n"
            "  --frames on|off     EM: place each part of the graph that its odometry\n"
            "                      leaves without a held pose (a team's robot, each from its\n"
            "                      own origin) in the frame most of its loops to the placed\n"
            "                      parts agree on, before the first E-step (default on; a\n"
            "                      graph of one part is not touched)\n"
            "  --literal           EM exactly as published: keep the EM weights at the end\n"
            "                      (default: re-solve with accepted loops at weight 1)\n"
            "  --weights FILE      write one line per loop closure: from to weight state\n"
            "  --covariances FILE  write one line per pose: id, then the upper triangle of its\n"
            "                      marginal covariance at the result, row by row (6 numbers\n"
            "                      in 2D: x y theta; 21 in 3D: x y z rx ry rz; body frame)\n"
            "  --threads N         factorisation threads (default: the machine's, at most 8;\n"
            "                      the result is the same for any N)\n"
            "  --ordering O        auto (default: AMD, and on large graphs the fewest flops of\n"
            "                      AMD, nested dissection and METIS where built), amd, nested\n"
            "                      or metis\n"
            "  --quiet             no per-iteration or progress lines\n"
            "  --json              print the summary as one JSON object on stdout (progress goes\n"
            "                      to stderr)\n");
}

static int pgem_optimize_enum_value(const char *name, const char *value, pgem_optimize_args_t *args)
{
    if (strcmp(name, "--solver") == 0) {
        if (value != NULL && (strcmp(value, "gn") == 0 || strcmp(value, "lm") == 0)) {
            args->method = value[0] == 'g' ? PGEM_GAUSS_NEWTON : PGEM_LEVENBERG_MARQUARDT;
            return 1;
        }
        fprintf(stderr, "pgem optimize: --solver takes gn or lm\n");
        return 0;
    }
    if (strcmp(name, "--distance") == 0) {
        if (value != NULL && (strcmp(value, "innovation") == 0 || strcmp(value, "point") == 0)) {
            args->robust.distance =
                value[0] == 'i' ? PGEM_DISTANCE_INNOVATION : PGEM_DISTANCE_POINT;
            return 1;
        }
        fprintf(stderr, "pgem optimize: --distance takes innovation or point\n");
        return 0;
    }
    return pgem_cli_parse_kernel("pgem", value, &args->robust.kernel); /* --robust */
}

/* The robust options that take a number. */
static int pgem_optimize_robust_value(const char *name, const char *value,
                                      pgem_robust_options_t *robust)
{
    if (strcmp(name, "--m-step-iterations") == 0) {
        return pgem_cli_parse_u32("pgem", name, value, &robust->m_step_iterations);
    }
    if (strcmp(name, "--max-em-iterations") == 0) {
        return pgem_cli_parse_u32("pgem", name, value, &robust->max_em_iterations);
    }
    if (strcmp(name, "--frames") == 0) {
        if (value != NULL && (strcmp(value, "on") == 0 || strcmp(value, "off") == 0)) {
            robust->frames = strcmp(value, "off") == 0 ? -1 : 0;
            return 1;
        }
        fprintf(stderr, "pgem optimize: --frames takes on or off, got '%s'\n", value != NULL ? value : "");
        return 0;
    }
    if (strcmp(name, "--dormant-threshold") == 0) {
        if (value != NULL && strcmp(value, "off") == 0) {
            robust->dormant_threshold = -1.0;
            return 1;
        }
        return pgem_cli_parse_number("pgem", name, value, 0, &robust->dormant_threshold);
    }
    double *field = strcmp(name, "--robust-scale") == 0      ? &robust->scale
                    : strcmp(name, "--prune-threshold") == 0 ? &robust->prune_threshold
                    : strcmp(name, "--gate") == 0            ? &robust->gate
                    : strcmp(name, "--odometry-inflation") == 0 ? &robust->odometry_inflation
                                                                : &robust->predictable_rotation;
    return pgem_cli_parse_number("pgem", name, value, 1, field);
}

static int pgem_optimize_threads(const char *name, const char *value, uint32_t *threads)
{
    if (!pgem_cli_parse_at_least("pgem optimize", name, value, 1u, "thread", threads)) {
        return 0;
    }
    if (*threads > PGEM_MAX_THREADS) {
        fprintf(stderr, "pgem optimize: --threads takes at most %u, got %u\n", PGEM_MAX_THREADS,
                *threads);
        return 0;
    }
    return 1;
}

static int pgem_optimize_value(void *user, const char *name, const char *value)
{
    pgem_optimize_args_t *args = user;
    if (strcmp(name, "-o") == 0 || strcmp(name, "--output") == 0) {
        return pgem_cli_text_value("pgem optimize", name, value, "a file name", &args->output);
    }
    if (strcmp(name, "--weights") == 0) {
        return pgem_cli_text_value("pgem optimize", name, value, "a file name", &args->weights);
    }
    if (strcmp(name, "--covariances") == 0) {
        return pgem_cli_text_value("pgem optimize", name, value, "a file name",
                                   &args->covariances);
    }
    if (strcmp(name, "--max-iterations") == 0) {
        return pgem_cli_parse_u32("pgem", name, value, &args->max_iterations);
    }
    if (strcmp(name, "--threads") == 0) {
        return pgem_optimize_threads(name, value, &args->threads);
    }
    if (strcmp(name, "--ordering") == 0) {
        return pgem_cli_set_ordering("pgem optimize", value);
    }
    if (strcmp(name, "--solver") == 0 || strcmp(name, "--distance") == 0 ||
        strcmp(name, "--robust") == 0) {
        return pgem_optimize_enum_value(name, value, args);
    }
    return pgem_optimize_robust_value(name, value, &args->robust);
}

static int pgem_optimize_flag(void *user, const char *name)
{
    pgem_optimize_args_t *args = user;
    int *field = strcmp(name, "--restart") == 0   ? &args->robust.restart
                 : strcmp(name, "--literal") == 0 ? &args->robust.literal
                 : strcmp(name, "--quiet") == 0   ? &args->quiet
                 : strcmp(name, "--json") == 0    ? &args->json
                                                  : NULL;
    if (field != NULL) {
        *field = 1;
    }
    return field != NULL;
}

static int pgem_optimize_positional(void *user, const char *argument)
{
    return pgem_cli_one_file("pgem optimize", "input", &((pgem_optimize_args_t *)user)->input,
                             argument);
}

static int pgem_optimize_parse(int argc, char **argv, pgem_optimize_args_t *args)
{
    static const char *const valued[] = {
        "-o", "--output", "--weights", "--covariances", "--max-iterations", "--threads", "--ordering", "--solver",
        "--distance",
        "--robust", "--m-step-iterations", "--max-em-iterations", "--dormant-threshold",
        "--robust-scale", "--prune-threshold", "--gate", "--odometry-inflation",
        "--predictable-rotation", "--frames"};
    const pgem_cli_parser_t parser = {
        "pgem optimize", valued, sizeof valued / sizeof valued[0], pgem_optimize_value,
        pgem_optimize_flag, pgem_optimize_positional, pgem_optimize_help, NULL, NULL};
    memset(args, 0, sizeof *args);
    args->robust.kernel = PGEM_KERNEL_NONE; /* without --robust: plain least squares */
    const int status = pgem_cli_parse_args(&parser, args, argc, argv);
    if (status != 0) {
        return status;
    }
    if (args->input == NULL) {
        fprintf(stderr, "pgem optimize: no input file (see pgem optimize --help)\n");
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

static int pgem_progress_line(const pgem_iteration_t *iteration, void *user)
{
    pgem_optimize_progress_t *progress = user;
    progress->shown = 0.0;
    if (!progress->quiet) {
        char chi2[PGEM_CLI_NUMBER_MAX];
        fprintf(progress->out, "%5u %18s %12.4e %10.4f%s\n", iteration->iteration,
                pgem_cli_number(chi2, sizeof chi2, iteration->chi2, 6), iteration->step_norm,
                pgem_cli_now() - progress->start, iteration->accepted ? "" : "  (rejected)");
        fflush(progress->out);
    }
    return 0;
}

/* During a long factorisation: a line on stderr once the solve has run for a few seconds,
 * then every few seconds, so a large graph never leaves a silent terminal. */
static void pgem_factor_progress(const pgem_progress_t *factor, void *user)
{
    pgem_optimize_progress_t *progress = user;
    const double now = pgem_cli_now();
    if (progress->quiet || now - progress->start < PGEM_PROGRESS_AFTER_SECONDS ||
        (progress->shown > 0.0 && now - progress->shown < PGEM_PROGRESS_EVERY_SECONDS)) {
        return;
    }
    progress->shown = now;
    fprintf(stderr, "pgem: iteration %u: factorisation %3.0f%% of %.3g multiply-adds, %.1f s\n",
            factor->iteration, 100.0 * factor->done, factor->multiply_adds, now - progress->start);
    fflush(stderr);
}

static void pgem_describe_input(FILE *out, const char *path, const pgem_io_graph_t *file)
{
    size_t loops = 0;
    for (size_t k = 0; k < file->edge_count; k++) {
        loops += file->edges[k].kind == PGEM_EDGE_LOOP;
    }
    fprintf(out, "%s: %dD, %zu poses, %zu edges (%zu odometry, %zu loop closures)\n", path,
            file->dimension, file->pose_count, file->edge_count, file->edge_count - loops, loops);
    if (file->chained_poses > 0) {
        fprintf(out, "  %zu poses had no VERTEX line: initial guess composed along the edges\n",
                file->chained_poses);
    }
    if (file->unknown_lines > 0) {
        fprintf(out, "  skipped %zu lines with unknown tags (first: '%s' at line %lu)\n",
                file->unknown_lines, file->first_unknown_tag, file->first_unknown_line);
    }
    if (file->equiv_lines > 0) {
        fprintf(out, "  skipped %zu TORO EQUIV lines\n", file->equiv_lines);
    }
}

/* How pgem's block is made up, from pgem_memory_size() on the instance's resolved config: bytes
 * per pose and per edge of capacity, and the bytes that scale with the factor's budget (the
 * factor's nonzeros when the budget was sized to them, as pgem_cli_load does). */
typedef struct pgem_block_parts {
    size_t per_pose;
    size_t per_edge;
    size_t factor;
} pgem_block_parts_t;

/* Capacities change by this much when measuring: every array then grows by a multiple of the
 * arena's 16-byte alignment, so the difference has no padding in it. */
#define PGEM_CAPACITY_STEP 16u

/* Bytes one more pose (edges: 1) of capacity costs, averaged over PGEM_CAPACITY_STEP. Taken
 * below and above the current capacity and the smaller kept, so that the id map doubling (its
 * slot count is a power of two) on one side does not count. */
static size_t pgem_capacity_cost(const pgem_config_t *config, size_t size, int edges)
{
    size_t cost = 0;
    for (int side = 0; side < 2; side++) {
        pgem_config_t probe = *config;
        uint32_t *capacity = edges ? &probe.max_edges : &probe.max_poses;
        if (side == 0 && *capacity <= PGEM_CAPACITY_STEP) {
            continue; /* 0 would mean "default" */
        }
        *capacity = side == 0 ? *capacity - PGEM_CAPACITY_STEP : *capacity + PGEM_CAPACITY_STEP;
        const size_t other = pgem_memory_size(&probe);
        const size_t low = side == 0 ? other : size;
        const size_t high = side == 0 ? size : other;
        if (other == 0 || high < low) {
            continue; /* beyond the limits */
        }
        const size_t each = (high - low) / PGEM_CAPACITY_STEP;
        cost = cost == 0 || each < cost ? each : cost;
    }
    return cost;
}

static void pgem_block_parts(const pgem_t *graph, uint32_t fill_budget, pgem_block_parts_t *parts)
{
    const pgem_config_t config = *pgem_resolved_config(graph);
    const size_t size = pgem_memory_size(&config);
    parts->per_pose = pgem_capacity_cost(&config, size, 0);
    parts->per_edge = pgem_capacity_cost(&config, size, 1);
    /* A budget of 0 means "default", so there is no size without a factor: the cost of one
     * nonzero is taken between two explicit budgets (whole b x b blocks apart) and multiplied by
     * the instance's budget. A robust solve's budget covers the factor with every loop closure
     * active, which is larger than the pruned graph's factor_nonzeros. */
    const uint32_t block = (uint32_t)PGEM_TANGENT_SIZE(config.dimension);
    const uint32_t step = block * block * PGEM_CAPACITY_STEP * 256u;
    pgem_config_t probe = config;
    probe.fill_budget = block * block;
    const size_t low = pgem_memory_size(&probe);
    probe.fill_budget += step;
    const size_t high = pgem_memory_size(&probe);
    const double per_nonzero = high > low ? (double)(high - low) / (double)step : 0.0;
    parts->factor = (size_t)(per_nonzero * (double)fill_budget + 0.5);
}

/* ,"solve_seconds":..,"analysis_seconds":.. (to the microsecond). */
static void pgem_print_json_seconds(double seconds, double analysis_seconds)
{
    printf(",\"solve_seconds\":");
    pgem_json_fixed(stdout, seconds, 6);
    printf(",\"analysis_seconds\":");
    pgem_json_fixed(stdout, analysis_seconds, 6);
}

/* "initial_chi2":..,"final_chi2":..,"solve_seconds":..,"analysis_seconds":.. (chi2 to 10
 * digits, null when not finite). */
static void pgem_print_json_timing(double initial, double final, double seconds,
                                   double analysis_seconds)
{
    printf("\"initial_chi2\":");
    pgem_json_number(stdout, initial, 10);
    printf(",\"final_chi2\":");
    pgem_json_number(stdout, final, 10);
    pgem_print_json_seconds(seconds, analysis_seconds);
}

/* With --covariances: "covariances":FILE,"covariance_seconds":.., (the factor and the
 * inverse, to the microsecond). */
static void pgem_print_json_covariances(const pgem_optimize_args_t *args)
{
    if (args->covariances != NULL) {
        printf("\"covariances\":");
        pgem_json_string(stdout, args->covariances);
        printf(",\"covariance_seconds\":");
        pgem_json_fixed(stdout, args->covariance_seconds, 6);
        printf(",");
    }
}

/* "block_bytes":..,"block_bytes_per_pose":..,"block_bytes_per_edge":..,"block_bytes_factor":..}
 * and the line end: the end of both summaries. */
static void pgem_print_json_block(const pgem_memory_stats_t *stats, const pgem_block_parts_t *parts,
                                  uint32_t threads)
{
    printf("\"block_bytes\":%zu,\"block_bytes_per_pose\":%zu,\"block_bytes_per_edge\":%zu,"
           "\"block_bytes_factor\":%zu,\"threads\":%u}\n",
           stats->block_bytes, parts->per_pose, parts->per_edge, parts->factor, threads);
}

static void pgem_print_summary(FILE *out, const pgem_optimize_args_t *args, const pgem_t *graph,
                               const pgem_summary_t *summary, double seconds, int status)
{
    pgem_memory_stats_t stats;
    pgem_block_parts_t parts;
    pgem_memory_use(graph, &stats);
    pgem_block_parts(graph, stats.factor_budget, &parts);
    if (args->json) {
        printf("{\"input\":");
        pgem_json_string(stdout, args->input);
        printf(",\"method\":\"%s\",\"status\":\"%s\",\"termination\":\"%s\","
               "\"iterations\":%u,",
               pgem_method_name(args->method), pgem_error_name(status),
               pgem_termination_name(summary->termination), summary->iterations);
        pgem_print_json_timing(summary->initial_chi2, summary->final_chi2, seconds,
                               args->analysis_seconds);
        printf(",\"usable\":%s,\"estimate_changed\":%s,"
               "\"poses\":%u,\"edges\":%u,\"unknowns\":%u,\"factor_nonzeros\":%u,",
               summary->usable ? "true" : "false", summary->estimate_changed ? "true" : "false",
               pgem_pose_count(graph), pgem_edge_count(graph), summary->variables,
               stats.factor_nonzeros);
        pgem_print_json_covariances(args);
        pgem_print_json_block(&stats, &parts, args->threads);
        return;
    }
    char initial[PGEM_CLI_NUMBER_MAX];
    char final[PGEM_CLI_NUMBER_MAX];
    fprintf(out, "%s: %s after %u iterations; chi2 %s -> %s in %.4f s\n",
            pgem_method_name(args->method), pgem_termination_name(summary->termination),
            summary->iterations, pgem_cli_number(initial, sizeof initial, summary->initial_chi2, 6),
            pgem_cli_number(final, sizeof final, summary->final_chi2, 6), seconds);
    fprintf(out, "  %u unknowns, factor %u nonzeros, memory block %zu bytes%s\n",
            summary->variables, stats.factor_nonzeros, stats.block_bytes,
            summary->estimate_changed ? "" : ", estimate unchanged");
    if (status != PGEM_OK) { /* on stderr, as every error */
        fprintf(stderr, "pgem: solve failed: %s; the estimate is the one before the solve\n",
                pgem_last_error(graph));
    }
}

static int pgem_round_line(const pgem_robust_progress_t *progress, void *user)
{
    const pgem_optimize_progress_t *state = user;
    if (!state->quiet) {
        char chi2[PGEM_CLI_NUMBER_MAX];
        fprintf(state->out, "round %3u: %6u active loops, %6u pruned, chi2 %14s, largest weight change %.3g, %.3f s\n",
                progress->round, progress->active_loops, progress->pruned_loops,
                pgem_cli_number(chi2, sizeof chi2, progress->chi2, 6), progress->largest_change,
                pgem_cli_now() - state->start);
        fflush(state->out);
    }
    return 0;
}

/* Progress lines and the text summary go to stdout, or to stderr when stdout holds the JSON. */
static FILE *pgem_progress_stream(const pgem_optimize_args_t *args)
{
    return args->json ? stderr : stdout;
}

/* The warnings a robust solve's outcome calls for, on stderr (also with --json). */
static void pgem_warn_outcome(const pgem_t *graph, const pgem_robust_summary_t *summary)
{
    if (summary->non_finite > 0u) {
        pgem_edge_view_t edge;
        (void)pgem_edge_at(graph, summary->first_non_finite, &edge);
        fprintf(stderr, "pgem: warning: %u loop closures rejected before the solve: their chi2 "
                        "is not finite (the first: %llu-%llu)\n", summary->non_finite,
                (unsigned long long)edge.from, (unsigned long long)edge.to);
    }
    if (summary->outcome == PGEM_ROBUST_ALL_REJECTED) {
        fprintf(stderr, "pgem: warning: all %u loop closures were rejected: the result is the "
                        "odometry alone (are the loop detector's matches or their information "
                        "wrong?)\n", summary->loops);
    } else if (summary->outcome == PGEM_ROBUST_MOST_REJECTED) {
        fprintf(stderr, "pgem: warning: %u of %u loop closures (more than 90%%) were rejected: "
                        "check the loop detector's matches and their information\n",
                summary->rejected, summary->loops);
    }
}

/* The JSON fields of a robust solve that only some solves have: "termination" when it did not
 * converge, "parts_held" and "held_poses" (the ids that hold them) when pruning left parts of
 * the graph without a held pose. */
static void pgem_print_json_robust_extras(const pgem_t *graph, const pgem_robust_summary_t *summary,
                                          int status)
{
    if (status == PGEM_OK && summary->termination != PGEM_ROBUST_CONVERGED) {
        printf(",\"termination\":\"%s\"", pgem_robust_termination_name(summary->termination));
    }
    if (status == PGEM_OK && summary->frames_placed > 0u) {
        printf(",\"frames_placed\":%u", summary->frames_placed);
    }
    if (status != PGEM_OK || summary->parts_held == 0u) {
        return;
    }
    pgem_id_t *ids = malloc(summary->parts_held * sizeof *ids);
    const uint32_t listed = ids != NULL ? summary->parts_held : 0u;
    (void)pgem_robust_held_parts(graph, ids, listed);
    printf(",\"parts_held\":%u,\"held_poses\":[", summary->parts_held);
    for (uint32_t k = 0; k < listed; k++) {
        printf("%s%llu", k > 0u ? "," : "", (unsigned long long)ids[k]);
    }
    printf("]");
    free(ids);
}

/* The text lines of a robust solve that only some solves have: why it ended when it did not
 * converge, and the parts that pruning left without a held pose (the first ten named). */
static void pgem_print_robust_extras(FILE *out, const pgem_t *graph,
                                     const pgem_robust_summary_t *summary)
{
    if (summary->termination == PGEM_ROBUST_ROUND_LIMIT) {
        fprintf(out, "  not settled: loop closures still changed state at the round limit\n");
    } else if (summary->termination == PGEM_ROBUST_OSCILLATED) {
        fprintf(out, "  not settled: the accepted loop closures came back to a set of an earlier "
                     "pass; ended at the pass of the cycle with the lowest robust cost\n");
    } else if (summary->termination == PGEM_ROBUST_STOPPED) {
        fprintf(out, "  stopped before the loop closures settled\n");
    }
    if (summary->frames_placed > 0u) {
        fprintf(out, "  %u part%s of the graph placed in the frame %s agreeing loop closures "
                     "imply\n", summary->frames_placed, summary->frames_placed > 1u ? "s" : "",
                summary->frames_placed > 1u ? "their" : "its");
    }
    if (summary->parts_held == 0u) {
        return;
    }
    fprintf(out, "  %u part%s of the graph joined only by rejected loop closures, each held at "
                 "its own gauge: pose%s", summary->parts_held, summary->parts_held > 1u ? "s" : "",
            summary->parts_held > 1u ? "s" : "");
    pgem_id_t ids[10];
    const uint32_t listed = summary->parts_held < 10u ? summary->parts_held : 10u;
    (void)pgem_robust_held_parts(graph, ids, listed);
    for (uint32_t k = 0; k < listed; k++) {
        fprintf(out, "%s %llu", k > 0u ? "," : "", (unsigned long long)ids[k]);
    }
    if (summary->parts_held > 10u) {
        fprintf(out, " and %u more", summary->parts_held - 10u);
    }
    fprintf(out, "\n");
}

static void pgem_print_robust_summary(FILE *out, const pgem_optimize_args_t *args,
                                      const pgem_t *graph, const pgem_robust_summary_t *summary,
                                      double seconds, int status)
{
    pgem_memory_stats_t stats;
    pgem_block_parts_t parts;
    pgem_memory_use(graph, &stats);
    pgem_block_parts(graph, stats.factor_budget, &parts);
    if (args->json) {
        printf("{\"input\":");
        pgem_json_string(stdout, args->input);
        printf(",\"robust\":\"%s\",\"status\":\"%s\",\"outcome\":\"%s\",\"rounds\":%u,"
               "\"em_iterations\":%u,\"gn_iterations\":%u,\"loops\":%u,\"pruned\":%u,"
               "\"rejected\":%u,\"non_finite\":%u,\"readmitted\":%u,\"gated\":%u",
               pgem_kernel_name(args->robust.kernel), pgem_error_name(status),
               pgem_robust_outcome_name(summary->outcome), summary->rounds,
               summary->em_iterations, summary->gn_iterations, summary->loops, summary->pruned,
               summary->rejected, summary->non_finite, summary->readmitted, summary->gated);
        pgem_print_json_robust_extras(graph, summary, status);
        printf(",\"initial_chi2\":");
        pgem_json_number(stdout, summary->initial_chi2, 10);
        printf(",\"final_chi2\":");
        pgem_json_number(stdout, summary->final_chi2, 10);
        printf(",\"final_chi2_with_rejected\":");
        pgem_json_number(stdout, summary->final_chi2_all, 10);
        printf(",\"estimate_changed\":%s", summary->estimate_changed ? "true" : "false");
        pgem_print_json_seconds(seconds, args->analysis_seconds);
        printf(",\"usable\":%s,\"poses\":%u,\"edges\":%u,\"analyses\":%u,"
               "\"factor_nonzeros\":%u,",
               summary->usable ? "true" : "false", pgem_pose_count(graph),
               pgem_edge_count(graph), stats.analyses, stats.factor_nonzeros);
        pgem_print_json_covariances(args);
        pgem_print_json_block(&stats, &parts, args->threads);
    } else if (status == PGEM_OK) {
        char initial[PGEM_CLI_NUMBER_MAX];
        char final[PGEM_CLI_NUMBER_MAX];
        char all[PGEM_CLI_NUMBER_MAX];
        fprintf(out, "%s: %u rounds, %u E/M iterations, %u GN iterations; %u of %u loop closures rejected (consistency test: %u re-admitted, %u pruned); chi2 %s -> %s (%s with the rejected loops) in %.4f s\n",
                pgem_kernel_name(args->robust.kernel), summary->rounds, summary->em_iterations,
                summary->gn_iterations, summary->rejected, summary->loops, summary->readmitted,
                summary->gated, pgem_cli_number(initial, sizeof initial, summary->initial_chi2, 6),
                pgem_cli_number(final, sizeof final, summary->final_chi2, 6),
                pgem_cli_number(all, sizeof all, summary->final_chi2_all, 6), seconds);
        pgem_print_robust_extras(out, graph, summary);
    } else { /* no rejected counts or final chi2 to report: the solve left nothing behind */
        fprintf(out, "%s: failed after %u rounds, %u E/M iterations, %u GN iterations in %.4f s\n",
                pgem_kernel_name(args->robust.kernel), summary->rounds, summary->em_iterations,
                summary->gn_iterations, seconds);
    }
    if (status == PGEM_OK) {
        pgem_warn_outcome(graph, summary);
    }
    if (status != PGEM_OK) {
        fprintf(stderr, "pgem: robust solve failed: %s; the estimate is the one before the solve\n",
                pgem_last_error(graph));
    }
}

/* Runs the robust solve (one line per round) or the plain one (one line per iteration), prints
 * the summary and writes the files asked for. Returns a PGEM_EXIT_* code. */
/* The solve, then the outputs; file is the graph read (overwritten by the result's). */
static int pgem_optimize_run(pgem_optimize_args_t *args, pgem_t *graph,
                             pgem_io_graph_t *file)
{
    const int robust = args->robust.kernel != PGEM_KERNEL_NONE;
    pgem_optimize_progress_t progress = {pgem_progress_stream(args), 0.0, args->quiet, 0.0};
    pgem_robust_options_t robust_options = args->robust;
    pgem_solve_options_t solve = {0};
    pgem_robust_summary_t robust_summary;
    pgem_summary_t summary;
    solve.method = args->method;
    robust_options.on_round = pgem_round_line;
    robust_options.user = &progress;
    solve.max_iterations = args->max_iterations; /* robust: the final solve's limit */
    solve.on_progress = pgem_factor_progress;
    solve.user = &progress;
    if (!robust) {
        solve.on_iteration = pgem_progress_line;
        solve.user = &progress;
        if (!args->quiet) {
            fprintf(progress.out, "%5s %18s %12s %10s\n", "iter", "chi2", "step-norm", "seconds");
        }
    }
    pgem_write_ahead_t ahead; /* the result's edge lines, formatted during the solve */
    memset(&ahead, 0, sizeof ahead);
    if (args->output != NULL && pgem_cli_refill_edges(graph, file)) {
        pgem_write_ahead_start(&ahead, file);
    }
    progress.start = pgem_cli_now();
    int status = robust ? pgem_robust_optimize(graph, &robust_options, &solve, &robust_summary)
                        : pgem_optimize(graph, &solve, &summary);
    double seconds = pgem_cli_now() - progress.start;
    pgem_write_ahead_finish(&ahead);
    double *covariances = NULL; /* every pose's, at the result (--covariances) */
    if (status == PGEM_OK && args->covariances != NULL) {
        covariances = pgem_cli_covariances(graph, &args->covariance_seconds);
    }
    if (robust) {
        pgem_print_robust_summary(progress.out, args, graph, &robust_summary, seconds, status);
    } else {
        pgem_print_summary(progress.out, args, graph, &summary, seconds, status);
    }
    if (covariances != NULL && !args->json) {
        fprintf(progress.out, "  covariances of %u poses in %.4f s\n", pgem_pose_count(graph),
                args->covariance_seconds);
    }
    int exit_code = PGEM_EXIT_OK;
    if (status != PGEM_OK || (args->covariances != NULL && covariances == NULL)) {
        exit_code = PGEM_EXIT_FAILURE;
    } else if (args->weights != NULL && pgem_cli_write_weights(graph, args->weights) != 0) {
        exit_code = PGEM_EXIT_IO;
    } else if (covariances != NULL &&
               (exit_code = pgem_cli_write_covariances(graph, covariances, args->covariances)) !=
                   PGEM_EXIT_OK) {
        /* the message is printed */
    } else if (args->output != NULL) {
        const int ahead_usable = ahead.text != NULL && pgem_write_ahead_matches(graph, file);
        exit_code = pgem_cli_write(graph, file, args->output, ahead_usable ? ahead.text : NULL,
                                   ahead.size);
    }
    pgem_write_ahead_free(&ahead);
    free(covariances);
    return exit_code;
}

/* A file without edges is most likely not the file meant (a wrong path, an empty export,
 * another format whose tags are all unknown): an error, not an empty success. */
static void pgem_optimize_nothing(const pgem_optimize_args_t *args, const pgem_io_graph_t *file)
{
    fprintf(stderr, "pgem: %s has no edges: nothing to optimize", args->input);
    if (file->unknown_lines > 0) {
        fprintf(stderr, " (%zu lines with unknown tags, the first '%s' on line %lu: not a g2o "
                        "or TORO file?)", file->unknown_lines, file->first_unknown_tag,
                file->first_unknown_line);
    } else if (file->pose_count == 0) {
        fprintf(stderr, " (the file holds no graph lines at all)");
    }
    fprintf(stderr, "\n");
}

int pgem_cmd_optimize(int argc, char **argv)
{
    pgem_optimize_args_t args;
    int status = pgem_optimize_parse(argc, argv, &args);
    if (status != PGEM_EXIT_OK) {
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    pgem_io_graph_t file = {0};
    status = pgem_cli_read_graph("pgem", args.input, 0u, &file);
    if (status != PGEM_EXIT_OK) {
        pgem_io_graph_free(&file);
        return status;
    }
    pgem_describe_input(pgem_progress_stream(&args), args.input, &file);
    if (file.edge_count == 0) {
        pgem_optimize_nothing(&args, &file);
        pgem_io_graph_free(&file);
        return PGEM_EXIT_FAILURE;
    }
    pgem_t *graph = NULL;
    if (args.threads == 0u) {
        args.threads = pgem_thread_count_online();
        args.threads = args.threads < 8u ? args.threads : 8u;
    }
    status = pgem_cli_load(&file, args.input, args.threads, &graph, &args.analysis_seconds);
    if (status != PGEM_OK || args.output == NULL) {
        pgem_io_graph_free(&file); /* kept only to be written over with the result */
    }
    if (status != PGEM_OK) {
        pgem_destroy(graph);
        return PGEM_EXIT_FAILURE;
    }
    /* the threads are created once, here, and serve every factorisation of the solve */
    pgem_thread_pool_t *pool = NULL;
    if (args.threads > 1u) {
        const pgem_executor_t executor = pgem_thread_pool_create(args.threads, &pool) == PGEM_OK
                                             ? pgem_thread_pool_executor(pool)
                                             : pgem_thread_pool_executor(NULL);
        if (pool == NULL) {
            fprintf(stderr, "pgem: could not start %u threads; solving on one\n", args.threads);
            args.threads = 1u;
        } else {
            (void)pgem_set_executor(graph, &executor);
        }
    }
    status = pgem_optimize_run(&args, graph, &file);
    pgem_io_graph_free(&file);
    pgem_set_executor(graph, NULL);
    pgem_thread_pool_destroy(pool);
    pgem_destroy(graph);
    return status;
}
