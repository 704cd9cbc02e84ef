/* pgem-lcm-send: publishes a graph file over LCM the way a front-end would, pose by pose with
 * the edges that each new pose completes, for pgem-lcm-bridge. Options shuffle the order,
 * repeat messages, pace them, send a slice of the edges, wait for the bridge's status, measure
 * how long each loop closure takes to appear in a published graph and ask the bridge to
 * solve. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "lcm_tool.h"
#include "pgem_command_t.h"
#include "pgem_edge2_t.h"
#include "pgem_edge3_t.h"
#include "pgem_graph_t.h"
#include "pgem_pose2_t.h"
#include "pgem_pose3_t.h"
#include "pgem_status_t.h"

#define SEND_TOOL "pgem-lcm-send"
#define SEND_SOURCE_DEFAULT "pgem-lcm-send"
#define SEND_SOURCE_MAX 63          /* bytes of a source name (edge2_t.lcm) */
#define SEND_PROGRESS_SECONDS 2.0   /* between progress lines */
#define SEND_WAIT_SLICE 0.25        /* longest single wait, so a signal is seen soon */
#define SEND_STATUS_QUEUE 1000      /* statuses LCM may hold for us before dropping */
#define SEND_GRAPH_QUEUE 64         /* graphs LCM may hold for us (about 700 KB each at 10000
                                       poses) before dropping */
#define SEND_LATENCY_WAIT 10.0      /* --latency without --wait: seconds to wait for graphs */
#define SEND_POLL_STEP 0.001        /* LCM waits in whole milliseconds: the last one is slept */

/* The command line. */
typedef struct send_args {
    pgem_lcm_options_t lcm;
    const char *input;       /* graph file */
    const char *source;      /* --source NAME */
    double rate;             /* --rate HZ: edge messages per second; 0: as fast as possible */
    int shuffle;             /* --shuffle given */
    uint64_t seed;           /* its seed */
    uint64_t repeat;         /* --repeat N: copies of every message, at least 1 */
    uint64_t first;          /* --first K: first edge sequence sent */
    uint64_t count;          /* --count N: edges sent from K on (UINT64_MAX: to the end) */
    int select;              /* --first or --count given: only the poses the edges need */
    double wait;             /* --wait SECONDS; negative: do not wait */
    const char *latency;     /* --latency FILE.csv; NULL: not measured */
    int optimize;            /* --optimize: ask the bridge to solve at the end */
    uint64_t pause_every;    /* --pause-every N: silent after every N edge messages; 0 never */
    double pause_seconds;    /* --pause SECONDS: for how long (default 1) */
    int quiet;               /* --quiet: no progress lines */
    int foreign_ids;         /* --foreign-ids: edges may name other senders' poses */
} send_args_t;

/* One message of the plan: a pose or an edge of the file graph, by index. */
typedef struct send_item {
    size_t index;
    int edge;
} send_item_t;

/* What is sent, in order (copies included). */
typedef struct send_plan {
    send_item_t *items;
    size_t count;             /* messages, copies included */
    size_t poses;             /* distinct poses sent */
    size_t edges;             /* distinct edges sent */
    size_t edge_messages;     /* edge messages, copies included */
    unsigned char *fixed;     /* per pose of the file: named by a FIX line */
} send_plan_t;

/* --latency: one file edge, when it was first sent and first seen in a published graph. */
typedef struct send_mark {
    double sent;              /* clock (pgem_cli_now) of its first send; negative: not sent or
                                 not a loop closure */
    double seen;              /* clock when the first graph including it arrived; negative:
                                 none yet */
    int64_t solve_id;         /* that graph's solve */
    double since_pause;       /* seconds from the end of the last --pause-every pause to its
                                 send; negative: sent before any */
} send_mark_t;

/* --latency: the marks of every file edge, indexed by sequence (= file index). */
typedef struct send_latency {
    send_mark_t *marks;       /* edge_count entries; NULL: no --latency */
    size_t edges;             /* entries */
    const char *source;       /* this run's source name: loops of other sources are skipped */
    size_t sent;              /* loop closures sent */
    size_t seen;              /* of those, seen in a graph */
    uint64_t graphs;          /* graphs received */
} send_latency_t;

/* What publishing needs. */
typedef struct send_context {
    lcm_t *lcm;
    const pgem_io_graph_t *graph;
    const send_plan_t *plan;
    pgem_channels_t channels;
    char source[SEND_SOURCE_MAX + 1];
    int receiving;            /* subscribed (--wait, --latency): dispatch while sending */
    send_latency_t latency;
    double pause_end;         /* clock when the last --pause-every pause ended; negative none */
} send_context_t;

/* --wait: the bridge's latest status and whether it shows every edge taken. */
typedef struct send_wait {
    pgem_status_t *latest;    /* a copy of the latest status (NULL: none yet) */
    uint64_t statuses;        /* statuses received */
    int armed;                /* all sent: statuses from now on are judged */
    int satisfied;            /* a judged status showed every edge taken */
    int64_t edges;            /* accepted_edges needed */
} send_wait_t;

static void send_usage(FILE *out)
{
    fprintf(out,
            "usage: pgem-lcm-send FILE [--rate HZ] [--source NAME] [--shuffle SEED] [--repeat N]\n"
            "                     [--first K] [--count N] [--wait SECONDS] [--latency FILE.csv]\n"
            "                     [--pause-every N [--pause SECONDS]] [--optimize] [--quiet]\n"
            "                     [--foreign-ids]\n"
            "                     [--url URL] [--channel-prefix P]\n"
            "                     [--pose-channel C] [--edge-channel C] [--graph-channel C]\n"
            "                     [--status-channel C] [--command-channel C]\n");
}

