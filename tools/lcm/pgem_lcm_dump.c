/* pgem-lcm-dump: subscribes to the bridge's optimized graph (pgem.graph_t) and writes the
 * latest one: its poses as g2o, its loop-closure weights as pgem optimize --weights writes
 * them, its solve statistics as JSON, and optionally the bridge's latest status, the newest
 * pose's covariance and the team's robots as JSON. Every file is written atomically (FILE.tmp,
 * then renamed). */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "lcm_tool.h"
#include "pgem_compaction_t.h"
#include "pgem_covariance_t.h"
#include "pgem_graph_t.h"
#include "pgem_status_t.h"
#include "pgem_team_t.h"
#include "utf8.h"

#define DUMP_TOOL "pgem-lcm-dump"
#define DUMP_SLICE 0.25   /* longest single wait, so a signal or deadline is seen soon */
#define DUMP_QUEUE 128    /* messages LCM may hold per subscription before dropping */
#define DUMP_COVARIANCE_WAIT 2.0 /* s a run that met its condition waits for the graph's
                                    covariance and team, which the bridge publishes after the
                                    graph */

/* The command line. Conditions are unset when negative (seconds) or 0 (counts). */
typedef struct dump_args {
    pgem_lcm_options_t lcm;
    const char *output;       /* -o OUT.g2o */
    const char *weights;      /* --weights W */
    const char *json;         /* --json J */
    const char *status;       /* --status S */
    const char *compactions;  /* --compactions C */
    const char *covariance;   /* --covariance V */
    const char *team;         /* --team T */
    uint64_t count;           /* --count N: stop after N graphs */
    uint64_t edges;           /* --edges N: stop at a graph with edges_included >= N */
    int has_edges;
    double idle;              /* --idle S: stop S seconds after the latest graph */
    double timeout;           /* --timeout S: give up after S seconds */
    int quiet;                /* --quiet: no line per graph */
    int settled;              /* --settled: stop at the first settle solve's graph */
} dump_args_t;

/* What the handlers keep: the latest messages and counts. */
typedef struct dump_state {
    const pgem_channels_t *channels;
    pgem_graph_t *graph;      /* the latest graph (a copy), NULL before the first */
    pgem_status_t *status;    /* the latest status (a copy), NULL before the first */
    uint64_t graphs;          /* graphs received (well-formed) */
    uint64_t statuses;        /* statuses received */
    int graph_new;            /* a graph arrived since the main loop last looked */
    int status_new;           /* a status arrived since the main loop last looked */
    double last_graph;        /* clock when the latest graph arrived */
    FILE *compactions;        /* --compactions: appended as compactions arrive */
    int compaction_error;     /* a write to it failed */
    pgem_covariance_t *covariance; /* the latest newest-pose covariance (a copy), or NULL */
    uint64_t covariances;     /* covariances received (well-formed) */
    int covariance_new;       /* one arrived since the main loop last looked */
    pgem_team_t *team;        /* the latest team (a copy), or NULL */
    uint64_t teams;           /* teams received (well-formed) */
    int team_new;             /* one arrived since the main loop last looked */
    int graph_held;           /* a stop condition was met: later graphs are not taken */
} dump_state_t;

static void dump_usage(FILE *out)
{
    fprintf(out,
            "usage: pgem-lcm-dump [-o OUT.g2o] [--weights W] [--json J] [--status S]\n"
            "                     [--compactions C] [--covariance V] [--team T] [--count N]\n"
            "                     [--edges N] [--idle SECONDS] [--settled] [--timeout SECONDS]\n"
            "                     [--quiet] [--url URL] [--channel-prefix P] [--graph-channel C]\n"
            "                     [--status-channel C] [--compaction-channel C]\n"
            "                     [--covariance-channel C] [--team-channel C]\n");
}

