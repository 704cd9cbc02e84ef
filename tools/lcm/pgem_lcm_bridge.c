/* pgem-lcm-bridge: the robust back-end as an LCM service. */
#define _POSIX_C_SOURCE 200809L
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bridge.h"
#include "cli.h"
#include "lcm_tool.h"

#define TOOL "pgem-lcm-bridge"

static void usage(FILE *out, const void *context)
{
    const pgem_lcm_options_t *lcm = context;
    fprintf(out,
            "usage: pgem-lcm-bridge [options]\n"
            "Receives poses and edges from front-ends over LCM, updates the estimate\n"
            "incrementally for every pose (EM on the whole graph once the stream goes quiet,\n"
            "or on command) and publishes the optimized graph and a status.\n"
            "Stops cleanly on SIGINT or SIGTERM.\n"
            "\n"
            "  --dimension 2|3        pose dimension (default 2)\n"
            "  --max-poses N          pose capacity (default 20000)\n"
            "  --max-edges N          edge capacity (default 4 per pose)\n"
            "  --fill-budget N        nonzeros reserved for the factor (default: the core's)\n"
            "  --max-pending N        edges that may wait for a pose (default 4096)\n"
            "  --max-sources N        front-ends (default 64)\n"
            "  --journal PATH         append-only journal (LCM log format); an existing one\n"
            "                         is replayed first, so a restarted bridge has its graph\n"
            "  --journal-sync         fdatasync every journal record (survives power loss)\n"
            "  --snapshot-dir DIR     let SNAPSHOT commands write FILE and FILE.weights into\n"
            "                         DIR (FILE a plain name; default: SNAPSHOT is refused)\n"
            "  --snapshot-limit N     SNAPSHOTs accepted in any minute at most; more are\n"
            "                         refused, named (6)\n"
            "  --snapshot-budget MIB  MiB snapshots may write in any minute; one that would\n"
            "                         pass it is refused, named (64)\n"
            "  --pending-timeout S    an edge waits at most S seconds for its poses, then it\n"
            "                         expires (60)\n"
            "  --full                 re-solve the whole graph with EM for new loop closures\n"
            "                         (debounced, rate-limited) instead of an incremental\n"
            "                         update per pose; the settle solve after idle is the same\n"
            "  --incremental          the default (kept for older command lines)\n"
            "  --compact              keep mapping past the capacity: at 90%% of --max-poses\n"
            "                         or --max-edges remove poses down to 70%% (chain poses\n"
            "                         first, their odometry composed, loop closures carried\n"
            "                         onto kept poses); a later edge to a removed pose enters\n"
            "                         on the kept pose before it, a pose message with a\n"
            "                         removed id is refused as 'removed'; each compaction\n"
            "                         is published (pgem.compaction_t: the removed poses and\n"
            "                         their anchors); poses are refused only when compaction\n"
            "                         can free nothing, as 'full' (default: poses beyond the\n"
            "                         capacity are refused as 'capacity')\n"
            "  --compact-tail N       the newest poses compaction never removes (64)\n"
            "  --no-live-em           incremental: no whole-graph EM passes while the stream\n"
            "                         goes on (by default one runs on a copy of the graph, on\n"
            "                         a thread of its own, and its verdicts and estimate are\n"
            "                         taken into the live map when it ends; the copy's block\n"
            "                         is sized at start, about the core block without the\n"
            "                         incremental factor's room)\n"
            "  --debounce S           with --full: quiet time after a loop closure before\n"
            "                         solving (0.01)\n"
            "  --max-delay S          with --full: longest a loop closure waits while more\n"
            "                         arrive (0.1)\n"
            "  --max-rate HZ          with --full: solves per second at most (20)\n"
            "  --status-period S      seconds between status messages (0.5)\n"
            "  --idle-solve S         solve edges not yet solved (odometry only, say) after S\n"
            "                         seconds without new messages (0.5)\n"
            "  --robust KERNEL        weight loop closures: em (default: Lee et al. EM with\n"
            "                         pruning), cauchy, huber, dcs (IRLS), none (weight 1)\n"
            "  --robust-scale C       kernel scale: Cauchy c, Huber k, DCS phi (default 1)\n"
            "  --prune-threshold T    EM: prune loop closures with weight below T (default\n"
            "                         0.01)\n"
            "  --m-step-iterations N  Gauss-Newton iterations per M-step (default 1)\n"
            "  --max-em-iterations N  EM: E/M iterations per round (default 5; --literal: 100)\n"
            "  --gate G               EM: consistency-test chi2 threshold (default 99.9%%\n"
            "                         quantile)\n"
            "  --restart              EM: restart from the initial estimate after pruning\n"
            "  --dormant-threshold D|off  EM: a loop weighing less than D gets no place in\n"
            "                         the factor, with the same result (default T/100; off:\n"
            "                         every loop in the factor)\n"
            "  --literal              the paper's EM as published (no polish or gate)\n"
            "  --distance D           innovation (default: loops tested against what the map\n"
            "                         predicts for them) or point (the paper's chi2)\n"
            "  --odometry-inflation K innovation: the map's covariance counts K times (4)\n"
            "  --predictable-rotation R  innovation: a loop is tested by its innovation when\n"
            "                         the map predicts its rotation to R radians (0.1)\n"
            "  --no-covariance        publish no pgem.covariance_t (by default the newest\n"
            "                         pose's marginal covariance follows every graph: from\n"
            "                         the incremental factor after an update, from a factor\n"
            "                         at the estimate after a whole-graph solve)\n"
            "  --quiet                no progress lines on stderr\n");
    pgem_lcm_options_help(out, lcm);
    fprintf(out, "Exit status: 0 after a clean stop, 1 if the bridge could not start, 2 usage.\n");
}