static void send_help(FILE *out, const void *context)
{
    const pgem_lcm_options_t *lcm = context;
    send_usage(out);
    fprintf(out,
            "\n"
            "Publishes a g2o or TORO graph file over LCM as a front-end would, for\n"
            "pgem-lcm-bridge: the poses (pgem.pose2_t or pose3_t, by the file's dimension)\n"
            "in file order, each followed at once by the edges (pgem.edge2_t or edge3_t)\n"
            "whose later-sent pose it is, so odometry k-1 -> k and the loop closures ending\n"
            "at k follow pose k; edges ready at the same pose keep file order. An edge's\n"
            "sequence is its index in the file (0-based), its kind the reader's (the first\n"
            "edge between ids i and i+1 odometry, else loop); poses named by FIX lines are\n"
            "sent fixed; utime is the wall clock when sent.\n"
            "\n"
            "  --rate HZ              edges per second, paced to absolute deadlines (poses go\n"
            "                         with their edges); default 0: as fast as possible,\n"
            "                         which can overrun a receiver's UDP buffer\n"
            "  --source NAME          the front-end's name in every message (default\n"
            "                         pgem-lcm-send; 1 to 63 bytes)\n"
            "  --shuffle SEED         every message (poses and edges) in a random order, the same\n"
            "                         for the same seed: out-of-order arrival\n"
            "  --repeat N             every message N times in a row (default 1): replays, which\n"
            "                         the bridge must recognise; with --shuffle the copies are\n"
            "                         shuffled too\n"
            "  --first K              only the edges with sequence K, K+1, ... and the poses they\n"
            "                         need (default 0)\n"
            "  --count N              only N edges from --first on (default: all)\n"
            "  --wait SECONDS         then wait until a status (pgem.status_t) received after the\n"
            "                         last message shows accepted_edges >= the edges sent,\n"
            "                         pending 0 and queued 0, and print it; exit 1 when none\n"
            "                         does within SECONDS (the counters are the bridge's totals\n"
            "                         since it started)\n"
            "  --latency FILE.csv     measure every loop closure sent: from its first publish\n"
            "                         to the arrival of the first graph (pgem.graph_t) whose\n"
            "                         loops include it (same source name and sequence); after\n"
            "                         the last message keep receiving until every one was seen\n"
            "                         or --wait SECONDS (default 10) pass. FILE.csv gets\n"
            "                         'sequence,from,to,latency_ms,solve_id,since_pause_s', one\n"
            "                         line per loop closure sent in sequence order (latency and\n"
            "                         solve empty when never seen; since_pause_s the seconds\n"
            "                         from the end of the last --pause-every pause to its send,\n"
            "                         empty before the first); stdout a line with the median,\n"
            "                         p90, p99 and maximum (nearest rank). Monotonic clock; a\n"
            "                         loop closure the bridge already had from an earlier run\n"
            "                         counts from this run's send\n"
            "  --pause-every N        stay silent after every N edge messages (before the next\n"
            "                         pose), receiving meanwhile, as a robot that stands still\n"
            "                         and drives on; the pacing resumes after it\n"
            "  --pause SECONDS        how long each of those pauses lasts (default 1)\n"
            "  --optimize             at the end (with --wait, once the status shows every\n"
            "                         edge taken) ask the bridge to solve now (pgem.command_t\n"
            "                         OPTIMIZE): the bridge solves on new loop closures, so\n"
            "                         without it no graph may include the last odometry edges\n"
            "  --quiet                no progress lines on stderr\n"
            "  --foreign-ids          FILE is one robot's of a team: an edge may name an id\n"
            "                         with no VERTEX line in it, another robot's pose (its\n"
            "                         inter-robot loop closures). Such an edge is sent after\n"
            "                         its own pose (after the last pose when neither is FILE's)\n"
            "                         and the bridge holds it until the other robot's sender\n"
            "                         publishes that pose. Without it such a file is refused\n");
    pgem_lcm_options_help(out, lcm);
    fprintf(out,
            "\n"
            "Progress goes to stderr about every 2 s, the summary to stdout. Exit codes: 0 sent\n"
            "(and with --wait, taken), 1 nothing to send, a failed publish, --wait timed out or\n"
            "a signal stopped it, 2 bad command line, 3 FILE could not be read or the --latency\n"
            "file not written. Loop closures never seen in a graph are not an error by\n"
            "themselves.\n");
}

/* A value option of the sender; returns 1 when parsed, 0 after printing an error. */
static int send_parse_value(void *user, const char *arg, const char *value)
{
    send_args_t *args = user;
    if (strcmp(arg, "--rate") == 0) {
        return pgem_cli_parse_number(SEND_TOOL, arg, value, 0, &args->rate);
    }
    if (strcmp(arg, "--wait") == 0) {
        return pgem_cli_parse_number(SEND_TOOL, arg, value, 0, &args->wait);
    }
    if (strcmp(arg, "--pause-every") == 0) {
        return pgem_lcm_parse_u64(SEND_TOOL, arg, value, &args->pause_every);
    }
    if (strcmp(arg, "--pause") == 0) {
        return pgem_cli_parse_number(SEND_TOOL, arg, value, 0, &args->pause_seconds);
    }
    if (strcmp(arg, "--latency") == 0) {
        if (value == NULL || value[0] == '\0') {
            fprintf(stderr, "%s: --latency needs a file name\n", SEND_TOOL);
            return 0;
        }
        args->latency = value;
        return 1;
    }
    if (strcmp(arg, "--shuffle") == 0) {
        args->shuffle = 1;
        return pgem_lcm_parse_u64(SEND_TOOL, arg, value, &args->seed);
    }
    if (strcmp(arg, "--first") == 0) {
        args->select = 1;
        return pgem_lcm_parse_u64(SEND_TOOL, arg, value, &args->first);
    }
    if (strcmp(arg, "--count") == 0 || strcmp(arg, "--repeat") == 0) {
        int count = strcmp(arg, "--count") == 0;
        uint64_t *target = count ? &args->count : &args->repeat;
        args->select |= count;
        if (!pgem_lcm_parse_u64(SEND_TOOL, arg, value, target)) {
            return 0;
        }
        if (*target == 0) {
            fprintf(stderr, "%s: %s needs at least 1\n", SEND_TOOL, arg);
            return 0;
        }
        return 1;
    }
    /* --source */
    if (value == NULL || value[0] == '\0' || strlen(value) > SEND_SOURCE_MAX) {
        fprintf(stderr, "%s: --source needs a name of 1 to %d bytes\n", SEND_TOOL,
                SEND_SOURCE_MAX);
        return 0;
    }
    args->source = value;
    return 1;
}