static void dump_help(FILE *out, const void *context)
{
    const pgem_lcm_options_t *lcm = context;
    dump_usage(out);
    fprintf(out,
            "\n"
            "Subscribes to the optimized graph pgem-lcm-bridge publishes after every solve\n"
            "(pgem.graph_t) and writes the latest one. At least one file is needed:\n"
            "\n"
            "  -o OUT.g2o             its poses as g2o VERTEX_SE2 / VERTEX_SE3:QUAT lines\n"
            "                         (%%.17g). graph_t carries no edges, so OUT has poses\n"
            "                         only; for the full graph send the bridge a SNAPSHOT\n"
            "                         command\n"
            "  --weights W            one 'from to weight state' line per loop closure in the\n"
            "                         graph's order, as pgem optimize --weights writes them (for\n"
            "                         pgem eval and pgem plot)\n"
            "  --json J               the graph's solve statistics, counts and per-source last\n"
            "                         sequence numbers as one JSON object\n"
            "  --status S             the bridge's latest status (pgem.status_t) as one JSON\n"
            "                         object\n"
            "  --compactions C        every compaction (pgem.compaction_t, bridge --compact) as\n"
            "                         it arrives, one line per removed pose: 'REMOVED N ID\n"
            "                         ANCHOR' and the pose in the anchor's frame (x y theta, or\n"
            "                         x y z qx qy qz qw); a gap in N is a lost message\n"
            "  --covariance V         the newest pose's marginal covariance (pgem.covariance_t)\n"
            "                         as one JSON object: its id, pose, the n x n matrix (body\n"
            "                         frame), the graph's solve_id and whether it came from a\n"
            "                         factor at the estimate; at a stop condition the one of\n"
            "                         that graph is waited for (up to 2 s)\n"
            "  --team T               the team's robots (pgem.team_t) as one JSON object: per\n"
            "                         robot (source) its poses, first pose, part, whether the\n"
            "                         part holds the anchor, and its frame (own odometry frame\n"
            "                         into the map's); at a stop condition the one of that\n"
            "                         graph is waited for (up to 2 s)\n"
            "\n"
            "When to stop and write (the first condition met ends the run, exit 0):\n"
            "  --count N              after N graphs\n"
            "  --edges N              at the first graph with edges_included >= N\n"
            "  --idle SECONDS         SECONDS after the latest graph, once one has arrived\n"
            "  --settled              at the first graph of a settle solve (the bridge solves\n"
            "                         the whole graph from the front-end's estimates once the\n"
            "                         stream is quiet); with --edges N, the first with N edges\n"
            "  --timeout SECONDS      give up: write the latest graph, if any, and exit 1\n"
            "Without --count, --edges or --idle it runs until SIGINT or SIGTERM (or --timeout),\n"
            "rewriting the files at every new graph and status, and exits 0 once it has written\n"
            "them. A signal before a stop condition is met writes the latest graph and exits 1.\n"
            "\n"
            "  --quiet                no line per graph on stderr\n");
    pgem_lcm_options_help(out, lcm);
    fprintf(out,
            "\n"
            "Files are written atomically (FILE.tmp, then renamed). A --status, --covariance\n"
            "or --team file is written when one has arrived (else a warning). Large graphs\n"
            "need a large kernel receive buffer: unless the URL sets recv_buf_size, 16 MB is\n"
            "asked for, or net.core.rmem_max when that is less. Exit codes: 0 written, 1 no\n"
            "graph (no status, covariance or team when only those are asked for) or the stop\n"
            "condition was not met, 2 bad command line, 3 a file could not be written.\n");
}

/* A file option's value; prints an error and returns 0 when it is missing. */
static int dump_parse_file(const char *arg, const char *value, const char **target)
{
    if (value == NULL || value[0] == '\0') {
        fprintf(stderr, "%s: %s needs a file name\n", DUMP_TOOL, arg);
        return 0;
    }
    *target = value;
    return 1;
}

/* A value option of the dumper; returns 1 when parsed, 0 after printing an error. */
static int dump_parse_value(void *user, const char *arg, const char *value)
{
    dump_args_t *args = user;
    if (strcmp(arg, "-o") == 0 || strcmp(arg, "--output") == 0) {
        return dump_parse_file(arg, value, &args->output);
    }
    if (strcmp(arg, "--weights") == 0) {
        return dump_parse_file(arg, value, &args->weights);
    }
    if (strcmp(arg, "--json") == 0) {
        return dump_parse_file(arg, value, &args->json);
    }
    if (strcmp(arg, "--status") == 0) {
        return dump_parse_file(arg, value, &args->status);
    }
    if (strcmp(arg, "--compactions") == 0) {
        return dump_parse_file(arg, value, &args->compactions);
    }
    if (strcmp(arg, "--covariance") == 0) {
        return dump_parse_file(arg, value, &args->covariance);
    }
    if (strcmp(arg, "--team") == 0) {
        return dump_parse_file(arg, value, &args->team);
    }
    if (strcmp(arg, "--count") == 0) {
        if (!pgem_lcm_parse_u64(DUMP_TOOL, arg, value, &args->count)) {
            return 0;
        }
        if (args->count == 0) {
            fprintf(stderr, "%s: --count needs at least 1\n", DUMP_TOOL);
            return 0;
        }
        return 1;
    }
    if (strcmp(arg, "--edges") == 0) {
        args->has_edges = 1;
        return pgem_lcm_parse_u64(DUMP_TOOL, arg, value, &args->edges);
    }
    return pgem_cli_parse_number(DUMP_TOOL, arg, value, 0,
                                 strcmp(arg, "--idle") == 0 ? &args->idle : &args->timeout);
}

static int dump_flag(void *user, const char *name)
{
    dump_args_t *args = user;
    int *flag = strcmp(name, "--quiet") == 0     ? &args->quiet
                : strcmp(name, "--settled") == 0 ? &args->settled
                                                 : NULL;
    if (flag == NULL) {
        return 0;
    }
    *flag = 1;
    return 1;
}

