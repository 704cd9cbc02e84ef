/* Shared pieces of the LCM tools (pgem-lcm-bridge, pgem-lcm-send, pgem-lcm-dump): the common
 * options (--url, --channel-prefix, --*-channel), opening LCM, clocks, a clean stop on SIGINT
 * and SIGTERM, waiting for and dispatching messages, and status_t as text or JSON (files are
 * written with pgem_cli_file_t, whole or not at all). Every function that can fail prints "TOOL: what went wrong" to stderr,
 * where TOOL is the program name it is given. */
#ifndef PGEM_LCM_TOOL_H
#define PGEM_LCM_TOOL_H

#include <stdint.h>
#include <stdio.h>

#include <lcm/lcm.h>

#include "channels.h"
#include "cli.h"
#include "pgem_status_t.h"

/* ---- Common options --------------------------------------------------------------------- */

/* The per-channel options a tool takes (the `accepted` mask of pgem_lcm_options_init). */
#define PGEM_LCM_POSE_CHANNEL 0x01u    /* --pose-channel C */
#define PGEM_LCM_EDGE_CHANNEL 0x02u    /* --edge-channel C */
#define PGEM_LCM_GRAPH_CHANNEL 0x04u   /* --graph-channel C */
#define PGEM_LCM_STATUS_CHANNEL 0x08u  /* --status-channel C */
#define PGEM_LCM_COMMAND_CHANNEL 0x10u /* --command-channel C */
#define PGEM_LCM_COMPACTION_CHANNEL 0x20u /* --compaction-channel C */
#define PGEM_LCM_COVARIANCE_CHANNEL 0x40u /* --covariance-channel C */
#define PGEM_LCM_TEAM_CHANNEL 0x80u /* --team-channel C */
#define PGEM_LCM_ALL_CHANNELS 0xffu

/* The LCM options of one command line. NULL members mean "not given". */
typedef struct pgem_lcm_options {
    const char *tool;         /* program name for messages, e.g. "pgem-lcm-send" */
    unsigned accepted;        /* which --*-channel options the tool takes */
    const char *url;          /* --url URL; NULL: LCM's choice (LCM_DEFAULT_URL, else its
                                 built-in udpm default) */
    const char *prefix;       /* --channel-prefix P; NULL: PGEM_CHANNEL_PREFIX_DEFAULT */
    const char *pose;         /* --pose-channel ... --command-channel: a channel's own name */
    const char *edge;
    const char *graph;
    const char *status;
    const char *command;
    const char *compaction;
    const char *covariance;
    const char *team;
} pgem_lcm_options_t;

/* Clears *options for a tool that takes the channel options in `accepted`. */
void pgem_lcm_options_init(pgem_lcm_options_t *options, const char *tool, unsigned accepted);

/* Takes argv[*k] when it is --url, --channel-prefix or an accepted --*-channel option, with
 * its value (then *k is left on the value, so the caller's k++ moves past it). Returns 1 when
 * taken, 0 when argv[*k] is none of these (the caller goes on parsing), -1 after printing
 * "TOOL: OPTION needs a value" (a usage error). */
int pgem_lcm_parse_option(pgem_lcm_options_t *options, int argc, char **argv, int *k);

/* Prints the help lines of the common options, and of the accepted channel options. */
void pgem_lcm_options_help(FILE *out, const pgem_lcm_options_t *options);

/* The channel names for a dimension (2 or 3): every name from the prefix, then the names
 * given alone. Returns 0, or -1 after printing which name is invalid (empty, or longer than
 * LCM's 63 characters). */
int pgem_lcm_channels(const pgem_lcm_options_t *options, int dimension,
                      pgem_channels_t *channels);

/* The tools' one argument loop (pgem_cli_parse_args) with the LCM options first
 * (pgem_lcm_parse_option): -h/--help (help to stdout), then the tool's flags, valued options
 * and positional arguments; anything else is "TOOL: unknown option 'X' (see TOOL --help)".
 * parser holds the tool's own options; its tool, common and context are filled in here (the
 * context, which help gets, is options). Returns 0, -1 after --help, or PGEM_EXIT_USAGE after
 * a usage error was printed. */