static int send_flag(void *user, const char *name)
{
    send_args_t *args = user;
    if (strcmp(name, "--quiet") == 0) {
        args->quiet = 1;
    } else if (strcmp(name, "--optimize") == 0) {
        args->optimize = 1;
    } else if (strcmp(name, "--foreign-ids") == 0) {
        args->foreign_ids = 1;
    } else {
        return 0;
    }
    return 1;
}

static int send_input(void *user, const char *argument)
{
    send_args_t *args = user;
    if (args->input != NULL) {
        fprintf(stderr, "%s: more than one input file ('%s')\n", SEND_TOOL, argument);
        return 0;
    }
    args->input = argument;
    return 1;
}

/* Returns PGEM_EXIT_OK, PGEM_EXIT_USAGE, or -1 after --help. */
static int send_parse(int argc, char **argv, send_args_t *args)
{
    static const char *const valued[] = {"--rate", "--wait", "--shuffle", "--first",
                                         "--count", "--repeat", "--source", "--latency",
                                         "--pause-every", "--pause"};
    static const pgem_cli_parser_t parser = {
        NULL, valued, sizeof valued / sizeof valued[0], send_parse_value, send_flag, send_input,
        send_help, NULL, NULL};
    memset(args, 0, sizeof *args);
    pgem_lcm_options_init(&args->lcm, SEND_TOOL,
                          PGEM_LCM_POSE_CHANNEL | PGEM_LCM_EDGE_CHANNEL |
                              PGEM_LCM_GRAPH_CHANNEL | PGEM_LCM_STATUS_CHANNEL |
                              PGEM_LCM_COMMAND_CHANNEL);
    args->source = SEND_SOURCE_DEFAULT;
    args->repeat = 1;
    args->count = UINT64_MAX;
    args->wait = -1.0;
    args->pause_seconds = 1.0;
    int status = pgem_lcm_parse_args(&args->lcm, &parser, args, argc, argv);
    if (status != 0) {
        return status;
    }
    if (args->input == NULL) {
        fprintf(stderr, "%s: no input file (see %s --help)\n", SEND_TOOL, SEND_TOOL);
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

/* ---- The plan --------------------------------------------------------------------------- */

static void send_plan_free(send_plan_t *plan)
{
    free(plan->items);
    free(plan->fixed);
    memset(plan, 0, sizeof *plan);
}

/* Whether the edge with this sequence is selected by --first / --count. */
static int send_selected(const send_args_t *args, size_t sequence)
{
    return (uint64_t)sequence >= args->first && (uint64_t)sequence - args->first < args->count;
}

/* Appends `repeat` copies of one message. */
static void send_plan_add(send_plan_t *plan, size_t index, int edge, uint64_t repeat)
{
    for (uint64_t copy = 0; copy < repeat; copy++) {
        plan->items[plan->count++] = (send_item_t){index, edge};
    }
}

/* Fisher-Yates with the tools' splitmix64 generator: the same permutation for a seed. */
static void send_shuffle(send_plan_t *plan, uint64_t seed)
{
    uint64_t state = seed;
    for (size_t k = plan->count; k > 1u; k--) {
        size_t j = (size_t)(pgem_cli_uniform(&state) * (double)k);
        if (j >= k) {
            j = k - 1u;
        }
        send_item_t swap = plan->items[k - 1u];
        plan->items[k - 1u] = plan->items[j];
        plan->items[j] = swap;
    }
}

/* For every selected edge, the file index of its later pose (poses are sent in file order),
 * the poses needed, and the selected edges ordered by that pose, stably (file order within
 * one pose): `order` gets the edge indices, `needed` marks poses. Returns the edges chosen. */
static size_t send_order_edges(const pgem_io_graph_t *graph, const send_args_t *args,
                               const pgem_io_pose_index_t *ids, size_t *ready, size_t *start,
                               size_t *order, unsigned char *needed)
{
    size_t chosen = 0;
    for (size_t e = 0; e < graph->edge_count; e++) {
        ready[e] = PGEM_IO_NO_POSE;
        if (!send_selected(args, e)) {
            continue;
        }
        size_t from = pgem_io_find_pose(ids, graph->pose_count, graph->edges[e].from);
        size_t to = pgem_io_find_pose(ids, graph->pose_count, graph->edges[e].to);
        if (from == PGEM_IO_NO_POSE && to == PGEM_IO_NO_POSE) { /* (--foreign-ids alone) */
            ready[e] = graph->pose_count - 1u; /* after the last pose */
        } else if (from == PGEM_IO_NO_POSE || to == PGEM_IO_NO_POSE) {
            const size_t own = from == PGEM_IO_NO_POSE ? to : from; /* another sender's pose */
            needed[own] = 1;
            ready[e] = own;
        } else {
            needed[from] = needed[to] = 1;
            ready[e] = from > to ? from : to;
        }
        start[ready[e] + 1u]++;
        chosen++;
    }
    for (size_t p = 0; p < graph->pose_count; p++) {
        start[p + 1u] += start[p]; /* counting sort: start[p] is pose p's first slot */
    }
    for (size_t e = 0; e < graph->edge_count; e++) {
        if (ready[e] != PGEM_IO_NO_POSE) {
            order[start[ready[e]]++] = e; /* afterwards start[p] is the end of pose p's run */
        }
    }
    return chosen;
}

/* Fills plan->items: poses in file order, each followed by the edges it completes. */
static void send_plan_stream(const pgem_io_graph_t *graph, const send_args_t *args,
                             const size_t *end, const size_t *order,
                             const unsigned char *needed, send_plan_t *plan)
{
    size_t next = 0;
    for (size_t p = 0; p < graph->pose_count; p++) {
        if (needed[p] || !args->select) {
            send_plan_add(plan, p, 0, args->repeat);
            plan->poses++;
        }
        for (; next < end[p]; next++) {
            send_plan_add(plan, order[next], 1, args->repeat);
        }
    }
}

/* Marks the poses named by FIX lines. */
static void send_mark_fixed(const pgem_io_graph_t *graph, const pgem_io_pose_index_t *ids,
                            unsigned char *fixed)
{
    for (size_t f = 0; f < graph->fixed_count; f++) {
        size_t pose = pgem_io_find_pose(ids, graph->pose_count, graph->fixed[f]);
        if (pose != PGEM_IO_NO_POSE) {
            fixed[pose] = 1;
        }
    }
}

/* Builds the plan. Returns PGEM_EXIT_OK or PGEM_EXIT_FAILURE (printed). */
static int send_plan_build(const pgem_io_graph_t *graph, const send_args_t *args,
                           send_plan_t *plan)
{
    size_t poses = graph->pose_count, edges = graph->edge_count;
    memset(plan, 0, sizeof *plan);
    pgem_io_pose_index_t *ids = pgem_io_index_poses(graph);
    size_t *ready = malloc((edges + 1u) * sizeof *ready);
    size_t *start = calloc(poses + 1u, sizeof *start);
    size_t *order = malloc((edges + 1u) * sizeof *order);
    unsigned char *needed = calloc(poses, 1);
    plan->fixed = calloc(poses, 1);
    int status = PGEM_EXIT_FAILURE;
    if (ids == NULL || ready == NULL || start == NULL || order == NULL || needed == NULL ||
        plan->fixed == NULL) {
        fprintf(stderr, "%s: out of memory\n", SEND_TOOL);
        goto done;
    }
    send_mark_fixed(graph, ids, plan->fixed);
    plan->edges = send_order_edges(graph, args, ids, ready, start, order, needed);
    if (args->select && plan->edges == 0) {
        fprintf(stderr, "%s: no edges with sequence from %llu (%s has %zu edges, 0 to %zu)\n",
                SEND_TOOL, (unsigned long long)args->first, args->input, edges,
                edges > 0 ? edges - 1u : 0u);
        goto done;
    }
    size_t messages = poses + plan->edges;
    if (args->repeat > (uint64_t)(SIZE_MAX / sizeof *plan->items / (messages + 1u))) {
        fprintf(stderr, "%s: --repeat %llu is too many copies\n", SEND_TOOL,
                (unsigned long long)args->repeat);
        goto done;
    }
    plan->items = malloc((size_t)args->repeat * messages * sizeof *plan->items + 1u);
    if (plan->items == NULL) {
        fprintf(stderr, "%s: out of memory for %llu copies of %zu messages\n", SEND_TOOL,
                (unsigned long long)args->repeat, messages);
        goto done;
    }
    send_plan_stream(graph, args, start, order, needed, plan);
    plan->edge_messages = plan->edges * (size_t)args->repeat;
    if (args->shuffle) {
        send_shuffle(plan, args->seed);
    }
    status = PGEM_EXIT_OK;
done:
    free(ids);
    free(ready);
    free(start);
    free(order);
    free(needed);
    if (status != PGEM_EXIT_OK) {
        send_plan_free(plan);
    }
    return status;
}

/* ---- Publishing ------------------------------------------------------------------------- */

/* The upper triangle, row by row, of an n x n row-major matrix. */
static void send_upper_triangle(const double *full, int n, double *upper)
{
    int k = 0;
    for (int row = 0; row < n; row++) {
        for (int col = row; col < n; col++) {
            upper[k++] = full[row * n + col];
        }
    }
}

static int send_pose(send_context_t *context, size_t index)
{
    const pgem_io_pose_t *pose = &context->graph->poses[index];
    int8_t fixed = (int8_t)context->plan->fixed[index];
    if (context->graph->dimension == 3) {
        pgem_pose3_t message = {pgem_lcm_utime(), context->source, (int64_t)pose->id, {0},
                                fixed};
        memcpy(message.pose, pose->pose, sizeof message.pose);
        return pgem_pose3_t_publish(context->lcm, context->channels.pose, &message);
    }
    pgem_pose2_t message = {pgem_lcm_utime(), context->source, (int64_t)pose->id, {0}, fixed};
    memcpy(message.pose, pose->pose, sizeof message.pose);
    return pgem_pose2_t_publish(context->lcm, context->channels.pose, &message);
}

static int send_edge(send_context_t *context, size_t index)
{
    const pgem_io_edge_t *edge = &context->graph->edges[index];
    int8_t kind = edge->kind == PGEM_EDGE_LOOP ? PGEM_EDGE2_T_LOOP : PGEM_EDGE2_T_ODOMETRY;
    if (context->graph->dimension == 3) {
        pgem_edge3_t message = {pgem_lcm_utime(), context->source, (int64_t)index,
                                (int64_t)edge->from, (int64_t)edge->to, {0}, {0}, kind};
        memcpy(message.measurement, edge->measurement, sizeof message.measurement);
        send_upper_triangle(edge->information, 6, message.information);
        return pgem_edge3_t_publish(context->lcm, context->channels.edge, &message);
    }
    pgem_edge2_t message = {pgem_lcm_utime(), context->source, (int64_t)index,
                            (int64_t)edge->from, (int64_t)edge->to, {0}, {0}, kind};
    memcpy(message.measurement, edge->measurement, sizeof message.measurement);
    send_upper_triangle(edge->information, 3, message.information);
    return pgem_edge2_t_publish(context->lcm, context->channels.edge, &message);
}

/* Counts of one run, for progress lines and the summary. */
typedef struct send_progress {
    double start;            /* clock when sending began */
    double last_line;        /* clock of the last progress line */
    size_t poses;            /* pose messages sent */
    size_t edges;            /* edge messages sent */
    size_t pause_edges;      /* edge messages sent since the last pause (--pause-every) */
} send_progress_t;

static void send_progress_line(const send_args_t *args, const send_plan_t *plan,
                               send_progress_t *progress, double now)
{
    if (args->quiet || now - progress->last_line < SEND_PROGRESS_SECONDS) {
        return;
    }
    double elapsed = now - progress->start;
    fprintf(stderr, "sent %zu/%zu edges, %.1f edges/s\n", progress->edges, plan->edge_messages,
            elapsed > 0.0 ? (double)progress->edges / elapsed : 0.0);
    progress->last_line = now;
}

/* Waits until the clock reaches `deadline`. While subscribed, the messages that arrive
 * meanwhile are dispatched at once (LCM is polled in whole milliseconds that end before the
 * deadline, what is waiting taken before the rest is slept), so their arrival times are taken promptly. Returns 1 at the
 * deadline, 0 when a stop was requested, -1 when receiving failed (printed). */
static int send_pause(send_context_t *context, double deadline)
{
    for (;;) {
        if (pgem_lcm_stop_signal() != 0) {
            return 0;
        }
        double left = deadline - pgem_cli_now();
        if (left <= 0.0) {
            return 1;
        }
        if (!context->receiving || left <= SEND_POLL_STEP) {
            /* what arrived is dispatched even when less than a poll step is left (above about
             * 1000 edges/s every gap is), or graphs would wait for the end of the send */
            if (context->receiving && pgem_lcm_drain(SEND_TOOL, context->lcm) < 0) {
                return -1;
            }
            return pgem_lcm_sleep_until(deadline);
        }
        /* pgem_lcm_handle rounds up to a millisecond: one less ends before the deadline. */
        if (pgem_lcm_handle(SEND_TOOL, context->lcm, left - SEND_POLL_STEP) < 0) {
            return -1;
        }
    }
}

/* --latency: notes the first send of a loop closure. */
static void send_mark_sent(send_context_t *context, size_t index, double now)
{
    send_latency_t *latency = &context->latency;
    if (latency->marks == NULL || context->graph->edges[index].kind != PGEM_EDGE_LOOP ||
        latency->marks[index].sent >= 0.0) {
        return;
    }
    latency->marks[index].sent = now;
    latency->marks[index].since_pause = context->pause_end >= 0.0 ? now - context->pause_end : -1.0;
    latency->sent++;
}

/* Publishes the plan, paced by --rate. While subscribed (--wait, --latency), messages that
 * arrive meanwhile are dispatched (statuses are not judged yet): while pacing waits, and
 * without --rate before every pose, never between a pose and the edges sent with it (a large
 * graph takes milliseconds to decode, and the bridge may solve while a new pose has no edge
 * yet). Returns PGEM_EXIT_OK or PGEM_EXIT_FAILURE (printed). */
static int send_all(send_context_t *context, const send_args_t *args, send_progress_t *progress)
{
    const send_plan_t *plan = context->plan;
    progress->start = progress->last_line = pgem_cli_now();
    for (size_t k = 0; k < plan->count; k++) {
        const send_item_t *item = &plan->items[k];
        if (args->pause_every > 0u && !item->edge && progress->pause_edges >= args->pause_every) {
            /* silent, as a robot standing still (before a pose: never between a pose and
             * its edges); the pacing resumes from here */
            const double from = pgem_cli_now();
            const int paused = send_pause(context, from + args->pause_seconds);
            if (paused < 0) {
                return PGEM_EXIT_FAILURE;
            }
            if (paused == 0) {
                break;
            }
            context->pause_end = pgem_cli_now();
            progress->start += context->pause_end - from;
            progress->pause_edges = 0;
        }
        /* A message is due when the next edge is: poses travel with the edges after them. */
        int due = args->rate > 0.0
                      ? send_pause(context, progress->start + (double)progress->edges / args->rate)
                      : 1;
        if (due < 0) {
            return PGEM_EXIT_FAILURE;
        }
        if (due == 0 || pgem_lcm_stop_signal() != 0) {
            break;
        }
        if (context->receiving && args->rate <= 0.0 && !item->edge &&
            pgem_lcm_drain(SEND_TOOL, context->lcm) < 0) {
            return PGEM_EXIT_FAILURE;
        }
        int status = item->edge ? send_edge(context, item->index)
                                : send_pose(context, item->index);
        if (status != 0) {
            fprintf(stderr, "%s: publishing on %s failed (LCM at %s)\n", SEND_TOOL,
                    item->edge ? context->channels.edge : context->channels.pose,
                    pgem_lcm_url_name(args->lcm.url));
            return PGEM_EXIT_FAILURE;
        }
        double now = pgem_cli_now();
        if (item->edge) {
            send_mark_sent(context, item->index, now);
        }
        progress->edges += item->edge != 0;
        progress->pause_edges += item->edge != 0;
        progress->poses += item->edge == 0;
        send_progress_line(args, plan, progress, now);
    }
    if (pgem_lcm_stop_signal() != 0) {
        fprintf(stderr, "%s: stopped by signal %d after %zu of %zu edge messages\n", SEND_TOOL,
                pgem_lcm_stop_signal(), progress->edges, plan->edge_messages);
        return PGEM_EXIT_FAILURE;
    }
    return PGEM_EXIT_OK;
}

static void send_summary(const send_args_t *args, const send_plan_t *plan,
                         const send_progress_t *progress)
{
    double seconds = pgem_cli_now() - progress->start;
    printf("sent %zu poses and %zu edges in %.3f s (%.1f edges/s)", plan->poses, plan->edges,
           seconds, seconds > 0.0 ? (double)progress->edges / seconds : 0.0);
    if (args->repeat > 1u) {
        printf(", every message %llu times (%zu pose and %zu edge messages)",
               (unsigned long long)args->repeat, progress->poses, progress->edges);
    }
    printf("\n");
    fflush(stdout);
}

/* ---- --wait ----------------------------------------------------------------------------- */

static void send_on_status(const lcm_recv_buf_t *buffer, const char *channel,
                           const pgem_status_t *status, void *user)
{
    send_wait_t *wait = user;
    (void)buffer;
    (void)channel;
    pgem_status_t *copy = pgem_status_t_copy(status);
    if (copy == NULL) {
        return;
    }
    if (wait->latest != NULL) {
        pgem_status_t_destroy(wait->latest);
    }
    wait->latest = copy;
    wait->statuses++;
    if (wait->armed && status->accepted_edges >= wait->edges && status->pending == 0 &&
        status->queued == 0) {
        wait->satisfied = 1;
    }
}

/* Whether the waiting after the last message is over: a status showed every edge taken (or
 * no --wait), and every loop closure sent was seen in a graph (or no --latency). */
static int send_waited(const send_args_t *args, const send_context_t *context,
                       const send_wait_t *wait)
{
    const send_latency_t *latency = &context->latency;
    return (args->wait < 0.0 || wait->satisfied) &&
           (latency->marks == NULL || latency->seen == latency->sent);
}

/* After the last message: receives until send_waited, --wait SECONDS (with --latency alone,
 * SEND_LATENCY_WAIT) or a stop signal. Returns 0, or -1 when receiving failed (printed). */
static int send_linger(const send_args_t *args, send_context_t *context, send_wait_t *wait)
{
    double deadline = pgem_cli_now() + (args->wait >= 0.0 ? args->wait : SEND_LATENCY_WAIT);
    wait->armed = 1;
    for (;;) {
        if (pgem_lcm_handle(SEND_TOOL, context->lcm, 0.0) < 0) {
            return -1;
        }
        double left = deadline - pgem_cli_now();
        if (send_waited(args, context, wait) || left <= 0.0 || pgem_lcm_stop_signal() != 0) {
            return 0;
        }
        if (pgem_lcm_handle(SEND_TOOL, context->lcm,
                            left < SEND_WAIT_SLICE ? left : SEND_WAIT_SLICE) < 0) {
            return -1;
        }
    }
}

/* Prints the outcome of --wait. Returns a PGEM_EXIT_* code. */
static int send_wait_report(const send_args_t *args, const send_context_t *context,
                            const send_wait_t *wait)
{
    if (wait->latest != NULL) {
        printf("bridge%s: ", wait->satisfied ? "" : " (latest status)");
        pgem_lcm_print_status(stdout, wait->latest);
    }
    if (wait->satisfied) {
        return PGEM_EXIT_OK;
    }
    const char *why = pgem_lcm_stop_signal() != 0 ? "stopped by a signal" : "timed out";
    if (wait->latest == NULL) {
        fprintf(stderr, "%s: %s after %g s: no status on %s (is pgem-lcm-bridge running at %s "
                        "with the same channel prefix?)\n",
                SEND_TOOL, why, args->wait, context->channels.status,
                pgem_lcm_url_name(args->lcm.url));
    } else {
        fprintf(stderr, "%s: %s after %g s waiting for the bridge to take %zu edges (accepted "
                        "edges %lld, pending %d, queued %d)%s\n",
                SEND_TOOL, why, args->wait, context->plan->edges,
                (long long)wait->latest->accepted_edges, (int)wait->latest->pending,
                (int)wait->latest->queued,
                wait->latest->dimension != context->graph->dimension
                    ? "; the bridge's dimension differs from the file's"
                    : "");
    }
    return PGEM_EXIT_FAILURE;
}

/* ---- --latency ------------------------------------------------------------------------- */

/* Marks the loop closures of this source in a graph as seen, with the graph's arrival time. */
static void send_on_graph(const lcm_recv_buf_t *buffer, const char *channel,
                          const pgem_graph_t *graph, void *user)
{
    send_latency_t *latency = user;
    double now = pgem_cli_now();
    (void)buffer;
    (void)channel;
    latency->graphs++;
    int32_t source = 0;
    while (source < graph->num_sources && strcmp(graph->sources[source], latency->source) != 0) {
        source++;
    }
    if (source == graph->num_sources) {
        return;
    }
    for (int32_t k = 0; k < graph->num_loops; k++) {
        const pgem_loop_t *loop = &graph->loops[k];
        if (loop->source_index != source || loop->sequence < 0 ||
            (uint64_t)loop->sequence >= (uint64_t)latency->edges) {
            continue;
        }
        send_mark_t *mark = &latency->marks[loop->sequence];
        if (mark->sent < 0.0 || mark->seen >= 0.0) {
            continue; /* not sent by this run (yet), or seen before */
        }
        mark->seen = now;
        mark->solve_id = graph->stats.solve_id;
        latency->seen++;
    }
}

/* Allocates the marks, none sent or seen. Returns 0, or -1 after printing. */
static int send_latency_init(send_latency_t *latency, const pgem_io_graph_t *graph,
                             const char *source)
{
    memset(latency, 0, sizeof *latency);
    latency->marks = malloc((graph->edge_count + 1u) * sizeof *latency->marks);
    if (latency->marks == NULL) {
        fprintf(stderr, "%s: out of memory for --latency\n", SEND_TOOL);
        return -1;
    }
    for (size_t e = 0; e < graph->edge_count; e++) {
        latency->marks[e] = (send_mark_t){-1.0, -1.0, 0, -1.0};
    }
    latency->edges = graph->edge_count;
    latency->source = source;
    return 0;
}

static int send_compare_doubles(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* The nearest-rank percentile (1 to 100) of count > 0 sorted values. */
static double send_nearest_rank(const double *sorted, size_t count, unsigned percent)
{
    size_t rank = (percent * count + 99u) / 100u; /* ceil(percent / 100 * count) */
    return sorted[rank > 0u ? rank - 1u : 0u];
}

/* Writes FILE.csv, one line per loop closure sent, in sequence order. Returns 0 or -1. */
static int send_latency_csv(const send_args_t *args, const send_context_t *context)
{
    const send_latency_t *latency = &context->latency;
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, SEND_TOOL, args->latency) != 0) {
        return -1;
    }
    int failed = fprintf(file.stream, "sequence,from,to,latency_ms,solve_id,since_pause_s\n") < 0;
    for (size_t e = 0; e < latency->edges && !failed; e++) {
        const send_mark_t *mark = &latency->marks[e];
        const pgem_io_edge_t *edge = &context->graph->edges[e];
        if (mark->sent < 0.0) {
            continue;
        }
        failed = fprintf(file.stream, "%zu,%llu,%llu,", e, (unsigned long long)edge->from,
                         (unsigned long long)edge->to) < 0;
        if (mark->seen >= 0.0) {
            failed |= fprintf(file.stream, "%.3f,%lld,", 1e3 * (mark->seen - mark->sent),
                              (long long)mark->solve_id) < 0;
        } else {
            failed |= fputs(",,", file.stream) < 0;
        }
        if (mark->since_pause >= 0.0) {
            failed |= fprintf(file.stream, "%.3f", mark->since_pause) < 0;
        }
        failed |= fputs("\n", file.stream) < 0;
    }
    return (pgem_cli_file_commit(&file, failed) == PGEM_EXIT_OK ? 0 : -1);
}

/* Prints "latency: N loop closures seen of M, median ..." (the latencies in ms, nearest
 * rank). Returns 0, or -1 when out of memory (printed). */
static int send_latency_summary(const send_latency_t *latency)
{
    double *values = malloc((latency->seen + 1u) * sizeof *values);
    if (values == NULL) {
        fprintf(stderr, "%s: out of memory for the latency summary\n", SEND_TOOL);
        return -1;
    }
    size_t count = 0;
    for (size_t e = 0; e < latency->edges; e++) {
        const send_mark_t *mark = &latency->marks[e];
        if (mark->sent >= 0.0 && mark->seen >= 0.0 && count < latency->seen) {
            values[count++] = 1e3 * (mark->seen - mark->sent);
        }
    }
    printf("latency: %zu loop closures seen of %zu", count, latency->sent);
    if (count > 0u) {
        qsort(values, count, sizeof *values, send_compare_doubles);
        printf(", median %.1f ms, p90 %.1f ms, p99 %.1f ms, max %.1f ms",
               send_nearest_rank(values, count, 50u), send_nearest_rank(values, count, 90u),
               send_nearest_rank(values, count, 99u), values[count - 1u]);
    }
    printf("\n");
    fflush(stdout);
    free(values);
    return 0;
}

/* Writes the CSV and prints the summary (and, on stderr, how many were never seen). Returns
 * a PGEM_EXIT_* code. */
static int send_latency_report(const send_args_t *args, const send_context_t *context)
{
    const send_latency_t *latency = &context->latency;
    if (send_latency_csv(args, context) != 0) {
        return PGEM_EXIT_IO;
    }
    if (send_latency_summary(latency) != 0) {
        return PGEM_EXIT_FAILURE;
    }
    if (latency->seen < latency->sent) {
        fprintf(stderr, "%s: %zu of %zu loop closures never seen in a graph on %s (%llu "
                        "graphs received)\n",
                SEND_TOOL, latency->sent - latency->seen, latency->sent,
                context->channels.graph, (unsigned long long)latency->graphs);
    }
    return PGEM_EXIT_OK;
}

/* ---- --optimize ------------------------------------------------------------------------- */

/* Asks the bridge to solve now. Returns a PGEM_EXIT_* code. */
static int send_optimize(const send_args_t *args, send_context_t *context)
{
    pgem_command_t command;
    char empty[1] = "";
    memset(&command, 0, sizeof command);
    command.utime = pgem_lcm_utime();
    command.command = PGEM_COMMAND_T_OPTIMIZE;
    command.path = empty;
    if (pgem_command_t_publish(context->lcm, context->channels.command, &command) != 0) {
        fprintf(stderr, "%s: publishing on %s failed (LCM at %s)\n", SEND_TOOL,
                context->channels.command, pgem_lcm_url_name(args->lcm.url));
        return PGEM_EXIT_FAILURE;
    }
    printf("asked the bridge to solve (OPTIMIZE on %s)\n", context->channels.command);
    return PGEM_EXIT_OK;
}

/* ---- main ------------------------------------------------------------------------------- */

/* The subscriptions of a run (NULL: not subscribed). */
typedef struct send_subscriptions {
    pgem_status_t_subscription_t *status;   /* --wait */
    pgem_graph_t_subscription_t *graph;     /* --latency */
} send_subscriptions_t;

/* Subscribes before anything is sent, so that no status or graph is missed. Returns 0, or -1
 * after printing. */
static int send_subscribe(const send_args_t *args, send_context_t *context, send_wait_t *wait,
                          send_subscriptions_t *subscriptions)
{
    if (args->wait >= 0.0) {
        subscriptions->status = pgem_status_t_subscribe(context->lcm, context->channels.status,
                                                        send_on_status, wait);
        if (subscriptions->status == NULL) {
            fprintf(stderr, "%s: cannot subscribe to %s\n", SEND_TOOL, context->channels.status);
            return -1;
        }
        pgem_status_t_subscription_set_queue_capacity(subscriptions->status, SEND_STATUS_QUEUE);
    }
    if (args->latency != NULL) {
        subscriptions->graph = pgem_graph_t_subscribe(context->lcm, context->channels.graph,
                                                      send_on_graph, &context->latency);
        if (subscriptions->graph == NULL) {
            fprintf(stderr, "%s: cannot subscribe to %s\n", SEND_TOOL, context->channels.graph);
            return -1;
        }
        pgem_graph_t_subscription_set_queue_capacity(subscriptions->graph, SEND_GRAPH_QUEUE);
    }
    context->receiving = args->wait >= 0.0 || args->latency != NULL;
    context->pause_end = -1.0;
    return 0;
}

static void send_unsubscribe(send_context_t *context, send_subscriptions_t *subscriptions)
{
    if (subscriptions->status != NULL) {
        pgem_status_t_unsubscribe(context->lcm, subscriptions->status);
    }
    if (subscriptions->graph != NULL) {
        pgem_graph_t_unsubscribe(context->lcm, subscriptions->graph);
    }
}

/* Sends, then waits for the bridge (--wait, --latency), reports and asks for a solve
 * (--optimize). Returns a PGEM_EXIT_* code. */
static int send_and_wait(const send_args_t *args, send_context_t *context, send_wait_t *wait)
{
    send_progress_t progress = {0.0, 0.0, 0, 0, 0};
    int status = send_all(context, args, &progress);
    if (status == PGEM_EXIT_OK) {
        send_summary(args, context->plan, &progress);
        if (context->receiving && send_linger(args, context, wait) != 0) {
            status = PGEM_EXIT_FAILURE;
        }
        if (status == PGEM_EXIT_OK && args->wait >= 0.0) {
            status = send_wait_report(args, context, wait);
        }
    }
    if (args->latency != NULL) {
        /* Also after a failure: the loop closures measured so far. */
        int written = send_latency_report(args, context);
        status = status == PGEM_EXIT_OK ? written : status;
    }
    if (status == PGEM_EXIT_OK && args->optimize) {
        status = send_optimize(args, context);
    }
    return status;
}

/* Opens LCM, subscribes for --wait and --latency, sends, waits. Returns a PGEM_EXIT_* code. */
static int send_run(const send_args_t *args, send_context_t *context)
{
    send_wait_t wait = {NULL, 0, 0, 0, (int64_t)context->plan->edges};
    send_subscriptions_t subscriptions = {NULL, NULL};
    if (pgem_lcm_catch_signals(SEND_TOOL) != 0) {
        return PGEM_EXIT_FAILURE;
    }
    if (args->latency != NULL &&
        send_latency_init(&context->latency, context->graph, context->source) != 0) {
        return PGEM_EXIT_FAILURE;
    }
    /* Graphs are large (about 700 KB at 10000 poses): a receive buffer for bursts of them. */
    context->lcm = pgem_lcm_open(SEND_TOOL, args->lcm.url,
                                 args->latency != NULL ? PGEM_LCM_RECEIVE_BUFFER : 0);
    int status = PGEM_EXIT_FAILURE;
    if (context->lcm != NULL && send_subscribe(args, context, &wait, &subscriptions) == 0) {
        status = send_and_wait(args, context, &wait);
    }
    if (context->lcm != NULL) {
        send_unsubscribe(context, &subscriptions);
        lcm_destroy(context->lcm);
    }
    if (wait.latest != NULL) {
        pgem_status_t_destroy(wait.latest);
    }
    free(context->latency.marks);
    return status;
}

int main(int argc, char **argv)
{
    send_args_t args;
    int status = send_parse(argc, argv, &args);
    if (status != PGEM_EXIT_OK) {
        if (status == PGEM_EXIT_USAGE) {
            send_usage(stderr);
        }
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    pgem_io_graph_t graph = {0};
    send_plan_t plan = {0};
    send_context_t context;
    memset(&context, 0, sizeof context);
    status = pgem_cli_read_graph(SEND_TOOL, args.input,
                                 PGEM_CLI_NEED_POSES | PGEM_CLI_WARN_CHAINED |
                                     (args.foreign_ids ? PGEM_CLI_FOREIGN_IDS
                                                       : PGEM_CLI_OFFER_FOREIGN),
                                 &graph);
    if (status == PGEM_EXIT_OK && graph.foreign_edges > 0 && !args.quiet) {
        fprintf(stderr, "%s: %zu edges name another sender's poses (the first on line %lu): "
                        "the bridge holds each until that pose arrives\n",
                SEND_TOOL, graph.foreign_edges, graph.first_foreign_line);
    }
    if (status == PGEM_EXIT_OK) {
        status = pgem_lcm_channels(&args.lcm, graph.dimension, &context.channels) == 0
                     ? send_plan_build(&graph, &args, &plan)
                     : PGEM_EXIT_USAGE;
    }
    if (status == PGEM_EXIT_OK) {
        context.graph = &graph;
        context.plan = &plan;
        snprintf(context.source, sizeof context.source, "%s", args.source);
        status = send_run(&args, &context);
    }
    send_plan_free(&plan);
    pgem_io_graph_free(&graph);
    return status;
}