/* Returns PGEM_EXIT_OK, PGEM_EXIT_USAGE, or -1 after --help. */
static int dump_parse(int argc, char **argv, dump_args_t *args)
{
    static const char *const valued[] = {"-o", "--output", "--weights", "--json", "--status",
                                         "--compactions", "--covariance", "--team", "--count",
                                         "--edges",
                                         "--idle", "--timeout"};
    static const pgem_cli_parser_t parser = {
        NULL, valued, sizeof valued / sizeof valued[0], dump_parse_value, dump_flag, NULL,
        dump_help, NULL, NULL};
    memset(args, 0, sizeof *args);
    pgem_lcm_options_init(&args->lcm, DUMP_TOOL, PGEM_LCM_GRAPH_CHANNEL | PGEM_LCM_STATUS_CHANNEL |
                                                     PGEM_LCM_COMPACTION_CHANNEL |
                                                     PGEM_LCM_COVARIANCE_CHANNEL |
                                                     PGEM_LCM_TEAM_CHANNEL);
    args->idle = -1.0;
    args->timeout = -1.0;
    int status = pgem_lcm_parse_args(&args->lcm, &parser, args, argc, argv);
    if (status != 0) {
        return status;
    }
    if (args->output == NULL && args->weights == NULL && args->json == NULL &&
        args->status == NULL && args->covariance == NULL && args->team == NULL) {
        fprintf(stderr, "%s: nothing to write: give -o, --weights, --json, --status, "
                        "--covariance or --team\n", DUMP_TOOL);
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

/* Whether the run ends at a condition rather than at a signal or --timeout. */
static int dump_has_condition(const dump_args_t *args)
{
    return args->count > 0 || args->has_edges || args->idle >= 0.0 || args->settled;
}

/* Whether a graph output (-o, --weights, --json) was asked for. */
static int dump_wants_graph(const dump_args_t *args)
{
    return args->output != NULL || args->weights != NULL || args->json != NULL;
}

/* ---- Receiving -------------------------------------------------------------------------- */

/* Why a decoded graph cannot be used, or NULL when it can. */
static const char *dump_graph_problem(const pgem_graph_t *graph)
{
    if (graph->dimension != 2 && graph->dimension != 3) {
        return "dimension is neither 2 nor 3";
    }
    if (graph->pose_size != (graph->dimension == 2 ? 3 : 7)) {
        return "pose_size does not match the dimension";
    }
    if (graph->num_poses < 0 || graph->num_loops < 0 || graph->num_sources < 0) {
        return "a negative count";
    }
    return NULL;
}

static void dump_on_graph(const lcm_recv_buf_t *buffer, const char *channel,
                          const pgem_graph_t *graph, void *user)
{
    dump_state_t *state = user;
    (void)buffer;
    if (state->graph_held) {
        return;
    }
    const char *problem = dump_graph_problem(graph);
    if (problem != NULL) {
        fprintf(stderr, "%s: ignored a graph on %s: %s\n", DUMP_TOOL, channel, problem);
        return;
    }
    pgem_graph_t *copy = pgem_graph_t_copy(graph);
    if (copy == NULL) {
        fprintf(stderr, "%s: out of memory for a graph of %d poses\n", DUMP_TOOL,
                (int)graph->num_poses);
        return;
    }
    if (state->graph != NULL) {
        pgem_graph_t_destroy(state->graph);
    }
    state->graph = copy;
    state->graphs++;
    state->graph_new = 1;
    state->last_graph = pgem_cli_now();
}

static void dump_on_status(const lcm_recv_buf_t *buffer, const char *channel,
                           const pgem_status_t *status, void *user)
{
    dump_state_t *state = user;
    (void)buffer;
    (void)channel;
    pgem_status_t *copy = pgem_status_t_copy(status);
    if (copy == NULL) {
        return;
    }
    if (state->status != NULL) {
        pgem_status_t_destroy(state->status);
    }
    state->status = copy;
    state->statuses++;
    state->status_new = 1;
}

static void dump_on_compaction(const lcm_recv_buf_t *buffer, const char *channel,
                               const pgem_compaction_t *compaction, void *user)
{
    dump_state_t *state = user;
    (void)buffer;
    (void)channel;
    for (int32_t i = 0; i < compaction->num_removed && !state->compaction_error; i++) {
        fprintf(state->compactions, "REMOVED %lld %llu %llu", (long long)compaction->compaction,
                (unsigned long long)compaction->ids[i], (unsigned long long)compaction->anchors[i]);
        for (int32_t v = 0; v < compaction->pose_size; v++) {
            fprintf(state->compactions, " %.17g", compaction->relative[i][v]);
        }
        fputc('\n', state->compactions);
        state->compaction_error = ferror(state->compactions) != 0; /* any write above failed */
    }
    if (fflush(state->compactions) != 0) {
        state->compaction_error = 1;
    }
}

/* Why a decoded covariance cannot be used, or NULL when it can. */
static const char *dump_covariance_problem(const pgem_covariance_t *covariance)
{
    if (covariance->dimension != 2 && covariance->dimension != 3) {
        return "dimension is neither 2 nor 3";
    }
    if (covariance->pose_size != (covariance->dimension == 2 ? 3 : 7) ||
        covariance->size != (covariance->dimension == 2 ? 3 : 6)) {
        return "pose_size or size does not match the dimension";
    }
    return NULL;
}

static void dump_on_covariance(const lcm_recv_buf_t *buffer, const char *channel,
                               const pgem_covariance_t *covariance, void *user)
{
    dump_state_t *state = user;
    (void)buffer;
    const char *problem = dump_covariance_problem(covariance);
    if (problem != NULL) {
        fprintf(stderr, "%s: ignored a covariance on %s: %s\n", DUMP_TOOL, channel, problem);
        return;
    }
    pgem_covariance_t *copy = pgem_covariance_t_copy(covariance);
    if (copy == NULL) {
        return;
    }
    if (state->covariance != NULL) {
        pgem_covariance_t_destroy(state->covariance);
    }
    state->covariance = copy;
    state->covariances++;
    state->covariance_new = 1;
}

/* Why a decoded team cannot be used, or NULL when it can. */
static const char *dump_team_problem(const pgem_team_t *team)
{
    if (team->dimension != 2 && team->dimension != 3) {
        return "dimension is neither 2 nor 3";
    }
    if (team->pose_size != (team->dimension == 2 ? 3 : 7)) {
        return "pose_size does not match the dimension";
    }
    return team->num_robots < 0 ? "a negative count" : NULL;
}

static void dump_on_team(const lcm_recv_buf_t *buffer, const char *channel,
                         const pgem_team_t *team, void *user)
{
    dump_state_t *state = user;
    (void)buffer;
    const char *problem = dump_team_problem(team);
    if (problem != NULL) {
        fprintf(stderr, "%s: ignored a team on %s: %s\n", DUMP_TOOL, channel, problem);
        return;
    }
    pgem_team_t *copy = pgem_team_t_copy(team);
    if (copy == NULL) {
        return;
    }
    if (state->team != NULL) {
        pgem_team_t_destroy(state->team);
    }
    state->team = copy;
    state->teams++;
    state->team_new = 1;
}

/* Loops in the PRUNED state. */
static int32_t dump_pruned(const pgem_graph_t *graph)
{
    int32_t pruned = 0;
    for (int32_t k = 0; k < graph->num_loops; k++) {
        pruned += graph->loops[k].state == PGEM_LOOP_T_PRUNED;
    }
    return pruned;
}

/* "graph 12: 3500 poses, 2461 loops (100 pruned), chi2 7223.14, solve 38 ms", then the
 * solve's message: why it is not usable, or its warning */
static void dump_graph_line(const pgem_graph_t *graph)
{
    double milliseconds = (double)graph->stats.solve_time_us / 1000.0;
    char chi2[PGEM_CLI_NUMBER_MAX];
    char why[256]; /* from the network: escaped */
    pgem_utf8_escape(why, sizeof why, graph->stats.message == NULL ? "" : graph->stats.message);
    fprintf(stderr, "graph %lld: %d poses, %d loops (%d pruned), chi2 %s, solve %.*f ms%s%s\n",
            (long long)graph->stats.solve_id, (int)graph->num_poses, (int)graph->num_loops,
            (int)dump_pruned(graph), pgem_cli_number(chi2, sizeof chi2, graph->stats.chi2, 2),
            milliseconds < 10.0 ? 1 : 0, milliseconds,
            !graph->stats.usable ? ", not usable: " : why[0] != '\0' ? "; " : "", why);
}

/* ---- Writing ---------------------------------------------------------------------------- */

/* The poses as a g2o file, through the library's writer. Returns 0 or -1 (printed). */
static int dump_write_g2o(const pgem_graph_t *graph, const char *path)
{
    pgem_io_graph_t poses;
    pgem_cli_file_t file;
    memset(&poses, 0, sizeof poses);
    poses.dimension = graph->dimension;
    poses.pose_count = (size_t)graph->num_poses;
    poses.poses = calloc(poses.pose_count > 0 ? poses.pose_count : 1u, sizeof *poses.poses);
    if (poses.poses == NULL) {
        fprintf(stderr, "%s: out of memory\n", DUMP_TOOL);
        return -1;
    }
    for (size_t k = 0; k < poses.pose_count; k++) {
        poses.poses[k].id = (pgem_id_t)(uint64_t)graph->ids[k];
        memcpy(poses.poses[k].pose, graph->poses[k], (size_t)graph->pose_size * sizeof(double));
    }
    int status = pgem_cli_file_open(&file, DUMP_TOOL, path);
    if (status == 0) {
        int failed = pgem_io_write_stream(file.stream, PGEM_FORMAT_G2O, &poses) != PGEM_OK;
        status = (pgem_cli_file_commit(&file, failed) == PGEM_EXIT_OK ? 0 : -1);
    }
    free(poses.poses);
    return status;
}

/* One line per loop closure, the format of pgem optimize --weights. */
static int dump_write_weights(const pgem_graph_t *graph, const char *path)
{
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, DUMP_TOOL, path) != 0) {
        return -1;
    }
    fprintf(file.stream, "# from to weight state (one line per loop closure)\n");
    for (int32_t k = 0; k < graph->num_loops; k++) {
        const pgem_loop_t *loop = &graph->loops[k];
        fprintf(file.stream, "%llu %llu %.9g %s\n", (unsigned long long)(uint64_t)loop->from,
                (unsigned long long)(uint64_t)loop->to, loop->weight,
                loop->state == PGEM_LOOP_T_PRUNED ? "pruned" : "accepted");
    }
    return (pgem_cli_file_commit(&file, 0) == PGEM_EXIT_OK ? 0 : -1);
}

