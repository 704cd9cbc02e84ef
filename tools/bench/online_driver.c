/* pgem-online-driver: streams a graph file into the library as a robot's front-end would and
 * times every update call; one JSON line per update on stdout, the final estimate and weights
 * written as `pgem optimize -o / --weights` writes them. Built for tools/bench/bench_online.py. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "online.h"

#define ONLINE_TOOL "pgem-online-driver"
#define ONLINE_PROGRESS_SECONDS 2.0 /* between progress lines on stderr */
#define ONLINE_NONE ((double)NAN) /* a number printed as null */

/* The command line. */
typedef struct online_args {
    const char *input;            /* graph file */
    const char *output;           /* -o OUT.g2o (NULL: none) */
    const char *weights;          /* --weights FILE (NULL: none) */
    const online_mode_t *mode;    /* --mode (default full) */
    uint32_t every;               /* --every N: one update per N poses (default 1) */
    uint32_t fill_budget;         /* --fill-budget N (0: the core's default, as the bridge) */
    online_guess_t guess;         /* --guess anchored|file */
    double time_limit;            /* --time-limit S: stop streaming after S s (0: never) */
    int quiet;                    /* --quiet: no progress lines */
} online_args_t;

/* What the stream did so far. */
typedef struct online_run {
    uint32_t updates;             /* update calls made */
    uint32_t failed;              /* of them, returned an error */
    double update_seconds;        /* their wall time, summed */
    double start;                 /* clock when streaming began */
    double next_progress;         /* clock of the next progress line */
    size_t poses;                 /* poses streamed */
    size_t edges;                 /* edges streamed */
    size_t added;                 /* edges since the last update */
    size_t loops_added;           /* of them, loop closures */
    int stopped;                  /* the time limit ended the stream early */
    int status;                   /* the last update's status */
    pgem_robust_summary_t last;   /* the last update's summary */
    uint32_t factor_peak;         /* most factor nonzeros after an update */
    double settle_seconds;        /* the mode's settle solve after the stream (-1: none) */
    double chi2_before_settle;    /* chi2 of the estimate the updates left (NaN: no settle) */
} online_run_t;

static void online_usage(FILE *out)
{
    fprintf(out,
            "usage: " ONLINE_TOOL " IN [--mode full|incremental] [--every N] [--fill-budget N]\n"
            "                          [--guess anchored|file] [--time-limit S] [-o OUT.g2o]\n"
            "                          [--weights FILE] [--quiet]\n"
            "\n"
            "Feeds a g2o or TORO graph to the pgem library as a stream: pose k (its VERTEX line,\n"
            "or for a file without them a guess composed along the odometry), then every edge\n"
            "whose later pose is k, in file order; after each pose's edges one update call, timed\n"
            "alone with a monotonic clock. The memory block is sized once for the whole file.\n"
            "Prints one JSON line per update (update, pose, id, poses, edges, added, loops_added,\n"
            "seconds, status, outcome, loops, pruned, rejected, rounds, em_iterations,\n"
            "gn_iterations, initial_chi2, chi2, factor_nonzeros, analyses) and a last line with\n"
            "type summary.\n"
            "\n"
            "  --mode full         what the LCM bridge does on every solve: EM on the whole graph,\n"
            "                      warm-started from the previous estimate (default)\n"
            "  --mode incremental  pgem_update after every pose (the robust gate on new loop\n"
            "                      closures), then pgem_update_settle (EM) at the end of the\n"
            "                      stream; the JSON lines add columns_touched, relinearized,\n"
            "                      rebuilt, loops_accepted, loops_rejected, readmitted\n"
            "  --every N           one update per N poses and after the last (default 1)\n"
            "  --fill-budget N     factor nonzeros the block holds (default: the core's, as the\n"
            "                      bridge)\n"
            "  --guess anchored    a new pose joined by odometry to a solved one is placed by the\n"
            "                      measurement, as the bridge does (default); file: kept as read\n"
            "  --time-limit S      stop streaming after the first update that ends S seconds or\n"
            "                      more after the start (the summary says so)\n"
            "  -o OUT.g2o          write the final graph (g2o)\n"
            "  --weights FILE      write one line per loop closure: from to weight state\n"
            "  --quiet             no progress lines on stderr\n"
            "\n"
            "Exit codes: 0 streamed, 1 the input was rejected or the last update failed, 2 bad\n"
            "command line, 3 a file could not be read or written.\n");
}

static const online_mode_t *online_find_mode(const char *name)
{
    for (const online_mode_t *mode = online_modes; name != NULL && mode->name != NULL; mode++) {
        if (strcmp(mode->name, name) == 0) {
            return mode;
        }
    }
    return NULL;
}

/* One option with a value; returns 1 if parsed, 0 if the option is not one of these, -1 on a
 * bad value (printed). */
