/* Shared pieces of the LCM tools: common options, LCM set-up and dispatch, clocks, signals,
 * atomic files and status_t output. */
#define _POSIX_C_SOURCE 200809L
#include "lcm_tool.h"

#include <errno.h>
#include <math.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cli.h"
#include "utf8.h"

/* LCM's own default when neither a URL nor LCM_DEFAULT_URL is given (lcm.h, LCM 1.3). */
#define PGEM_LCM_BUILTIN_URL "udpm://239.255.76.67:7667?ttl=0"

/* ---- Common options --------------------------------------------------------------------- */

/* One --*-channel option: its name, its bit in the mask and its help text. */
typedef struct pgem_lcm_channel_option {
    const char *name;
    unsigned bit;
    const char *help;
} pgem_lcm_channel_option_t;

static const pgem_lcm_channel_option_t pgem_lcm_channel_options[] = {
    {"--pose-channel", PGEM_LCM_POSE_CHANNEL, "pose channel (default: PREFIX + POSE2 or POSE3)"},
    {"--edge-channel", PGEM_LCM_EDGE_CHANNEL, "edge channel (default: PREFIX + EDGE2 or EDGE3)"},
    {"--graph-channel", PGEM_LCM_GRAPH_CHANNEL, "graph channel (default: PREFIX + GRAPH)"},
    {"--status-channel", PGEM_LCM_STATUS_CHANNEL, "status channel (default: PREFIX + STATUS)"},
    {"--command-channel", PGEM_LCM_COMMAND_CHANNEL,
     "command channel (default: PREFIX + COMMAND)"},
    {"--compaction-channel", PGEM_LCM_COMPACTION_CHANNEL,
     "compaction channel (default: PREFIX + COMPACTION)"},
    {"--covariance-channel", PGEM_LCM_COVARIANCE_CHANNEL,
     "covariance channel (default: PREFIX + COVARIANCE)"},
    {"--team-channel", PGEM_LCM_TEAM_CHANNEL, "team channel (default: PREFIX + TEAM)"},
};

#define PGEM_LCM_CHANNEL_OPTIONS \
    (sizeof pgem_lcm_channel_options / sizeof pgem_lcm_channel_options[0])

/* The member of *options that holds the name given by the option with this bit. */
static const char **pgem_lcm_channel_member(pgem_lcm_options_t *options, unsigned bit)
{
    switch (bit) {
    case PGEM_LCM_POSE_CHANNEL:
        return &options->pose;
    case PGEM_LCM_EDGE_CHANNEL:
        return &options->edge;
    case PGEM_LCM_GRAPH_CHANNEL:
        return &options->graph;
    case PGEM_LCM_STATUS_CHANNEL:
        return &options->status;
    case PGEM_LCM_COMPACTION_CHANNEL:
        return &options->compaction;
    case PGEM_LCM_COVARIANCE_CHANNEL:
        return &options->covariance;
    case PGEM_LCM_TEAM_CHANNEL:
        return &options->team;
    default:
        return &options->command;
    }
}

void pgem_lcm_options_init(pgem_lcm_options_t *options, const char *tool, unsigned accepted)
{
    memset(options, 0, sizeof *options);
    options->tool = tool;
    options->accepted = accepted;
}

int pgem_lcm_parse_option(pgem_lcm_options_t *options, int argc, char **argv, int *k)
{
    const char *arg = argv[*k];
    const char **target = NULL;
    if (strcmp(arg, "--url") == 0) {
        target = &options->url;
    } else if (strcmp(arg, "--channel-prefix") == 0) {
        target = &options->prefix;
    }
    for (size_t c = 0; target == NULL && c < PGEM_LCM_CHANNEL_OPTIONS; c++) {
        const pgem_lcm_channel_option_t *option = &pgem_lcm_channel_options[c];
        if ((options->accepted & option->bit) != 0u && strcmp(arg, option->name) == 0) {
            target = pgem_lcm_channel_member(options, option->bit);
        }
    }
    if (target == NULL) {
        return 0;
    }
    if (*k + 1 >= argc) {
        fprintf(stderr, "%s: %s needs a value\n", options->tool, arg);
        return -1;
    }
    *target = argv[++*k];
    return 1;
}