static void dump_json_stats(FILE *out, const pgem_solve_stats_t *stats)
{
    fprintf(out, "{\"solve_id\":%lld,\"trigger\":", (long long)stats->solve_id);
    pgem_json_string(out, stats->trigger != NULL ? stats->trigger : "");
    fprintf(out, ",\"usable\":%s,\"message\":", stats->usable ? "true" : "false");
    pgem_json_string(out, stats->message != NULL ? stats->message : "");
    fputs(",\"initial_chi2\":", out);
    pgem_json_number(out, stats->initial_chi2, 17);
    fputs(",\"chi2\":", out);
    pgem_json_number(out, stats->chi2, 17);
    fprintf(out, ",\"em_rounds\":%d,\"em_iterations\":%d,\"gn_iterations\":%d,"
                 "\"solve_time_us\":%lld,\"poses\":%d,\"edges\":%d,\"loops\":%d,\"pruned\":%d}",
            (int)stats->em_rounds, (int)stats->em_iterations, (int)stats->gn_iterations,
            (long long)stats->solve_time_us, (int)stats->poses, (int)stats->edges,
            (int)stats->loops, (int)stats->pruned);
}

/* The graph's statistics, counts and per-source last sequence numbers as one JSON object. */
static int dump_write_json(const dump_state_t *state, const char *path)
{
    const pgem_graph_t *graph = state->graph;
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, DUMP_TOOL, path) != 0) {
        return -1;
    }
    FILE *out = file.stream;
    fprintf(out, "{\"utime\":%lld,\"dimension\":%d,\"poses\":%d,\"loops\":%d,\"pruned\":%d,"
                 "\"edges_included\":%lld,\"graphs_received\":%llu,\"last_sequence\":{",
            (long long)graph->utime, (int)graph->dimension, (int)graph->num_poses,
            (int)graph->num_loops, (int)dump_pruned(graph), (long long)graph->edges_included,
            (unsigned long long)state->graphs);
    for (int32_t s = 0; s < graph->num_sources; s++) {
        fputs(s > 0 ? "," : "", out);
        pgem_json_string(out, graph->sources[s] != NULL ? graph->sources[s] : "");
        fprintf(out, ":%lld", (long long)graph->last_sequence[s]);
    }
    fputs("},\"stats\":", out);
    dump_json_stats(out, &graph->stats);
    fputs("}\n", out);
    return (pgem_cli_file_commit(&file, 0) == PGEM_EXIT_OK ? 0 : -1);
}

