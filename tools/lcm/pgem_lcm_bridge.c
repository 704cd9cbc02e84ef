/* pgem-lcm-bridge: the robust back-end as an LCM service. */
#define _POSIX_C_SOURCE 200809L
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bridge.h"
#include "cli.h"
#include "lcm_tool.h"

#define TOOL "pgem-lcm-bridge"

static void usage(FILE *out, const pgem_lcm_options_t *lcm)
{
    fprintf(out,
            "usage: pgem-lcm-bridge [options]\n"
            "Receives poses and edges from front-ends over LCM, optimizes with EM when new loop\n"
            "closures arrive (or on command) and publishes the optimized graph and a status.\n"
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
            "  --debounce S           quiet time after a loop closure before solving (0.01)\n"
            "  --max-delay S          longest a loop closure waits while more arrive (0.1)\n"
            "  --max-rate HZ          solves per second at most (20)\n"
            "  --status-period S      seconds between status messages (0.5)\n"
            "  --idle-solve S         solve edges not yet solved (odometry only, say) after S\n"
            "                         seconds without new messages (0.5)\n"
            "  --robust-scale C       EM Cauchy scale (default 1)\n"
            "  --prune-threshold T    prune loop closures with weight below T (default 0.01)\n"
            "  --m-step-iterations N  Gauss-Newton iterations per M-step (default 1)\n"
            "  --max-em-iterations N  E/M iterations per round (default 5)\n"
            "  --gate G               consistency-test chi2 threshold (default 99.9%% quantile)\n"
            "  --literal              the paper's EM as published (no polish or gate)\n"
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

static int parse_u32_option(const char *name, const char *value, uint32_t *out)
{
    return pgem_cli_parse_u32(name, value, out) ? 0 : -1;
}

static int parse_number_option(const char *name, const char *value, int strict, double *out)
{
    return pgem_cli_parse_number(TOOL, name, value, strict, out) ? 0 : -1;
}

/* One option with a value; returns 0, or -1 after printing why. */
static int parse_valued(parsed_t *p, const char *name, const char *value)
{
    pgem_bridge_options_t *o = &p->options;
    uint32_t dimension = 0;
    if (strcmp(name, "--dimension") == 0) {
        if (parse_u32_option(name, value, &dimension) != 0 || (dimension != 2 && dimension != 3)) {
            fprintf(stderr, TOOL ": --dimension takes 2 or 3, got '%s'\n", value);
            return -1;
        }
        o->dimension = (int)dimension;
    } else if (strcmp(name, "--max-poses") == 0) {
        return parse_u32_option(name, value, &o->max_poses);
    } else if (strcmp(name, "--max-edges") == 0) {
        return parse_u32_option(name, value, &o->max_edges);
    } else if (strcmp(name, "--fill-budget") == 0) {
        return parse_u32_option(name, value, &o->fill_budget);
    } else if (strcmp(name, "--max-pending") == 0) {
        return parse_u32_option(name, value, &o->max_pending);
    } else if (strcmp(name, "--max-sources") == 0) {
        return parse_u32_option(name, value, &o->max_sources);
    } else if (strcmp(name, "--journal") == 0) {
        o->journal = value;
    } else if (strcmp(name, "--debounce") == 0) {
        return parse_number_option(name, value, 1, &o->debounce);
    } else if (strcmp(name, "--max-delay") == 0) {
        return parse_number_option(name, value, 1, &o->max_delay);
    } else if (strcmp(name, "--max-rate") == 0) {
        return parse_number_option(name, value, 1, &o->max_rate);
    } else if (strcmp(name, "--status-period") == 0) {
        return parse_number_option(name, value, 1, &o->status_period);
    } else if (strcmp(name, "--idle-solve") == 0) {
        return parse_number_option(name, value, 1, &o->idle_solve);
    } else if (strcmp(name, "--robust-scale") == 0) {
        return parse_number_option(name, value, 1, &o->robust.scale);
    } else if (strcmp(name, "--prune-threshold") == 0) {
        return parse_number_option(name, value, 1, &o->robust.prune_threshold);
    } else if (strcmp(name, "--m-step-iterations") == 0) {
        return pgem_cli_parse_at_least(TOOL, name, value, 1, "iteration",
                                       &o->robust.m_step_iterations) ? 0 : -1;
    } else if (strcmp(name, "--max-em-iterations") == 0) {
        return pgem_cli_parse_at_least(TOOL, name, value, 1, "iteration",
                                       &o->robust.max_em_iterations) ? 0 : -1;
    } else if (strcmp(name, "--gate") == 0) {
        return parse_number_option(name, value, 1, &o->robust.gate);
    } else {
        fprintf(stderr, TOOL ": unknown option '%s' (see --help)\n", name);
        return -1;
    }
    return 0;
}

static int parse(int argc, char **argv, parsed_t *p)
{
    pgem_lcm_options_init(&p->lcm, TOOL, PGEM_LCM_ALL_CHANNELS);
    for (int i = 1; i < argc; ++i) {
        const char *arg = argv[i];
        int common = pgem_lcm_parse_option(&p->lcm, argc, argv, &i);
        if (common != 0) {
            if (common < 0) {
                return -1;
            }
            continue;
        }
        if (strcmp(arg, "--help") == 0 || strcmp(arg, "-h") == 0) {
            usage(stdout, &p->lcm);
            exit(PGEM_EXIT_OK);
        } else if (strcmp(arg, "--quiet") == 0) {
            p->quiet = 1;
        } else if (strcmp(arg, "--journal-sync") == 0) {
            p->options.journal_sync = 1;
        } else if (strcmp(arg, "--literal") == 0) {
            p->options.robust.literal = 1;
        } else if (strncmp(arg, "--", 2) == 0 && i + 1 < argc) {
            if (parse_valued(p, arg, argv[++i]) != 0) {
                return -1;
            }
        } else {
            fprintf(stderr, TOOL ": %s '%s' (see --help)\n",
                    strncmp(arg, "--", 2) == 0 ? "missing value for" : "unexpected argument",
                    arg);
            return -1;
        }
    }
    pgem_bridge_options_t *o = &p->options;
    if (o->dimension == 0) {
        o->dimension = 2;
    }
    o->url = p->lcm.url;
    return pgem_lcm_channels(&p->lcm, o->dimension, &o->channels);
}

int main(int argc, char **argv)
{
    parsed_t parsed;
    memset(&parsed, 0, sizeof parsed);
    if (parse(argc, argv, &parsed) != 0) {
        return PGEM_EXIT_USAGE;
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