static int online_parse_value(online_args_t *args, const char *arg, const char *value)
{
    const int output = strcmp(arg, "-o") == 0 || strcmp(arg, "--output") == 0;
    if (output || strcmp(arg, "--weights") == 0) {
        if (value == NULL) {
            fprintf(stderr, ONLINE_TOOL ": %s needs a file name\n", arg);
            return -1;
        }
        if (output) {
            args->output = value;
        } else {
            args->weights = value;
        }
    } else if (strcmp(arg, "--mode") == 0) {
        args->mode = online_find_mode(value);
        if (args->mode == NULL) {
            fprintf(stderr, ONLINE_TOOL ": --mode takes full or incremental\n");
            return -1;
        }
    } else if (strcmp(arg, "--every") == 0) {
        return pgem_cli_parse_at_least(ONLINE_TOOL, arg, value, 1, "pose", &args->every) ? 1 : -1;
    } else if (strcmp(arg, "--fill-budget") == 0) {
        return pgem_cli_parse_u32(ONLINE_TOOL, arg, value, &args->fill_budget) ? 1 : -1;
    } else if (strcmp(arg, "--guess") == 0) {
        if (value == NULL || (strcmp(value, "anchored") != 0 && strcmp(value, "file") != 0)) {
            fprintf(stderr, ONLINE_TOOL ": --guess takes anchored or file\n");
            return -1;
        }
        args->guess = value[0] == 'f' ? ONLINE_GUESS_FILE : ONLINE_GUESS_ANCHORED;
    } else if (strcmp(arg, "--time-limit") == 0) {
        return pgem_cli_parse_number(ONLINE_TOOL, arg, value, 1, &args->time_limit) ? 1 : -1;
    } else {
        return 0;
    }
    return 1;
}