static int dump_write_status(const pgem_status_t *status, const char *path)
{
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, DUMP_TOOL, path) != 0) {
        return -1;
    }
    pgem_lcm_json_status(file.stream, status);
    fputc('\n', file.stream);
    return (pgem_cli_file_commit(&file, 0) == PGEM_EXIT_OK ? 0 : -1);
}

/* The newest pose's covariance as one JSON object. */
static int dump_write_covariance(const dump_state_t *state, const char *path)
{
    const pgem_covariance_t *covariance = state->covariance;
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, DUMP_TOOL, path) != 0) {
        return -1;
    }
    FILE *out = file.stream;
    fprintf(out, "{\"utime\":%lld,\"solve_id\":%lld,\"id\":%llu,\"dimension\":%d,\"current\":%s,"
                 "\"pose\":[",
            (long long)covariance->utime, (long long)covariance->solve_id,
            (unsigned long long)(uint64_t)covariance->id, (int)covariance->dimension,
            covariance->current ? "true" : "false");
    for (int32_t v = 0; v < covariance->pose_size; v++) {
        fputs(v > 0 ? "," : "", out);
        pgem_json_number(out, covariance->pose[v], 17);
    }
    fputs("],\"covariance\":[", out);
    for (int32_t i = 0; i < covariance->size; i++) {
        fputs(i > 0 ? ",[" : "[", out);
        for (int32_t j = 0; j < covariance->size; j++) {
            fputs(j > 0 ? "," : "", out);
            pgem_json_number(out, covariance->covariance[i][j], 17);
        }
        fputc(']', out);
    }
    fprintf(out, "],\"covariances_received\":%llu}\n", (unsigned long long)state->covariances);
    return (pgem_cli_file_commit(&file, 0) == PGEM_EXIT_OK ? 0 : -1);
}

/* The team as one JSON object: per robot its source, poses, first pose, part, anchored and
 * frame. */
static int dump_write_team(const dump_state_t *state, const char *path)
{
    const pgem_team_t *team = state->team;
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, DUMP_TOOL, path) != 0) {
        return -1;
    }
    FILE *out = file.stream;
    fprintf(out, "{\"utime\":%lld,\"solve_id\":%lld,\"dimension\":%d,\"parts\":%d,\"robots\":[",
            (long long)team->utime, (long long)team->solve_id, (int)team->dimension,
            (int)team->num_parts);
    for (int32_t r = 0; r < team->num_robots; r++) {
        fputs(r > 0 ? ",{\"source\":" : "{\"source\":", out);
        pgem_json_string(out, team->sources[r] != NULL ? team->sources[r] : "");
        fprintf(out, ",\"poses\":%d,\"first_id\":%llu,\"part\":%d,\"anchored\":%s,\"frame\":[",
                (int)team->poses[r], (unsigned long long)(uint64_t)team->first_ids[r],
                (int)team->parts[r], team->anchored[r] ? "true" : "false");
        for (int32_t v = 0; v < team->pose_size; v++) {
            fputs(v > 0 ? "," : "", out);
            pgem_json_number(out, team->frames[r][v], 17);
        }
        fputs("]}", out);
    }
    fprintf(out, "],\"teams_received\":%llu}\n", (unsigned long long)state->teams);
    return (pgem_cli_file_commit(&file, 0) == PGEM_EXIT_OK ? 0 : -1);
}