int pgem_lcm_parse_args(pgem_lcm_options_t *options, const pgem_cli_parser_t *parser,
                        void *args, int argc, char **argv);

/* Parses a non-negative integer (decimal) for OPTION; prints "TOOL: OPTION needs a
 * non-negative integer, got 'TEXT'" and returns 0 on failure, else 1. */
int pgem_lcm_parse_u64(const char *tool, const char *option, const char *text,
                       uint64_t *value);

/* ---- LCM -------------------------------------------------------------------------------- */

/* The URL LCM will use for `url`: url itself, else $LCM_DEFAULT_URL, else LCM's default. */
const char *pgem_lcm_url_name(const char *url);

/* A kernel receive buffer that holds bursts of large messages (a 10000-pose graph_t is about
 * 700 KB; Linux's default buffer, about 200 KB, loses most of them). The kernel grants at most
 * net.core.rmem_max (LCM's multicast setup guide explains raising it). */
#define PGEM_LCM_RECEIVE_BUFFER (16 * 1024 * 1024)

/* lcm_create for url (NULL: LCM_DEFAULT_URL, else LCM's default). With receive_buffer > 0 and
 * a udpm:// URL that does not set recv_buf_size, asks for that many bytes of kernel receive
 * buffer, or net.core.rmem_max when that is less (recv_buf_size=N is added to the URL). On
 * failure prints "TOOL: cannot open LCM at URL (from where it came)" and returns NULL. */
lcm_t *pgem_lcm_open(const char *tool, const char *url, int receive_buffer);

/* Waits up to `seconds` (0: do not wait) for a message and dispatches it to its handlers with
 * lcm_handle. Returns 1 when a message was handled, 0 on timeout or when a signal interrupted
 * the wait, -1 after printing "TOOL: LCM receive failed: ...". */
int pgem_lcm_handle(const char *tool, lcm_t *lcm, double seconds);

/* Handles every message that is already there, without waiting. Returns how many were
 * handled, or -1 as pgem_lcm_handle. */
int pgem_lcm_drain(const char *tool, lcm_t *lcm);

/* ---- Clocks and signals ----------------------------------------------------------------- */

/* Wall-clock microseconds since the epoch, for the utime fields of the messages. (For
 * durations and deadlines use the monotonic pgem_cli_now, in seconds.) */
int64_t pgem_lcm_utime(void);

/* Sleeps until the monotonic time `deadline` (pgem_cli_now's clock, seconds). Returns 1 when
 * the deadline was reached, 0 when a stop was requested first (pgem_lcm_stop_signal). */
int pgem_lcm_sleep_until(double deadline);

/* Catches SIGINT and SIGTERM: the first one sets a flag (see pgem_lcm_stop_signal) and
 * interrupts blocking waits (no SA_RESTART); a second one of the same kind ends the process
 * at once with the default action. Returns 0, or -1 when sigaction failed (printed). */
int pgem_lcm_catch_signals(const char *tool);

/* The signal number that asked for a stop, or 0. */
int pgem_lcm_stop_signal(void);

/* ---- Output ----------------------------------------------------------------------------- */

/* A status_t as one JSON object (no newline): every field by its .lcm name, except reasons
 * and rejected, which become one object "rejected": {reason: count, ...}. */
void pgem_lcm_json_status(FILE *out, const pgem_status_t *status);

/* The total of status->rejected. */
int64_t pgem_lcm_status_rejected(const pgem_status_t *status);

/* A status_t in words, one line ending in a newline: "received R; accepted P poses, E edges;
 * R replays; rejected N (reason n, ...); pending P, queued Q; graph P poses, E edges, L loops
 * (X pruned); S solves". */
void pgem_lcm_print_status(FILE *out, const pgem_status_t *status);

#endif /* PGEM_LCM_TOOL_H */