/* Returns PGEM_EXIT_OK, PGEM_EXIT_USAGE (printed) or -1 after --help. */
static int online_parse(int argc, char **argv, online_args_t *args)
{
    memset(args, 0, sizeof *args);
    args->mode = &online_modes[0];
    args->every = 1;
    for (int k = 1; k < argc; k++) {
        const char *arg = argv[k];
        int taken = online_parse_value(args, arg, k + 1 < argc ? argv[k + 1] : NULL);
        if (taken < 0) {
            return PGEM_EXIT_USAGE;
        } else if (taken > 0) {
            k++;
        } else if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            online_usage(stdout);
            return -1;
        } else if (strcmp(arg, "--quiet") == 0) {
            args->quiet = 1;
        } else if (arg[0] == '-' && arg[1] != '\0') {
            fprintf(stderr, ONLINE_TOOL ": unknown option '%s' (see --help)\n", arg);
            return PGEM_EXIT_USAGE;
        } else if (args->input == NULL) {
            args->input = arg;
        } else {
            fprintf(stderr, ONLINE_TOOL ": more than one input file ('%s')\n", arg);
            return PGEM_EXIT_USAGE;
        }
    }
    if (args->input == NULL) {
        fprintf(stderr, ONLINE_TOOL ": no input file (see --help)\n");
        return PGEM_EXIT_USAGE;
    }
    if (args->mode->update == NULL) {
        fprintf(stderr, ONLINE_TOOL ": --mode %s: %s\n", args->mode->name, args->mode->why);
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

/* ,"key":value with the tools' JSON writer: 10 significant digits, null when not finite. */
static void online_json_number(const char *key, double value)
{
    printf(",\"%s\":", key);
    pgem_json_number(stdout, value, 10);
}

/* The JSON line of the update just made after pose `pose`. */
static void online_update_line(const online_stream_t *stream, const online_state_t *state,
                               const online_run_t *run, size_t pose, double seconds)
{
    const pgem_robust_summary_t *s = &run->last;
    pgem_memory_stats_t stats;
    pgem_get_memory_stats(state->core, &stats);
    printf("{\"type\":\"update\",\"update\":%u,\"pose\":%zu,\"id\":%llu,\"poses\":%u,"
           "\"edges\":%u,\"added\":%zu,\"loops_added\":%zu,\"seconds\":%.9f,\"status\":\"%s\","
           "\"outcome\":\"%s\",\"loops\":%u,\"pruned\":%u,\"rejected\":%u,\"rounds\":%u,"
           "\"em_iterations\":%u,\"gn_iterations\":%u",
           run->updates, pose, (unsigned long long)stream->file->poses[pose].id,
           pgem_pose_count(state->core), pgem_edge_count(state->core), run->added,
           run->loops_added, seconds, pgem_error_name(run->status),
           run->status == PGEM_OK ? pgem_robust_outcome_name(s->outcome) : "failed", s->loops,
           s->pruned, s->rejected, s->rounds, s->em_iterations, s->gn_iterations);
    online_json_number("initial_chi2", s->initial_chi2);
    online_json_number("chi2", run->status == PGEM_OK ? s->final_chi2 : ONLINE_NONE);
    printf(",\"factor_nonzeros\":%u,\"analyses\":%u,\"columns_touched\":%u,\"relinearized\":%u,"
           "\"rebuilt\":%d,\"loops_accepted\":%u,\"loops_rejected\":%u,\"readmitted\":%u}\n",
           stats.factor_nonzeros, stats.analyses, state->step.columns_touched,
           state->step.relinearized, state->step.rebuilt, state->step.loops_accepted,
           state->step.loops_rejected, state->step.loops_readmitted);
}

/* The last line: what was streamed, the final update's outcome and the memory. */
static void online_summary_line(const online_args_t *args, const online_stream_t *stream,
                                const online_state_t *state, const online_run_t *run)
{
    const pgem_robust_summary_t *s = &run->last;
    pgem_memory_stats_t stats;
    pgem_get_memory_stats(state->core, &stats);
    printf("{\"type\":\"summary\",\"input\":");
    pgem_json_string(stdout, args->input);
    printf(",\"mode\":\"%s\",\"every\":%u,\"guess\":\"%s\",\"poses\":%zu,\"poses_total\":%zu,"
           "\"edges\":%zu,\"edges_total\":%zu,\"updates\":%u,\"failed_updates\":%u,"
           "\"restarts\":%u,\"stopped\":%s",
           args->mode->name, args->every, args->guess == ONLINE_GUESS_FILE ? "file" : "anchored",
           run->poses, stream->file->pose_count, run->edges, stream->file->edge_count,
           run->updates, run->failed, state->restarts, run->stopped ? "true" : "false");
    online_json_number("time_limit", args->time_limit > 0.0 ? args->time_limit : ONLINE_NONE);
    online_json_number("update_seconds", run->update_seconds);
    online_json_number("settle_seconds", run->settle_seconds >= 0.0 ? run->settle_seconds : ONLINE_NONE);
    online_json_number("chi2_before_settle", run->chi2_before_settle);
    online_json_number("wall_seconds", pgem_cli_now() - run->start);
    printf(",\"status\":\"%s\",\"outcome\":\"%s\",\"loops\":%u,\"pruned\":%u,\"rejected\":%u",
           pgem_error_name(run->status),
           run->status == PGEM_OK ? pgem_robust_outcome_name(s->outcome) : "failed", s->loops,
           s->pruned, s->rejected);
    online_json_number("final_chi2", run->status == PGEM_OK ? s->final_chi2 : ONLINE_NONE);
    online_json_number("final_chi2_with_rejected", run->status == PGEM_OK ? s->final_chi2_all : ONLINE_NONE);
    printf(",\"block_bytes\":%zu,\"fill_budget\":%u,\"factor_nonzeros_peak\":%u,\"analyses\":%u}\n",
           state->block_bytes, stats.factor_budget, run->factor_peak, stats.analyses);
}

/* On stderr every ONLINE_PROGRESS_SECONDS (unless --quiet). */
static void online_progress(const online_args_t *args, const online_stream_t *stream,
                            online_run_t *run, double seconds)
{
    double now = pgem_cli_now();
    if (args->quiet || now < run->next_progress) {
        return;
    }
    run->next_progress = now + ONLINE_PROGRESS_SECONDS;
    fprintf(stderr, ONLINE_TOOL ": pose %zu of %zu, %u updates (last %.1f ms), %.0f s\n",
            run->poses, stream->file->pose_count, run->updates, 1e3 * seconds, now - run->start);
}

/* One update after pose `pose`, when the graph has an edge; its line on stdout. */
static void online_update(const online_args_t *args, const online_stream_t *stream,
                          online_state_t *state, online_run_t *run, size_t pose)
{
    if (pgem_edge_count(state->core) == 0u) {
        return; /* nothing to solve yet: the first pose alone */
    }
    double seconds = 0.0;
    run->status = args->mode->update(state, &run->last, &seconds);
    run->updates++;
    run->failed += run->status != PGEM_OK;
    run->update_seconds += seconds;
    pgem_memory_stats_t stats;
    pgem_get_memory_stats(state->core, &stats);
    run->factor_peak = stats.factor_nonzeros > run->factor_peak ? stats.factor_nonzeros
                                                                : run->factor_peak;
    online_update_line(stream, state, run, pose, seconds);
    if (run->status != PGEM_OK && !args->quiet) {
        fprintf(stderr, ONLINE_TOOL ": update %u (pose %zu) failed: %s\n", run->updates, pose,
                pgem_last_error(state->core));
    }
    run->added = run->loops_added = 0;
    online_progress(args, stream, run, seconds);
}

/* Pose p, its edges, and the update if one is due. 0, or -1 when the core refused an item. */
static int online_step(const online_args_t *args, const online_stream_t *stream,
                       online_state_t *state, online_run_t *run, size_t p)
{
    if (online_add_pose(state, stream, p) != 0) {
        return -1;
    }
    run->poses++;
    for (size_t k = stream->first_edge[p]; k < stream->first_edge[p + 1u]; k++) {
        const pgem_io_edge_t *edge = &stream->file->edges[stream->edges[k]];
        if (online_add_edge(state, edge) != 0) {
            return -1;
        }
        run->edges++;
        run->added++;
        run->loops_added += edge->kind == PGEM_EDGE_LOOP;
    }
    if ((p + 1u) % args->every == 0u || p + 1u == stream->file->pose_count) {
        online_update(args, stream, state, run, p);
    }
    return 0;
}

/* The whole stream, then the summary line. Returns a PGEM_EXIT_* code. */
static int online_stream_all(const online_args_t *args, const online_stream_t *stream,
                             online_state_t *state)
{
    online_run_t run;
    memset(&run, 0, sizeof run);
    run.status = PGEM_OK;
    run.start = pgem_cli_now();
    run.next_progress = run.start + ONLINE_PROGRESS_SECONDS;
    for (size_t p = 0; p < stream->file->pose_count; p++) {
        const uint32_t updates = run.updates;
        if (online_step(args, stream, state, &run, p) != 0) {
            return PGEM_EXIT_FAILURE;
        }
        if (args->time_limit > 0.0 && run.updates > updates && p + 1u < stream->file->pose_count &&
            pgem_cli_now() - run.start > args->time_limit) {
            run.stopped = 1;
            if (!args->quiet) {
                fprintf(stderr, ONLINE_TOOL ": time limit of %g s reached after pose %zu of %zu\n",
                        args->time_limit, p + 1u, stream->file->pose_count);
            }
            break;
        }
    }
    run.settle_seconds = -1.0;
    run.chi2_before_settle = ONLINE_NONE;
    if (run.status == PGEM_OK && args->mode->settle != NULL) {
        run.chi2_before_settle = pgem_total_chi2(state->core);
        run.status = args->mode->settle(state, &run.last, &run.settle_seconds);
    }
    online_summary_line(args, stream, state, &run);
    fflush(stdout);
    if (run.status != PGEM_OK) {
        fprintf(stderr, ONLINE_TOOL ": the last update failed (%s); nothing written\n",
                pgem_last_error(state->core));
        return PGEM_EXIT_FAILURE;
    }
    if (args->weights != NULL && pgem_cli_write_weights(state->core, args->weights) != 0) {
        return PGEM_EXIT_IO;
    }
    return args->output != NULL ? pgem_cli_write(state->core, NULL, args->output, NULL, 0u)
                                  : PGEM_EXIT_OK;
}

/* Capacities for the whole file, sized once, as a robot sizes its block before it starts. */
static int online_open(const online_args_t *args, const pgem_io_graph_t *file,
                       online_state_t *state)
{
    pgem_config_t config;
    pgem_io_config(file, &config);
    config.fill_budget = args->fill_budget;
    if (args->mode->settle != NULL) { /* the incremental factor's room: twice the default fill */
        const uint64_t b = (uint64_t)PGEM_TANGENT_SIZE(config.dimension);
        const uint64_t fill = 2u * (uint64_t)PGEM_DEFAULT_FILL_PER_POSE * b * b * config.max_poses;
        config.online_fill = fill > (uint64_t)INT32_MAX ? (uint32_t)INT32_MAX : (uint32_t)fill;
    }
    return online_state_init(state, &config, args->guess);
}

int main(int argc, char **argv)
{
    online_args_t args;
    int status = online_parse(argc, argv, &args);
    if (status != PGEM_EXIT_OK) {
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    pgem_io_graph_t file = {0};
    online_stream_t stream = {0};
    online_state_t state = {0};
    status = pgem_cli_read_graph(ONLINE_TOOL, args.input, PGEM_CLI_NEED_POSES, &file);
    if (status == PGEM_EXIT_OK && file.edge_count == 0u) {
        fprintf(stderr, ONLINE_TOOL ": %s has no edges: nothing to stream\n", args.input);
        status = PGEM_EXIT_FAILURE;
    }
    if (status == PGEM_EXIT_OK && online_stream_build(&file, &stream) != 0) {
        fprintf(stderr, ONLINE_TOOL ": out of memory for the stream of %s\n", args.input);
        status = PGEM_EXIT_FAILURE;
    }
    if (status == PGEM_EXIT_OK) {
        status = online_open(&args, &file, &state) == 0 ? online_stream_all(&args, &stream, &state)
                                                        : PGEM_EXIT_FAILURE;
    }
    online_state_free(&state);
    online_stream_free(&stream);
    pgem_io_graph_free(&file);
    return status;
}