/* Writes the graph files asked for from the latest graph. Returns a PGEM_EXIT_* code. */
static int dump_write_graph_files(const dump_args_t *args, const dump_state_t *state)
{
    int failed = 0;
    if (args->output != NULL) {
        failed |= dump_write_g2o(state->graph, args->output) != 0;
    }
    if (args->weights != NULL) {
        failed |= dump_write_weights(state->graph, args->weights) != 0;
    }
    if (args->json != NULL) {
        failed |= dump_write_json(state, args->json) != 0;
    }
    return failed ? PGEM_EXIT_IO : PGEM_EXIT_OK;
}

/* ---- The run ---------------------------------------------------------------------------- */

/* How a run ended. */
typedef enum dump_end {
    DUMP_MET = 0,       /* a stop condition was met */
    DUMP_TIMEOUT = 1,   /* --timeout passed */
    DUMP_SIGNAL = 2,    /* SIGINT or SIGTERM */
    DUMP_LCM_ERROR = 3, /* receiving failed (printed) */
    DUMP_WRITE_ERROR = 4 /* a file could not be written (printed) */
} dump_end_t;

/* Whether the graph just received meets --count or --edges. */
static int dump_graph_meets(const dump_args_t *args, const dump_state_t *state)
{
    if (args->settled) { /* with --edges N: the first settled graph with N edges */
        const char *trigger = state->graph->stats.trigger;
        if (trigger == NULL || strcmp(trigger, "settle") != 0) {
            return 0;
        }
        return !args->has_edges || (state->graph->edges_included >= 0 &&
                                    (uint64_t)state->graph->edges_included >= args->edges);
    }
    return (args->count > 0 && state->graphs >= args->count) ||
           (args->has_edges && state->graph->edges_included >= 0 &&
            (uint64_t)state->graph->edges_included >= args->edges);
}

/* Handles what one message brought: the line per graph, the stop conditions and, without
 * one, rewriting the files. Returns 1 when a condition is met, 0 to go on, -1 on a write
 * failure. */
static int dump_take(const dump_args_t *args, dump_state_t *state)
{
    int free_running = !dump_has_condition(args);
    if (state->graph_new) {
        state->graph_new = 0;
        if (!args->quiet) {
            dump_graph_line(state->graph);
        }
        if (dump_graph_meets(args, state)) {
            return 1;
        }
        if (free_running && dump_wants_graph(args) &&
            dump_write_graph_files(args, state) != PGEM_EXIT_OK) {
            return -1;
        }
    }
    if (state->status_new && free_running && args->status != NULL) {
        state->status_new = 0;
        if (dump_write_status(state->status, args->status) != 0) {
            return -1;
        }
    }
    if (state->covariance_new && free_running && args->covariance != NULL) {
        state->covariance_new = 0;
        if (dump_write_covariance(state, args->covariance) != 0) {
            return -1;
        }
    }
    if (state->team_new && free_running && args->team != NULL) {
        state->team_new = 0;
        if (dump_write_team(state, args->team) != 0) {
            return -1;
        }
    }
    return 0;
}

/* Whether --covariance or --team still waits for the one of the latest graph. */
static int dump_awaits(const dump_args_t *args, const dump_state_t *state)
{
    const int64_t solve_id = state->graph->stats.solve_id;
    return (args->covariance != NULL &&
            (state->covariance == NULL || state->covariance->solve_id < solve_id)) ||
           (args->team != NULL && (state->team == NULL || state->team->solve_id < solve_id));
}

/* After a stop condition: the bridge publishes a graph's team and covariance right after the
 * graph, so with --team or --covariance the ones of the graph that met it are waited for (up
 * to DUMP_COVARIANCE_WAIT s; later graphs are not taken meanwhile). */
static void dump_await_covariance(const dump_args_t *args, lcm_t *lcm, dump_state_t *state)
{
    const double deadline = pgem_cli_now() + DUMP_COVARIANCE_WAIT;
    state->graph_held = 1;
    while (state->graph != NULL && dump_awaits(args, state) && pgem_lcm_stop_signal() == 0) {
        const double left = deadline - pgem_cli_now();
        if (left <= 0.0 || pgem_lcm_handle(DUMP_TOOL, lcm, left < DUMP_SLICE ? left : DUMP_SLICE) < 0) {
            return;
        }
    }
}