static void log_line(void *user, const char *line)
{
    (void)user;
    fprintf(stderr, TOOL ": %s\n", line);
}

typedef struct parsed {
    pgem_bridge_options_t options;
    pgem_lcm_options_t lcm;
    int quiet;
} parsed_t;

/* How an option's value is read. */
typedef enum value_kind {
    COUNT,       /* a non-negative integer */
    ITERATIONS,  /* an integer, at least 1 */
    POSITIVE,    /* a positive number */
    PATH,        /* a file name */
    DIMENSION,   /* 2 or 3 */
    DISTANCE,    /* innovation or point */
    KERNEL,      /* em, cauchy, huber, dcs or none */
    DORMANT      /* a non-negative number, or off */
} value_kind_t;

typedef struct valued_option {
    const char *name;
    value_kind_t kind;
    size_t offset; /* of the field in pgem_bridge_options_t */
} valued_option_t;

#define FIELD(member) offsetof(pgem_bridge_options_t, member)

static const valued_option_t valued_options[] = {
    {"--dimension", DIMENSION, FIELD(dimension)},
    {"--max-poses", COUNT, FIELD(max_poses)},
    {"--max-edges", COUNT, FIELD(max_edges)},
    {"--fill-budget", COUNT, FIELD(fill_budget)},
    {"--max-pending", COUNT, FIELD(max_pending)},
    {"--max-sources", COUNT, FIELD(max_sources)},
    {"--compact-tail", COUNT, FIELD(compact_tail)},
    {"--journal", PATH, FIELD(journal)},
    {"--snapshot-dir", PATH, FIELD(snapshot_dir)},
    {"--snapshot-limit", COUNT, FIELD(snapshot_limit)},
    {"--snapshot-budget", POSITIVE, FIELD(snapshot_budget)},
    {"--pending-timeout", POSITIVE, FIELD(pending_timeout)},
    {"--debounce", POSITIVE, FIELD(debounce)},
    {"--max-delay", POSITIVE, FIELD(max_delay)},
    {"--max-rate", POSITIVE, FIELD(max_rate)},
    {"--status-period", POSITIVE, FIELD(status_period)},
    {"--idle-solve", POSITIVE, FIELD(idle_solve)},
    {"--robust-scale", POSITIVE, FIELD(robust.scale)},
    {"--prune-threshold", POSITIVE, FIELD(robust.prune_threshold)},
    {"--m-step-iterations", ITERATIONS, FIELD(robust.m_step_iterations)},
    {"--max-em-iterations", ITERATIONS, FIELD(robust.max_em_iterations)},
    {"--gate", POSITIVE, FIELD(robust.gate)},
    {"--robust", KERNEL, FIELD(robust.kernel)},
    {"--dormant-threshold", DORMANT, FIELD(robust.dormant_threshold)},
    {"--distance", DISTANCE, FIELD(robust.distance)},
    {"--odometry-inflation", POSITIVE, FIELD(robust.odometry_inflation)},
    {"--predictable-rotation", POSITIVE, FIELD(robust.predictable_rotation)},
};

#define VALUED_COUNT (sizeof valued_options / sizeof valued_options[0])