void pgem_lcm_options_help(FILE *out, const pgem_lcm_options_t *options)
{
    fprintf(out, "  %-22s LCM URL (default: $LCM_DEFAULT_URL, else\n"
                 "  %-22s %s)\n", "--url URL", "", PGEM_LCM_BUILTIN_URL);
    fprintf(out, "  %-22s channel names are P + POSE2, EDGE2, GRAPH, STATUS, ...\n"
                 "  %-22s (default %s)\n", "--channel-prefix P", "", PGEM_CHANNEL_PREFIX_DEFAULT);
    for (size_t c = 0; c < PGEM_LCM_CHANNEL_OPTIONS; c++) {
        const pgem_lcm_channel_option_t *option = &pgem_lcm_channel_options[c];
        if ((options->accepted & option->bit) != 0u) {
            char label[32];
            snprintf(label, sizeof label, "%s C", option->name);
            fprintf(out, "  %-22s %s\n", label, option->help);
        }
    }
}

int pgem_lcm_channels(const pgem_lcm_options_t *options, int dimension,
                      pgem_channels_t *channels)
{
    if (pgem_channels_init(channels, options->prefix, dimension) != 0) {
        fprintf(stderr, "%s: --channel-prefix '%s' is too long (channel names have at most 63 "
                        "characters)\n", options->tool, options->prefix);
        return -1;
    }
    const struct {
        const char *value;
        char *name;
        const char *option;
    } alone[] = {
        {options->pose, channels->pose, "--pose-channel"},
        {options->edge, channels->edge, "--edge-channel"},
        {options->graph, channels->graph, "--graph-channel"},
        {options->status, channels->status, "--status-channel"},
        {options->command, channels->command, "--command-channel"},
        {options->compaction, channels->compaction, "--compaction-channel"},
        {options->covariance, channels->covariance, "--covariance-channel"},
        {options->team, channels->team, "--team-channel"},
    };
    for (size_t c = 0; c < sizeof alone / sizeof alone[0]; c++) {
        if (alone[c].value != NULL && pgem_channel_set(alone[c].name, alone[c].value) != 0) {
            fprintf(stderr, "%s: %s needs a name of 1 to 63 characters, got '%s'\n",
                    options->tool, alone[c].option, alone[c].value);
            return -1;
        }
    }
    return 0;
}

static int lcm_common_option(void *context, int argc, char **argv, int *k)
{
    return pgem_lcm_parse_option((pgem_lcm_options_t *)context, argc, argv, k);
}

int pgem_lcm_parse_args(pgem_lcm_options_t *options, const pgem_cli_parser_t *parser,
                        void *args, int argc, char **argv)
{
    pgem_cli_parser_t cli = *parser;
    cli.tool = options->tool;
    cli.common = lcm_common_option;
    cli.context = options;
    return pgem_cli_parse_args(&cli, args, argc, argv);
}

int pgem_lcm_parse_u64(const char *tool, const char *option, const char *text, uint64_t *value)
{
    char *end = NULL;
    errno = 0;
    unsigned long long parsed = 0;
    if (text != NULL && text[0] >= '0' && text[0] <= '9') {
        parsed = strtoull(text, &end, 10);
    }
    if (end == NULL || *end != '\0' || errno != 0) {
        fprintf(stderr, "%s: %s needs a non-negative integer, got '%s'\n", tool, option,
                text != NULL ? text : "");
        return 0;
    }
    *value = (uint64_t)parsed;
    return 1;
}

/* ---- LCM -------------------------------------------------------------------------------- */