/* Receives until a condition is met, --timeout passes or a signal comes. */
static dump_end_t dump_receive(const dump_args_t *args, lcm_t *lcm, dump_state_t *state)
{
    double start = pgem_cli_now();
    for (;;) {
        double now = pgem_cli_now(), slice = DUMP_SLICE;
        if (pgem_lcm_stop_signal() != 0) {
            return DUMP_SIGNAL;
        }
        if (args->idle >= 0.0 && state->graphs > 0) {
            double left = state->last_graph + args->idle - now;
            if (left <= 0.0) {
                return DUMP_MET;
            }
            slice = left < slice ? left : slice;
        }
        if (args->timeout >= 0.0) {
            double left = start + args->timeout - now;
            if (left <= 0.0) {
                return DUMP_TIMEOUT;
            }
            slice = left < slice ? left : slice;
        }
        if (pgem_lcm_handle(DUMP_TOOL, lcm, slice) < 0) {
            return DUMP_LCM_ERROR;
        }
        int taken = dump_take(args, state);
        if (taken > 0) {
            dump_await_covariance(args, lcm, state);
            return DUMP_MET;
        }
        if (taken < 0) {
            return DUMP_WRITE_ERROR;
        }
    }
}

/* Writes every file asked for from the latest messages at the end of a run and says what
 * was written. Returns a PGEM_EXIT_* code for the files alone. */
static int dump_finish_files(const dump_args_t *args, const dump_state_t *state)
{
    int status = PGEM_EXIT_OK;
    if (dump_wants_graph(args) && state->graph != NULL) {
        status = dump_write_graph_files(args, state);
    }
    if (args->status != NULL && state->status != NULL &&
        dump_write_status(state->status, args->status) != 0) {
        status = PGEM_EXIT_IO;
    }
    if (args->status != NULL && state->status == NULL) {
        fprintf(stderr, "%s: no status arrived on %s; %s not written\n", DUMP_TOOL,
                state->channels->status, args->status);
    }
    if (args->covariance != NULL && state->covariance != NULL &&
        dump_write_covariance(state, args->covariance) != 0) {
        status = PGEM_EXIT_IO;
    }
    if (args->covariance != NULL && state->covariance == NULL) {
        fprintf(stderr, "%s: no covariance arrived on %s; %s not written\n", DUMP_TOOL,
                state->channels->covariance, args->covariance);
    } else if (args->covariance != NULL && state->graph != NULL &&
               state->covariance->solve_id != state->graph->stats.solve_id) {
        fprintf(stderr, "%s: the covariance written is that of graph %lld, not of the latest "
                        "graph %lld\n", DUMP_TOOL, (long long)state->covariance->solve_id,
                (long long)state->graph->stats.solve_id);
    }
    if (args->team != NULL && state->team != NULL && dump_write_team(state, args->team) != 0) {
        status = PGEM_EXIT_IO;
    }
    if (args->team != NULL && state->team == NULL) {
        fprintf(stderr, "%s: no team arrived on %s; %s not written\n", DUMP_TOOL,
                state->channels->team, args->team);
    } else if (args->team != NULL && state->graph != NULL &&
               state->team->solve_id != state->graph->stats.solve_id) {
        fprintf(stderr, "%s: the team written is that of graph %lld, not of the latest graph "
                        "%lld\n", DUMP_TOOL, (long long)state->team->solve_id,
                (long long)state->graph->stats.solve_id);
    }
    if (status == PGEM_EXIT_OK && state->graph != NULL) {
        printf("wrote graph %lld (%d poses, %d loops, %lld edges included); %llu graphs "
               "received\n",
               (long long)state->graph->stats.solve_id, (int)state->graph->num_poses,
               (int)state->graph->num_loops, (long long)state->graph->edges_included,
               (unsigned long long)state->graphs);
    }
    return status;
}

/* The exit code of a run that ended so, after its files were written with `files`. */
static int dump_exit_code(const dump_args_t *args, const dump_state_t *state, dump_end_t end,
                          int files)
{
    if (end == DUMP_LCM_ERROR) {
        return PGEM_EXIT_FAILURE;
    }
    if (end == DUMP_WRITE_ERROR || files != PGEM_EXIT_OK) {
        return PGEM_EXIT_IO;
    }
    /* what the run is for: the graph files, else the status, else the covariance, else the
     * team */
    const int graph = dump_wants_graph(args), status = !graph && args->status != NULL;
    const int covariance = !graph && !status && args->covariance != NULL;
    int complete = graph      ? state->graph != NULL
                   : status     ? state->status != NULL
                   : covariance ? state->covariance != NULL
                                : state->team != NULL;
    if (!complete) {
        fprintf(stderr, "%s: no %s arrived on %s%s\n", DUMP_TOOL,
                graph ? "graph" : status ? "status" : covariance ? "covariance" : "team",
                graph        ? state->channels->graph
                : status     ? state->channels->status
                : covariance ? state->channels->covariance
                             : state->channels->team,
                end == DUMP_TIMEOUT ? " before --timeout" : "");
        return PGEM_EXIT_FAILURE;
    }
    if (end == DUMP_MET || !dump_has_condition(args)) {
        return PGEM_EXIT_OK;
    }
    fprintf(stderr, "%s: %s before the stop condition was met (%llu graphs received); wrote the "
                    "latest graph\n",
            DUMP_TOOL, end == DUMP_TIMEOUT ? "timed out" : "stopped by a signal",
            (unsigned long long)state->graphs);
    return PGEM_EXIT_FAILURE;
}

