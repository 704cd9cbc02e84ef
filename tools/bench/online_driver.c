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
    uint32_t live_em;             /* --live-em N: a whole-graph pass every N poses (0: none) */
    uint32_t checkpoints;         /* --checkpoints K: the live estimate written K times (0: never) */
    const char *checkpoint_dir;   /* --checkpoint-dir DIR */
    int no_settle;                /* --no-settle: the stream's end is not followed by a settle */
    int no_pending;               /* --no-pending: with --live-em, the gate as without passes */
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
    uint32_t passes;              /* --live-em: passes solved */
    uint32_t passes_failed;       /* of them, whose solve failed (not adopted) */
    uint32_t adopted;             /* passes taken into the graph */
    double pass_seconds;          /* the passes' copies and solves, summed (not update time) */
    double pass_max;              /* the longest of them */
    double adopt_seconds;         /* the pgem_update_adopt calls, summed */
    uint32_t checkpoint;          /* --checkpoints: checkpoints written */
} online_run_t;

static void online_usage(FILE *out)
{
    fprintf(out,
            "usage: " ONLINE_TOOL " IN [--mode full|incremental] [--every N] [--fill-budget N]\n"
            "                          [--guess anchored|file] [--time-limit S] [-o OUT.g2o]\n"
            "                          [--weights FILE] [--live-em N [--no-pending]] [--no-settle]\n"
            "                          [--checkpoints K --checkpoint-dir DIR] [--quiet]\n"
            "\n"
            "Feeds a g2o or TORO graph to the pgem library as a stream: pose k (its VERTEX line,\n"
            "or for a file without them a guess composed along the odometry), then every edge\n"
            "whose later pose is k, in file order; after each pose's edges one update call, timed\n"
            "alone with a monotonic clock. The memory block is sized once for the whole file.\n"
            "Prints one JSON line per update (update, pose, id, poses, edges, added, loops_added,\n"
            "seconds, status, outcome, loops, pruned, rejected, rounds, em_iterations,\n"
            "gn_iterations, initial_chi2, chi2, factor_nonzeros, analyses), lines of type pass,\n"
            "adopt and checkpoint for the options below, and a last line with type summary.\n"
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
            "  --live-em N         incremental mode: a whole-graph EM pass every N poses, as a host\n"
            "                      runs one on another thread while the updates go on. At every\n"
            "                      N-th pose the pass started at the previous such pose, if any,\n"
            "                      is adopted (pgem_update_adopt) before that pose's update; after\n"
            "                      the update a new pass starts: a second instance gets a copy of\n"
            "                      the graph received so far (pgem_copy), its poses set to the\n"
            "                      stream's guesses (what batch EM on that graph starts from),\n"
            "                      every loop back in, then EM. It is solved here at once but\n"
            "                      adopted only at the next pass point: a pass that runs beside\n"
            "                      the updates and takes up to N poses' time. Its time is not\n"
            "                      update time: a JSON line of type pass gives it, one of type\n"
            "                      adopt each adoption. A pass costs about a batch EM of the graph\n"
            "                      so far, which must fit in N poses' time at the stream's rate;\n"
            "                      the shorter N, the sooner the pass's verdicts reach the map.\n"
            "                      bench_live.py uses 10: 1 s of a 10 Hz stream, beside 0.07-0.75 s\n"
            "                      for batch EM of KITTI to City10000 + 100 false loops here, about\n"
            "                      the LCM bridge's schedule (a pass once the last one's time has\n"
            "                      passed: at most half a core).\n"
            "                      As the LCM bridge with its passes, the updates then hold back a\n"
            "                      loop closure that passes the gate only because the map is\n"
            "                      uncertain, for a pass to judge (pgem_update_options_t.pending)\n"
            "  --no-pending        with --live-em: the gate lets such loops in, as without passes\n"
            "  --no-settle         incremental mode: no settle solve at the end of the stream, so\n"
            "                      the summary, -o and --weights are the live map\n"
            "  --checkpoints K     write the live estimate at every 1/K of the stream's poses\n"
            "                      (after the update, if one is due there, the first time the\n"
            "                      stream has ceil(i P / K) of its P poses) and at the end, before\n"
            "                      any settle: DIR/checkpoint_II.g2o (the graph received so far,\n"
            "                      as -o writes it) and DIR/checkpoint_II.weights (its loop\n"
            "                      verdicts, as --weights), II = 01 ... K, then a JSON line of type\n"
            "                      checkpoint (checkpoint, of, poses, edges, end, graph, weights);\n"
            "                      the end of a stream stopped early is checkpoint K\n"
            "  --checkpoint-dir DIR  an existing folder for them (needed with --checkpoints)\n"
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
    } else if (strcmp(arg, "--live-em") == 0) {
        return pgem_cli_parse_at_least(ONLINE_TOOL, arg, value, 1, "pose", &args->live_em) ? 1 : -1;
    } else if (strcmp(arg, "--checkpoints") == 0) {
        return pgem_cli_parse_at_least(ONLINE_TOOL, arg, value, 1, "checkpoint", &args->checkpoints)
                   ? 1 : -1;
    } else if (strcmp(arg, "--checkpoint-dir") == 0) {
        if (value == NULL) {
            fprintf(stderr, ONLINE_TOOL ": %s needs a folder name\n", arg);
            return -1;
        }
        args->checkpoint_dir = value;
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
        } else if (strcmp(arg, "--no-settle") == 0) {
            args->no_settle = 1;
        } else if (strcmp(arg, "--no-pending") == 0) {
            args->no_pending = 1;
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
    if ((args->live_em > 0u || args->no_settle) && args->mode->settle == NULL) {
        fprintf(stderr, ONLINE_TOOL ": %s needs --mode incremental\n",
                args->live_em > 0u ? "--live-em" : "--no-settle");
        return PGEM_EXIT_USAGE;
    }
    if (args->no_pending && args->live_em == 0u) {
        fprintf(stderr, ONLINE_TOOL ": --no-pending goes with --live-em\n");
        return PGEM_EXIT_USAGE;
    }
    if ((args->checkpoints > 0u) != (args->checkpoint_dir != NULL)) {
        fprintf(stderr, ONLINE_TOOL ": --checkpoints and --checkpoint-dir go together\n");
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
    pgem_memory_use(state->core, &stats);
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
    pgem_memory_use(state->core, &stats);
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
    printf(",\"block_bytes\":%zu,\"fill_budget\":%u,\"factor_nonzeros_peak\":%u,\"analyses\":%u",
           state->block_bytes, stats.factor_budget, run->factor_peak, stats.analyses);
    printf(",\"settle\":\"%s\",\"live_em\":%u,\"pending\":%s,\"passes\":%u,\"passes_failed\":%u,"
           "\"adopted\":%u",
           args->mode->settle == NULL ? "none" : args->no_settle ? "skipped" : "done", args->live_em,
           state->pending ? "true" : "false", run->passes, run->passes_failed, run->adopted);
    online_json_number("pass_seconds", run->pass_seconds);
    online_json_number("pass_seconds_max", run->pass_max);
    online_json_number("adopt_seconds", run->adopt_seconds);
    uint32_t loops = 0, pruned = 0;
    for (uint32_t k = 0; k < pgem_edge_count(state->core); k++) {
        pgem_edge_view_t edge;
        if (pgem_edge_at(state->core, k, &edge) == PGEM_OK && edge.kind == PGEM_EDGE_LOOP) {
            loops++;
            pruned += !edge.active;
        }
    }
    printf(",\"pass_block_bytes\":%zu,\"checkpoints\":%u,\"graph_loops\":%u,\"graph_pruned\":%u}\n",
           state->pass_bytes, run->checkpoint, loops, pruned);
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
    pgem_memory_use(state->core, &stats);
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

/* At a pass point, before that pose's update: the pass waiting since the previous point is
 * taken into the graph (the next update rebuilds at its estimate); one line of type adopt. */
static void online_adopt(const online_args_t *args, const online_stream_t *stream,
                         online_state_t *state, online_run_t *run, size_t pose)
{
    if (!state->pass_pending) {
        return;
    }
    pgem_adopt_summary_t adopt;
    memset(&adopt, 0, sizeof adopt);
    double seconds = 0.0;
    const uint32_t pass_poses = pgem_pose_count(state->pass);
    const int status = online_pass_adopt(state, &adopt, &seconds);
    run->adopted += status == PGEM_OK;
    run->adopt_seconds += seconds;
    printf("{\"type\":\"adopt\",\"pose\":%zu,\"id\":%llu,\"poses\":%u,\"edges\":%u,"
           "\"pass_poses\":%u,\"seconds\":%.9f,\"status\":\"%s\",\"poses_adopted\":%u,"
           "\"poses_carried\":%u,\"edges_adopted\":%u,\"loops_changed\":%u}\n",
           pose, (unsigned long long)stream->file->poses[pose].id, pgem_pose_count(state->core),
           pgem_edge_count(state->core), pass_poses, seconds, pgem_error_name(status),
           adopt.poses_adopted, adopt.poses_carried, adopt.edges_adopted, adopt.loops_changed);
    if (status != PGEM_OK && !args->quiet) {
        fprintf(stderr, ONLINE_TOOL ": adopting the pass at pose %zu failed: %s\n", pose,
                pgem_last_error(state->core));
    }
}

/* After the update at a pass point: a new pass on a copy of the graph, solved now, adopted at
 * the next point; one line of type pass. Its time is the host's other thread's, not the
 * updates'. */
static void online_pass(const online_args_t *args, const online_stream_t *stream,
                        online_state_t *state, online_run_t *run, size_t pose)
{
    pgem_robust_summary_t s;
    double seconds = 0.0;
    const int status = online_pass_run(state, &s, &seconds);
    run->passes++;
    run->passes_failed += status != PGEM_OK;
    run->pass_seconds += seconds;
    run->pass_max = seconds > run->pass_max ? seconds : run->pass_max;
    printf("{\"type\":\"pass\",\"pass\":%u,\"pose\":%zu,\"id\":%llu,\"poses\":%u,\"edges\":%u,"
           "\"seconds\":%.9f,\"status\":\"%s\",\"outcome\":\"%s\",\"loops\":%u,\"pruned\":%u,"
           "\"rounds\":%u,\"gn_iterations\":%u",
           run->passes, pose, (unsigned long long)stream->file->poses[pose].id,
           pgem_pose_count(state->core), pgem_edge_count(state->core), seconds,
           pgem_error_name(status), status == PGEM_OK ? pgem_robust_outcome_name(s.outcome) : "failed",
           s.loops, s.pruned, s.rounds, s.gn_iterations);
    online_json_number("final_chi2", status == PGEM_OK ? s.final_chi2 : ONLINE_NONE);
    printf("}\n");
    if (status != PGEM_OK && !args->quiet) {
        fprintf(stderr, ONLINE_TOOL ": the pass at pose %zu failed: %s\n", pose,
                state->pass != NULL ? pgem_last_error(state->pass) : "the pass's block");
    }
}

/* Pose p, its edges, and the update if one is due (with --live-em, at a pass point: the
 * waiting pass adopted before the update, a new one started after). 0, or -1 when the core
 * refused an item. */
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
    const int pass_point = args->live_em > 0u && (p + 1u) % args->live_em == 0u;
    if (pass_point) {
        online_adopt(args, stream, state, run, p);
    }
    if ((p + 1u) % args->every == 0u || p + 1u == stream->file->pose_count) {
        online_update(args, stream, state, run, p);
    }
    if (pass_point && p + 1u < stream->file->pose_count) { /* at the last pose none would adopt it */
        online_pass(args, stream, state, run, p);
    }
    return 0;
}

/* Writes the live estimate as checkpoint `index` of K: the graph received so far and its loop
 * verdicts, then one line of type checkpoint. A PGEM_EXIT_* code. */
static int online_checkpoint(const online_args_t *args, const online_state_t *state,
                             online_run_t *run, uint32_t index, int end)
{
    char graph[4096], weights[4096];
    const int a = snprintf(graph, sizeof graph, "%s/checkpoint_%02u.g2o", args->checkpoint_dir, index);
    const int b = snprintf(weights, sizeof weights, "%s/checkpoint_%02u.weights", args->checkpoint_dir,
                           index);
    if (a < 0 || b < 0 || (size_t)a >= sizeof graph || (size_t)b >= sizeof weights) {
        fprintf(stderr, ONLINE_TOOL ": --checkpoint-dir is too long\n");
        return PGEM_EXIT_IO;
    }
    int status = pgem_cli_write(state->core, NULL, graph, NULL, 0u);
    if (status == PGEM_EXIT_OK && pgem_cli_write_weights(state->core, weights) != 0) {
        status = PGEM_EXIT_IO;
    }
    if (status != PGEM_EXIT_OK) {
        return status;
    }
    run->checkpoint++;
    printf("{\"type\":\"checkpoint\",\"checkpoint\":%u,\"of\":%u,\"poses\":%zu,\"edges\":%zu,"
           "\"end\":%s,\"graph\":",
           index, args->checkpoints, run->poses, run->edges, end ? "true" : "false");
    pgem_json_string(stdout, graph);
    printf(",\"weights\":");
    pgem_json_string(stdout, weights);
    printf("}\n");
    fflush(stdout);
    return PGEM_EXIT_OK;
}

/* The checkpoints before the last that the stream has reached (the first time it holds
 * ceil(i P / K) of its P poses): a PGEM_EXIT_* code. */
static int online_checkpoints_due(const online_args_t *args, const online_stream_t *stream,
                                  const online_state_t *state, online_run_t *run)
{
    const uint64_t total = stream->file->pose_count, k = args->checkpoints;
    for (uint32_t i = run->checkpoint + 1u; i < args->checkpoints; i++) {
        if ((uint64_t)run->poses < ((uint64_t)i * total + k - 1u) / k) {
            break;
        }
        const int status = online_checkpoint(args, state, run, i, 0);
        if (status != PGEM_EXIT_OK) {
            return status;
        }
    }
    return PGEM_EXIT_OK;
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
        int written = args->checkpoints > 0u ? online_checkpoints_due(args, stream, state, &run)
                                             : PGEM_EXIT_OK;
        if (written != PGEM_EXIT_OK) {
            return written;
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
    if (args->checkpoints > 0u) { /* the end of the stream, before any settle */
        const int written = online_checkpoint(args, state, &run, args->checkpoints, 1);
        if (written != PGEM_EXIT_OK) {
            return written;
        }
    }
    run.settle_seconds = -1.0;
    run.chi2_before_settle = ONLINE_NONE;
    if (run.status == PGEM_OK && args->mode->settle != NULL && !args->no_settle) {
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
    if (online_state_init(state, &config, args->guess) != 0) {
        return -1;
    }
    state->pending = args->live_em > 0u && !args->no_pending; /* as the bridge with its passes */
    return args->live_em > 0u ? online_pass_init(state) : 0;
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