const char *pgem_lcm_url_name(const char *url)
{
    if (url != NULL) {
        return url;
    }
    const char *environment = getenv("LCM_DEFAULT_URL");
    return environment != NULL && environment[0] != '\0' ? environment : PGEM_LCM_BUILTIN_URL;
}

/* The largest receive buffer the kernel grants (Linux: net.core.rmem_max), or `wanted` when
 * that cannot be read; never more than `wanted`. Asking for more makes LCM warn. */
static int pgem_lcm_receive_limit(int wanted)
{
    FILE *limit = fopen("/proc/sys/net/core/rmem_max", "r");
    long most = 0;
    if (limit == NULL) {
        return wanted;
    }
    if (fscanf(limit, "%ld", &most) != 1 || most <= 0) {
        most = wanted;
    }
    fclose(limit);
    return most < wanted ? (int)most : wanted;
}

lcm_t *pgem_lcm_open(const char *tool, const char *url, int receive_buffer)
{
    const char *chosen = pgem_lcm_url_name(url);
    receive_buffer = receive_buffer > 0 ? pgem_lcm_receive_limit(receive_buffer) : 0;
    char *sized = NULL;
    if (receive_buffer > 0 && strncmp(chosen, "udpm://", 7) == 0 &&
        strstr(chosen, "recv_buf_size=") == NULL) {
        size_t length = strlen(chosen) + 40u;
        sized = malloc(length);
        if (sized != NULL) {
            snprintf(sized, length, "%s%crecv_buf_size=%d", chosen,
                     strchr(chosen, '?') != NULL ? '&' : '?', receive_buffer);
        }
    }
    lcm_t *lcm = lcm_create(sized != NULL ? sized : url);
    free(sized);
    if (lcm == NULL) {
        const char *environment = getenv("LCM_DEFAULT_URL");
        const char *origin = url != NULL ? "--url"
                             : environment != NULL && environment[0] != '\0'
                                 ? "LCM_DEFAULT_URL"
                                 : "LCM's default";
        fprintf(stderr, "%s: cannot open LCM at %s (from %s)\n", tool, pgem_lcm_url_name(url),
                origin);
    }
    return lcm;
}

int pgem_lcm_handle(const char *tool, lcm_t *lcm, double seconds)
{
    struct pollfd ready = {lcm_get_fileno(lcm), POLLIN, 0};
    int milliseconds = 0;
    if (seconds > 0.0) {
        milliseconds = seconds > 86400.0 ? 86400000 : (int)ceil(seconds * 1000.0);
    }
    int status = poll(&ready, 1, milliseconds);
    if (status < 0 && errno == EINTR) {
        return 0;
    }
    if (status < 0) {
        fprintf(stderr, "%s: LCM receive failed: poll: %s\n", tool, strerror(errno));
        return -1;
    }
    if (status == 0) {
        return 0;
    }
    if (lcm_handle(lcm) != 0) {
        fprintf(stderr, "%s: LCM receive failed (lcm_handle)\n", tool);
        return -1;
    }
    return 1;
}

int pgem_lcm_drain(const char *tool, lcm_t *lcm)
{
    int handled = 0, status;
    while ((status = pgem_lcm_handle(tool, lcm, 0.0)) > 0) {
        handled++;
    }
    return status < 0 ? -1 : handled;
}

/* ---- Clocks and signals ----------------------------------------------------------------- */

int64_t pgem_lcm_utime(void)
{
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    return (int64_t)now.tv_sec * 1000000 + (int64_t)(now.tv_nsec / 1000);
}

static volatile sig_atomic_t pgem_lcm_stop = 0;

static void pgem_lcm_on_signal(int number)
{
    pgem_lcm_stop = number;
}

int pgem_lcm_sleep_until(double deadline)
{
    double whole = floor(deadline);
    struct timespec until = {(time_t)whole, (long)((deadline - whole) * 1e9)};
    if (until.tv_nsec > 999999999L) {
        until.tv_nsec = 999999999L;
    }
    while (pgem_lcm_stop == 0) {
        int status = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &until, NULL);
        if (status != EINTR) {
            return 1; /* reached (or an error, which only a bad deadline could cause) */
        }
    }
    return 0;
}