/* Subscribes, receives and writes. Returns a PGEM_EXIT_* code. */
static int dump_run(const dump_args_t *args, const pgem_channels_t *channels, lcm_t *lcm)
{
    dump_state_t state;
    memset(&state, 0, sizeof state);
    state.channels = channels;
    pgem_graph_t_subscription_t *graphs =
        pgem_graph_t_subscribe(lcm, channels->graph, dump_on_graph, &state);
    pgem_status_t_subscription_t *statuses =
        args->status != NULL
            ? pgem_status_t_subscribe(lcm, channels->status, dump_on_status, &state)
            : NULL;
    pgem_covariance_t_subscription_t *covariances =
        args->covariance != NULL
            ? pgem_covariance_t_subscribe(lcm, channels->covariance, dump_on_covariance, &state)
            : NULL;
    pgem_team_t_subscription_t *teams =
        args->team != NULL ? pgem_team_t_subscribe(lcm, channels->team, dump_on_team, &state)
                           : NULL;
    pgem_compaction_t_subscription_t *compactions = NULL;
    if (args->compactions != NULL) {
        state.compactions = fopen(args->compactions, "w");
        if (state.compactions == NULL) {
            fprintf(stderr, "%s: cannot write %s\n", DUMP_TOOL, args->compactions);
            pgem_graph_t_unsubscribe(lcm, graphs);
            if (statuses != NULL) {
                pgem_status_t_unsubscribe(lcm, statuses);
            }
            if (covariances != NULL) {
                pgem_covariance_t_unsubscribe(lcm, covariances);
            }
            if (teams != NULL) {
                pgem_team_t_unsubscribe(lcm, teams);
            }
            return PGEM_EXIT_IO;
        }
        compactions = pgem_compaction_t_subscribe(lcm, channels->compaction, dump_on_compaction,
                                                  &state);
        if (compactions != NULL) {
            pgem_compaction_t_subscription_set_queue_capacity(compactions, DUMP_QUEUE);
        }
    }
    if (graphs == NULL || (args->status != NULL && statuses == NULL) ||
        (args->compactions != NULL && compactions == NULL) ||
        (args->covariance != NULL && covariances == NULL) ||
        (args->team != NULL && teams == NULL)) {
        if (state.compactions != NULL) {
            fclose(state.compactions);
        }
        fprintf(stderr, "%s: cannot subscribe to %s\n", DUMP_TOOL,
                graphs == NULL ? channels->graph : channels->status);
        return PGEM_EXIT_FAILURE;
    }
    pgem_graph_t_subscription_set_queue_capacity(graphs, DUMP_QUEUE);
    if (statuses != NULL) {
        pgem_status_t_subscription_set_queue_capacity(statuses, DUMP_QUEUE);
    }
    if (covariances != NULL) {
        pgem_covariance_t_subscription_set_queue_capacity(covariances, DUMP_QUEUE);
    }
    if (teams != NULL) {
        pgem_team_t_subscription_set_queue_capacity(teams, DUMP_QUEUE);
    }
    dump_end_t end = dump_receive(args, lcm, &state);
    int files = end == DUMP_LCM_ERROR || end == DUMP_WRITE_ERROR
                    ? PGEM_EXIT_OK
                    : dump_finish_files(args, &state);
    int status = dump_exit_code(args, &state, end, files);
    if (state.compactions != NULL) {
        if (fclose(state.compactions) != 0 || state.compaction_error) {
            fprintf(stderr, "%s: could not write %s\n", DUMP_TOOL, args->compactions);
            status = PGEM_EXIT_IO;
        }
        pgem_compaction_t_unsubscribe(lcm, compactions);
    }
    pgem_graph_t_unsubscribe(lcm, graphs);
    if (statuses != NULL) {
        pgem_status_t_unsubscribe(lcm, statuses);
    }
    if (covariances != NULL) {
        pgem_covariance_t_unsubscribe(lcm, covariances);
    }
    if (state.covariance != NULL) {
        pgem_covariance_t_destroy(state.covariance);
    }
    if (teams != NULL) {
        pgem_team_t_unsubscribe(lcm, teams);
    }
    if (state.team != NULL) {
        pgem_team_t_destroy(state.team);
    }
    if (state.graph != NULL) {
        pgem_graph_t_destroy(state.graph);
    }
    if (state.status != NULL) {
        pgem_status_t_destroy(state.status);
    }
    return status;
}

int main(int argc, char **argv)
{
    dump_args_t args;
    pgem_channels_t channels;
    int status = dump_parse(argc, argv, &args);
    if (status == PGEM_EXIT_OK && pgem_lcm_channels(&args.lcm, 2, &channels) != 0) {
        status = PGEM_EXIT_USAGE;
    }
    if (status != PGEM_EXIT_OK) {
        if (status == PGEM_EXIT_USAGE) {
            dump_usage(stderr);
        }
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    if (pgem_lcm_catch_signals(DUMP_TOOL) != 0) {
        return PGEM_EXIT_FAILURE;
    }
    lcm_t *lcm = pgem_lcm_open(DUMP_TOOL, args.lcm.url, PGEM_LCM_RECEIVE_BUFFER);
    if (lcm == NULL) {
        return PGEM_EXIT_FAILURE;
    }
    status = dump_run(&args, &channels, lcm);
    lcm_destroy(lcm);
    return status;
}