/* One option with a value; 1, or 0 after printing why. */
static int parse_value(void *user, const char *name, const char *value)
{
    parsed_t *p = user;
    const valued_option_t *option = valued_options;
    while (strcmp(option->name, name) != 0) {
        option++; /* the parser only passes names from the table */
    }
    char *field = (char *)&p->options + option->offset;
    switch (option->kind) {
    case COUNT:
        return pgem_cli_parse_u32(TOOL, name, value, (uint32_t *)(void *)field);
    case ITERATIONS:
        return pgem_cli_parse_at_least(TOOL, name, value, 1, "iteration",
                                       (uint32_t *)(void *)field);
    case POSITIVE:
        return pgem_cli_parse_number(TOOL, name, value, 1, (double *)(void *)field);
    case PATH:
        if (value == NULL || value[0] == '\0') {
            fprintf(stderr, TOOL ": %s needs a file name\n", name);
            return 0;
        }
        *(const char **)(void *)field = value;
        return 1;
    case DIMENSION:
        if (value == NULL || (strcmp(value, "2") != 0 && strcmp(value, "3") != 0)) {
            fprintf(stderr, TOOL ": --dimension takes 2 or 3, got '%s'\n",
                    value != NULL ? value : "");
            return 0;
        }
        p->options.dimension = value[0] - '0';
        return 1;
    case DISTANCE:
        if (value != NULL && strcmp(value, "innovation") == 0) {
            p->options.robust.distance = PGEM_DISTANCE_INNOVATION;
        } else if (value != NULL && strcmp(value, "point") == 0) {
            p->options.robust.distance = PGEM_DISTANCE_POINT;
        } else {
            fprintf(stderr, TOOL ": --distance takes innovation or point, got '%s'\n",
                    value != NULL ? value : "");
            return 0;
        }
        return 1;
    case KERNEL:
        if (!pgem_cli_parse_kernel(TOOL, value, &p->options.robust.kernel)) {
            return 0;
        }
        return 1;
    case DORMANT:
        if (value != NULL && strcmp(value, "off") == 0) {
            p->options.robust.dormant_threshold = -1.0;
            return 1;
        }
        return pgem_cli_parse_number(TOOL, name, value, 0, (double *)(void *)field);
    }
    return 0;
}

static int parse_flag(void *user, const char *name)
{
    parsed_t *p = user;
    if (strcmp(name, "--quiet") == 0) {
        p->quiet = 1;
    } else if (strcmp(name, "--journal-sync") == 0) {
        p->options.journal_sync = 1;
    } else if (strcmp(name, "--literal") == 0) {
        p->options.robust.literal = 1;
    } else if (strcmp(name, "--restart") == 0) {
        p->options.robust.restart = 1;
    } else if (strcmp(name, "--full") == 0) {
        p->options.full = 1;
    } else if (strcmp(name, "--incremental") == 0) {
        p->options.full = 0;
    } else if (strcmp(name, "--no-live-em") == 0) {
        p->options.no_live_em = 1;
    } else if (strcmp(name, "--compact") == 0) {
        p->options.compact = 1;
    } else if (strcmp(name, "--no-covariance") == 0) {
        p->options.no_covariance = 1;
    } else {
        return 0;
    }
    return 1;
}

/* Returns 0, -1 after --help, or PGEM_EXIT_USAGE. */
static int parse(int argc, char **argv, parsed_t *p)
{
    static const char *names[VALUED_COUNT];
    for (size_t v = 0; v < VALUED_COUNT; ++v) {
        names[v] = valued_options[v].name;
    }
    const pgem_cli_parser_t parser = {
        NULL, names, VALUED_COUNT, parse_value, parse_flag, NULL, usage, NULL, NULL};
    pgem_lcm_options_init(&p->lcm, TOOL, PGEM_LCM_ALL_CHANNELS);
    int status = pgem_lcm_parse_args(&p->lcm, &parser, p, argc, argv);
    if (status != 0) {
        return status;
    }
    pgem_bridge_options_t *o = &p->options;
    if (o->dimension == 0) {
        o->dimension = 2;
    }
    o->url = p->lcm.url;
    return pgem_lcm_channels(&p->lcm, o->dimension, &o->channels) == 0 ? 0 : PGEM_EXIT_USAGE;
}

int main(int argc, char **argv)
{
    parsed_t parsed;
    memset(&parsed, 0, sizeof parsed);
    int parsed_status = parse(argc, argv, &parsed);
    if (parsed_status != 0) {
        return parsed_status < 0 ? PGEM_EXIT_OK : PGEM_EXIT_USAGE;
    }
    if (!parsed.quiet) {
        parsed.options.log = log_line;
    }
    if (pgem_lcm_catch_signals(TOOL) != 0) {
        return PGEM_EXIT_FAILURE;
    }
    parsed.options.lcm = pgem_lcm_open(TOOL, parsed.lcm.url, PGEM_LCM_RECEIVE_BUFFER);
    if (parsed.options.lcm == NULL) {
        return PGEM_EXIT_FAILURE;
    }
    char message[1024];
    int status = pgem_bridge_run(&parsed.options, pgem_lcm_stop_signal, message, sizeof message);
    lcm_destroy(parsed.options.lcm);
    if (status != 0) {
        fprintf(stderr, TOOL ": %s\n", message);
        return PGEM_EXIT_FAILURE;
    }
    return PGEM_EXIT_OK;
}