int pgem_lcm_catch_signals(const char *tool)
{
    struct sigaction action;
    memset(&action, 0, sizeof action);
    action.sa_handler = pgem_lcm_on_signal;
    action.sa_flags = SA_RESETHAND; /* a second signal of the same kind takes the default */
    sigemptyset(&action.sa_mask);
    if (sigaction(SIGINT, &action, NULL) != 0 || sigaction(SIGTERM, &action, NULL) != 0) {
        fprintf(stderr, "%s: sigaction: %s\n", tool, strerror(errno));
        return -1;
    }
    return 0;
}

int pgem_lcm_stop_signal(void)
{
    return (int)pgem_lcm_stop;
}

/* ---- Output ----------------------------------------------------------------------------- */

int64_t pgem_lcm_status_rejected(const pgem_status_t *status)
{
    int64_t total = 0;
    for (int32_t r = 0; r < status->num_reasons; r++) {
        total += status->rejected[r];
    }
    return total;
}

void pgem_lcm_json_status(FILE *out, const pgem_status_t *s)
{
    fprintf(out, "{\"utime\":%lld,\"dimension\":%d,\"received\":%lld,\"accepted_poses\":%lld,"
                 "\"accepted_edges\":%lld,\"replays\":%lld,\"rejected\":{",
            (long long)s->utime, (int)s->dimension, (long long)s->received,
            (long long)s->accepted_poses, (long long)s->accepted_edges, (long long)s->replays);
    for (int32_t r = 0; r < s->num_reasons; r++) {
        fputs(r > 0 ? "," : "", out);
        pgem_json_string(out, s->reasons[r] != NULL ? s->reasons[r] : "");
        fprintf(out, ":%lld", (long long)s->rejected[r]);
    }
    fprintf(out, "},\"pending\":%d,\"queued\":%d,\"poses\":%d,\"edges\":%d,\"loops\":%d,"
                 "\"pruned\":%d,\"max_poses\":%d,\"max_edges\":%d,\"max_pending\":%d,"
                 "\"solves\":%lld,\"solving\":%s,\"commands\":%lld,\"journal_records\":%lld,"
                 "\"recovered\":%lld,\"message\":",
            (int)s->pending, (int)s->queued, (int)s->poses, (int)s->edges, (int)s->loops,
            (int)s->pruned, (int)s->max_poses, (int)s->max_edges, (int)s->max_pending,
            (long long)s->solves, s->solving ? "true" : "false", (long long)s->commands,
            (long long)s->journal_records, (long long)s->recovered);
    pgem_json_string(out, s->message != NULL ? s->message : "");
    fputc('}', out);
}

void pgem_lcm_print_status(FILE *out, const pgem_status_t *s)
{
    fprintf(out, "received %lld; accepted %lld poses, %lld edges; %lld replays; rejected %lld",
            (long long)s->received, (long long)s->accepted_poses, (long long)s->accepted_edges,
            (long long)s->replays, (long long)pgem_lcm_status_rejected(s));
    const char *separator = " (";
    for (int32_t r = 0; r < s->num_reasons; r++) {
        if (s->rejected[r] != 0) {
            char reason[64]; /* from the network: escaped */
            pgem_utf8_escape(reason, sizeof reason, s->reasons[r] != NULL ? s->reasons[r] : "?");
            fprintf(out, "%s%s %lld", separator, reason, (long long)s->rejected[r]);
            separator = ", ";
        }
    }
    fprintf(out, "%s; pending %d, queued %d; graph %d poses, %d edges, %d loops (%d pruned); "
                 "%lld solves%s\n",
            separator[0] == ',' ? ")" : "", (int)s->pending, (int)s->queued, (int)s->poses,
            (int)s->edges, (int)s->loops, (int)s->pruned, (long long)s->solves,
            s->solving ? ", solving" : "");
}
