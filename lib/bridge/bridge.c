/* The bridge's two threads: reception (LCM handlers: ingest, journal, queue) and the solver
 * (drain the queue into the core, decide when to solve, publish). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bridge_internal.h"
#include "pgem_command_t.h"

#define DEFAULT_MAX_POSES 20000u
#define DEFAULT_EDGES_PER_POSE 4u
#define BATCH 256
#define LCM_QUEUE_CAPACITY 100000 /* messages LCM may hold for a handler */
#define REJECTIONS_LOGGED 20      /* then one line per 1000 */
#define OPTIMIZE_INTERVAL 1.0     /* s from the end of a command solve to the next (issue 31) */

void pgem_bridge_defaults(pgem_bridge_options_t *options)
{
    if (options->dimension != 3) {
        options->dimension = 2;
    }
    if (options->channels.pose[0] == '\0') {
        pgem_channels_init(&options->channels, NULL, options->dimension);
    }
    if (options->max_poses == 0) {
        options->max_poses = DEFAULT_MAX_POSES;
    }
    if (options->max_edges == 0) {
        options->max_edges = DEFAULT_EDGES_PER_POSE * options->max_poses;
    }
    pgem_ingest_config_t ingest = {options->dimension, options->max_poses, options->max_edges,
                                   options->max_pending, options->max_sources, 0, 0, 0};
    pgem_ingest_config_resolve(&ingest);
    options->max_pending = ingest.max_pending;
    options->max_sources = ingest.max_sources;
    if (!(options->pending_timeout > 0.0)) {
        options->pending_timeout = (double)PGEM_PENDING_TIMEOUT_DEFAULT * 1e-6;
    }
    if (!(options->debounce > 0.0)) {
        options->debounce = 0.01;
    }
    if (!(options->max_rate > 0.0)) {
        options->max_rate = 20.0;
    }
    if (!(options->max_delay > 0.0)) {
        options->max_delay = 0.1;
    }
    if (!(options->status_period > 0.0)) {
        options->status_period = 0.5;
    }
    if (!(options->idle_solve > 0.0)) {
        options->idle_solve = 0.5;
    }
    if (options->snapshot_limit == 0) {
        options->snapshot_limit = BRIDGE_SNAPSHOT_LIMIT;
    }
    if (!(options->snapshot_budget > 0.0)) {
        options->snapshot_budget = BRIDGE_SNAPSHOT_BUDGET;
    }
}

/* ---- the queue (L held) ------------------------------------------------------------------- */

static void emit(void *user, const pgem_item_t *item)
{
    bridge_t *bridge = user;
    if (bridge->tail - bridge->head >= bridge->queue_capacity) {
        bridge->queue_overflows++; /* cannot happen: capacity is reserved on admission */
        return;
    }
    bridge->queue[bridge->tail % bridge->queue_capacity] = *item;
    bridge->tail++;
}

/* ---- reception thread --------------------------------------------------------------------- */

static pgem_role_t role_of_channel(const bridge_t *bridge, const char *channel)
{
    const pgem_channels_t *c = &bridge->options.channels;
    if (strcmp(channel, c->pose) == 0) {
        return PGEM_ROLE_POSE;
    }
    if (strcmp(channel, c->edge) == 0) {
        return PGEM_ROLE_EDGE;
    }
    return PGEM_ROLE_COMMAND;
}

static void log_rejection(bridge_t *bridge, const pgem_ingest_result_t *result)
{
    bridge->rejections_logged++;
    if (bridge->rejections_logged <= REJECTIONS_LOGGED) {
        bridge_log(bridge, "rejected (%s): %s", pgem_reject_name(result->reason),
                   result->message);
    } else if (bridge->rejections_logged % 1000 == 0) {
        bridge_log(bridge, "%lld messages rejected so far (latest, %s: %s)",
                   (long long)bridge->rejections_logged, pgem_reject_name(result->reason),
                   result->message);
    }
}

/* The ingest's admit hook: a message that would change the graph is journaled before anything
 * changes, so what the status acknowledges is always in the journal, and a message the journal
 * cannot take (a full disk, an I/O error) is refused and changes nothing: the front-end's
 * resend is accepted once the journal has room. Called from pgem_ingest_message with L held;
 * the write runs without it (nothing of the ingest changes meanwhile: this thread is its only
 * writer, and the solver only reads source names and the queue's visible part). */
static int journal_admit(void *user, const void *data, size_t size, char *message,
                         size_t message_size)
{
    bridge_t *bridge = user;
    pthread_mutex_unlock(&bridge->lock);
    int status = pgem_journal_append(bridge->journal, bridge->channel, data, size, bridge->utime,
                                     message, message_size);
    pthread_mutex_lock(&bridge->lock);
    return status;
}

/* Edges that expired (waited too long for their poses, or made room in a full list), from
 * count `before` to `after`: the latest is noted while fewer than 20 have expired, then once
 * per thousand, like rejections. */
static void log_expiries(bridge_t *bridge, int64_t before, int64_t after, const char *latest)
{
    if (after <= before) {
        return;
    }
    int64_t first = bridge->expiries_logged + 1;
    bridge->expiries_logged += after - before;
    int64_t last = bridge->expiries_logged;
    if (first <= REJECTIONS_LOGGED || last / 1000 > (first - 1) / 1000) {
        bridge_note(bridge, "%s%s", latest, after - before > 1 ? " (and earlier ones)" : "");
    }
}

/* Edges sent as ODOMETRY that entered the graph as loop closures (not a step of the chain),
 * from count `before` to `after`: noted (status and log) while fewer than 20 have, then once
 * per thousand. */
static void log_odometry_notes(bridge_t *bridge, int64_t before, int64_t after,
                               const char *latest)
{
    if (after <= before) {
        return;
    }
    int64_t first = bridge->odometry_notes_logged + 1;
    bridge->odometry_notes_logged += after - before;
    int64_t last = bridge->odometry_notes_logged;
    if (first <= REJECTIONS_LOGGED || last / 1000 > (first - 1) / 1000) {
        bridge_note(bridge, "%s (%lld so far)", latest, (long long)last);
    }
}

/* Expires what has waited too long by now, for a bridge that receives nothing (the ingest
 * does it at every message otherwise). Takes L. */
static void expire_quietly(bridge_t *bridge)
{
    char latest[sizeof bridge->last_message] = "";
    pthread_mutex_lock(&bridge->lock);
    int64_t before = bridge->counts.rejected[PGEM_REJECT_EXPIRED];
    if (pgem_ingest_expire(bridge->ingest, bridge_utime()) > 0) {
        pgem_ingest_counts(bridge->ingest, &bridge->counts);
        snprintf(latest, sizeof latest, "%s", pgem_ingest_last_expiry(bridge->ingest));
    }
    int64_t after = bridge->counts.rejected[PGEM_REJECT_EXPIRED];
    pthread_mutex_unlock(&bridge->lock);
    log_expiries(bridge, before, after, latest);
}

static void on_message(const lcm_recv_buf_t *buffer, const char *channel, void *user)
{
    bridge_t *bridge = user;
    pgem_ingest_result_t result;
    pgem_role_t role = role_of_channel(bridge, channel);
    char latest[sizeof bridge->last_message] = "";
    char odometry_note[sizeof bridge->last_message] = "";
    pthread_mutex_lock(&bridge->lock);
    int64_t expired = bridge->counts.rejected[PGEM_REJECT_EXPIRED];
    int64_t as_loops = bridge->counts.odometry_as_loops;
    bridge->channel = channel;
    bridge->utime = buffer->recv_utime;
    pgem_ingest_message(bridge->ingest, role, buffer->data, buffer->data_size,
                        buffer->recv_utime, &result);
    bridge->visible = bridge->tail;
    pgem_ingest_counts(bridge->ingest, &bridge->counts);
    if (bridge->journal != NULL) {
        bridge->journal_records = pgem_journal_records(bridge->journal);
    }
    if (bridge->counts.rejected[PGEM_REJECT_EXPIRED] > expired) {
        snprintf(latest, sizeof latest, "%s", pgem_ingest_last_expiry(bridge->ingest));
    }
    int64_t as_loops_now = bridge->counts.odometry_as_loops;
    if (as_loops_now > as_loops) {
        snprintf(odometry_note, sizeof odometry_note, "%s",
                 pgem_ingest_last_odometry_note(bridge->ingest));
    }
    if (result.verdict == PGEM_VERDICT_REJECTED) {
        snprintf(bridge->last_message, sizeof bridge->last_message, "rejected (%s): %.340s",
                 pgem_reject_name(result.reason), result.message);
    } else if (result.verdict == PGEM_VERDICT_COMMAND) {
        if (result.command == PGEM_COMMAND_T_OPTIMIZE) {
            bridge->optimize_requested = 1;
            bridge->optimize_commands++;
        } else if (result.command == PGEM_COMMAND_T_SNAPSHOT) {
            bridge->snapshot_requested = 1;
            memcpy(bridge->snapshot_path, result.path, sizeof bridge->snapshot_path);
        }
    }
    pthread_cond_signal(&bridge->wake);
    int64_t expired_now = bridge->counts.rejected[PGEM_REJECT_EXPIRED];
    pthread_mutex_unlock(&bridge->lock);

    log_expiries(bridge, expired, expired_now, latest);
    log_odometry_notes(bridge, as_loops, as_loops_now, odometry_note);
    if (result.verdict == PGEM_VERDICT_REJECTED) {
        log_rejection(bridge, &result);
    } else if (result.verdict == PGEM_VERDICT_COMMAND) {
        static const char *const names[] = {"", "OPTIMIZE", "RESET", "SNAPSHOT"};
        bridge_log(bridge, "command %s%s%s", names[result.command],
                   result.path[0] != '\0' ? " " : "", result.path);
    }
}

/* A journal record, replayed at start through the same ingest (no admit hook: it is in the
 * journal). Refusals are counted by reason and the first 20 logged; start() decides. */
static void on_journal_record(void *user, const char *channel, const void *data, size_t size,
                              int64_t utime)
{
    (void)channel;
    bridge_t *bridge = user;
    pgem_ingest_result_t result;
    pgem_ingest_message(bridge->ingest, PGEM_ROLE_ANY, data, size, utime, &result);
    if (result.verdict != PGEM_VERDICT_REJECTED) {
        return;
    }
    int64_t refused = 0;
    for (int r = 0; r < PGEM_REJECT_COUNT; ++r) {
        refused += bridge->replay_refused[r];
    }
    bridge->replay_refused[result.reason]++;
    if (refused == 0) {
        snprintf(bridge->replay_first, sizeof bridge->replay_first, "%s: %.320s",
                 pgem_reject_name(result.reason), result.message);
    }
    if (refused < REJECTIONS_LOGGED) {
        bridge_log(bridge, "journal record refused on replay (%s): %s",
                   pgem_reject_name(result.reason), result.message);
    }
}

/* ---- solver thread ------------------------------------------------------------------------ */

typedef struct schedule {
    int unsolved;         /* items added since the last solve */
    double last_item;     /* when the latest item was added */
    int dirty;            /* loop closures arrived since the last solve */
    double first_loop;    /* arrival of the first of them */
    double last_loop;     /* and of the latest */
    double last_start;    /* start of the last solve */
    double last_end;      /* and its end */
    int unsettled;        /* the last solve was incremental: a settle solve is owed */
    int stepped;          /* incremental: edges applied since the last update */
    const char *trigger;
    int command;          /* an OPTIMIZE waits for its whole-graph solve */
    double command_at;    /* not before: OPTIMIZE_INTERVAL after the last command solve */
    double command_end;   /* when the last command solve ended */
} schedule_t;

/* When the pending loop closures are to be solved: with full solves, after the debounce quiet
 * time, but no later than max_delay after the first of them, and never sooner than 1 / max_rate
 * after the last solve started; with incremental updates, at once. */
static double solve_due(const bridge_t *bridge, const schedule_t *s)
{
    const pgem_bridge_options_t *o = &bridge->options;
    if (!o->full && (s->dirty || s->unsolved)) {
        return 0.0; /* incremental updates: at once, for every batch of items */
    }
    if (s->command && !(s->dirty || s->unsolved || s->unsettled)) {
        return s->command_at; /* OPTIMIZE alone */
    }
    double due = s->dirty      ? fmin(s->last_loop + o->debounce, s->first_loop + o->max_delay)
                 : s->unsolved ? s->last_item + o->idle_solve
                               : fmax(s->last_item, s->last_end) + o->idle_solve; /* settle */
    return fmax(due, s->last_start + 1.0 / o->max_rate);
}

static int solve_owed(const schedule_t *s)
{
    return s->dirty || s->unsolved || s->unsettled || s->command;
}

static void wait_until(bridge_t *bridge, double when)
{
    double delay = when - bridge_now();
    if (delay <= 0) {
        return;
    }
    struct timespec deadline;
    clock_gettime(CLOCK_MONOTONIC, &deadline);
    double whole = floor(delay);
    deadline.tv_sec += (time_t)whole;
    deadline.tv_nsec += (long)((delay - whole) * 1e9);
    if (deadline.tv_nsec >= 1000000000L) {
        deadline.tv_sec++;
        deadline.tv_nsec -= 1000000000L;
    }
    pthread_cond_timedwait(&bridge->wake, &bridge->lock, &deadline);
}

/* Waits (L held) until there is work: items, a request, a due solve, or the stop. */
static void wait_for_work(bridge_t *bridge, const schedule_t *s)
{
    while (!bridge->stopping && bridge->visible == bridge->head && !bridge->optimize_requested &&
           !bridge->snapshot_requested && bridge->pass.state != BRIDGE_PASS_DONE) {
        const double pass_due = bridge_graph_pass_due(bridge);
        if (solve_owed(s) || isfinite(pass_due)) {
            const double due = fmin(solve_owed(s) ? solve_due(bridge, s) : (double)INFINITY, pass_due);
            if (bridge_now() >= due) {
                return;
            }
            wait_until(bridge, due);
        } else {
            pthread_cond_wait(&bridge->wake, &bridge->lock);
        }
    }
}

static void *solver_main(void *user)
{
    bridge_t *bridge = user;
    schedule_t s;
    memset(&s, 0, sizeof s);
    s.last_start = -1e300;
    s.command_end = -1e300;
    pgem_item_t batch[BATCH];
    for (;;) {
        pthread_mutex_lock(&bridge->lock);
        wait_for_work(bridge, &s);
        if (bridge->stopping) {
            pthread_mutex_unlock(&bridge->lock);
            break;
        }
        int count = 0;
        while (count < BATCH && bridge->head < bridge->visible) {
            batch[count++] = bridge->queue[bridge->head % bridge->queue_capacity];
            bridge->head++;
        }
        int drained = bridge->head == bridge->visible;
        /* Behind: more than a batch waits. Then the batch's poses are stepped once, at its
         * end, not one by one: a solver thread that falls behind a burst (a dense graph, a
         * loaded machine) catches up instead of the queue outgrowing its room. */
        const int behind = bridge->visible - bridge->head > BATCH;
        int optimize = bridge->optimize_requested; /* taken below when due */
        int recovery = bridge->recovery_pending && drained;
        const int replaying = bridge->recovery_pending; /* one full solve follows: no steps */
        int snapshot = bridge->snapshot_requested && drained;
        char path[PGEM_PATH_MAX];
        if (snapshot) {
            memcpy(path, bridge->snapshot_path, sizeof path);
            bridge->snapshot_requested = 0;
        }
        bridge->optimize_requested = 0;
        if (recovery) {
            bridge->recovery_pending = 0;
        }
        pthread_mutex_unlock(&bridge->lock);

        double now = bridge_now();
        if (count > 0) {
            s.unsolved = 1;
            s.last_item = now;
        }
        /* OPTIMIZE is one whole-graph solve on command, not one per message: while one waits,
         * later ones merge into it, and it runs no sooner than OPTIMIZE_INTERVAL after the
         * last command solve ended (issue 31: a 10 Hz flood had the solver re-solve the
         * whole graph without pause). */
        if (optimize && !s.command) {
            s.command = 1;
            s.command_at = fmax(now, s.command_end + OPTIMIZE_INTERVAL);
        }
        optimize = s.command && now >= s.command_at;
        for (int i = 0; i < count; ++i) {
            if (!bridge->options.full && !replaying && !behind && s.stepped &&
                batch[i].type == PGEM_ITEM_POSE) {
                bridge_graph_step(bridge); /* the edges of the poses before this one */
                s.stepped = 0;
            }
            s.stepped |= batch[i].type == PGEM_ITEM_EDGE;
            if (batch[i].type == PGEM_ITEM_RESET) {
                s.stepped = 0;
                s.dirty = 0;
                s.unsolved = 0;
                s.unsettled = 0;
            }
            if (bridge_graph_apply(bridge, &batch[i])) {
                if (!s.dirty) {
                    s.first_loop = now;
                    s.trigger = "loops";
                }
                s.dirty = 1;
                s.last_loop = now;
            }
        }
        if (behind && !bridge->options.full && !replaying && s.stepped) {
            bridge_graph_step(bridge);
            s.stepped = 0;
        }
        if (count > 0) {
            bridge_graph_counts(bridge);
        }
        now = bridge_now();
        int due = solve_owed(&s) && now >= solve_due(bridge, &s);
        if ((optimize || recovery || due) && pgem_edge_count(bridge->core) > 0) {
            /* Quiet for idle_solve after incremental solves: one solve of the whole graph from
             * the front-end's estimates, which is what the offline tools compute. */
            int settle = !optimize && !recovery && !s.dirty && !s.unsolved;
            s.last_start = now;
            if (optimize) {
                pthread_mutex_lock(&bridge->lock);
                const int64_t commands = bridge->optimize_commands;
                bridge->optimize_commands = 0;
                pthread_mutex_unlock(&bridge->lock);
                if (commands > 1) {
                    bridge_log(bridge, "OPTIMIZE: one whole-graph solve for %lld OPTIMIZE "
                               "commands (merged while one waited, at most one solve per "
                               "%.0f s)", (long long)commands, OPTIMIZE_INTERVAL);
                } else {
                    bridge_log(bridge, "OPTIMIZE: one whole-graph solve for %lld OPTIMIZE "
                               "command", (long long)commands);
                }
            }
            if (settle) {
                settle = bridge_graph_settle(bridge); /* 0: it gave way, and is still owed */
            } else {
                bridge_graph_solve(bridge, optimize ? "command"
                                           : recovery ? "recovery"
                                           : s.dirty  ? s.trigger
                                                      : "idle");
            }
            s.last_end = bridge_now();
            if (optimize) {
                s.command = 0;
                s.command_end = s.last_end;
            }
            s.unsettled = !settle; /* (after a recovery too: it may have been a split graph) */
            s.dirty = 0;
            s.unsolved = 0;
            s.stepped = 0;
        } else if (due) {
            s.unsolved = 0; /* poses without edges: nothing to solve */
            s.unsettled = 0;
            s.command = 0;
        }
        if (snapshot) {
            bridge_graph_snapshot(bridge, path);
        }
        if (!bridge->options.full && !replaying) {
            bridge_graph_pass(bridge); /* adopt a finished live EM pass, start the next */
        }
    }
    return NULL;
}

/* ---- start, run, stop ---------------------------------------------------------------------- */

/* After the journal's replay: its records refused for the bridge's dimension or capacities
 * mean the options differ from the ones the journal was written with, and starting would drop
 * part of the map, so the start fails (the journal is left as it is). Other refusals (messages
 * a front-end got wrong, in an lcm-logger recording used as a seed) are counted and named. */
static int journal_report(bridge_t *bridge, const pgem_journal_info_t *info, char *message,
                          size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    const int64_t *refused = bridge->replay_refused;
    int64_t total = 0;
    char reasons[512] = "";
    for (int r = 0; r < PGEM_REJECT_COUNT; ++r) {
        if (refused[r] > 0) {
            size_t used = strlen(reasons);
            snprintf(reasons + used, sizeof reasons - used, "%s%s %lld", used > 0 ? ", " : "",
                     pgem_reject_name((pgem_reject_t)r), (long long)refused[r]);
            total += refused[r];
        }
    }
    if (refused[PGEM_REJECT_CAPACITY] > 0 || refused[PGEM_REJECT_DIMENSION] > 0) {
        snprintf(message, message_size,
                 "journal %s: %lld of its %lld records do not fit this bridge (%s; the first, "
                 "%s): start it with the --dimension, --max-poses and --max-edges the journal "
                 "was written with, or with a new journal (this one is left as it is)",
                 o->journal, (long long)total, (long long)info->records, reasons,
                 bridge->replay_first);
        return -1;
    }
    const pgem_ingest_counts_t counts = bridge->counts;
    bridge_log(bridge, "journal %s: %lld records replayed (%lld poses, %lld edges), %lld with a "
               "checksum", o->journal, (long long)(info->records - total),
               (long long)counts.accepted_poses, (long long)counts.accepted_edges,
               (long long)info->checked);
    if (counts.odometry_as_loops > 0) {
        bridge_log(bridge, "journal %s: %lld edges sent as ODOMETRY entered as loop closures "
                   "(not a step of the chain; the latest: %s)", o->journal,
                   (long long)counts.odometry_as_loops,
                   pgem_ingest_last_odometry_note(bridge->ingest));
    }
    if (total > 0) {
        bridge_note(bridge, "journal %s: %lld more records refused on replay (%s)", o->journal,
                    (long long)total, reasons);
    }
    bridge_journal_damage(bridge, info);
    return 0;
}

static int open_journal(bridge_t *bridge, char *message, size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    pgem_journal_info_t info;
    bridge->journal = pgem_journal_open(o->journal, o->journal_sync, on_journal_record,
                                        bridge_journal_recognise, bridge, &info, message,
                                        message_size);
    if (bridge->journal == NULL) {
        return -1;
    }
    bridge->recovered = info.records;
    bridge->visible = bridge->tail;
    bridge->recovery_pending = info.records > 0;
    pgem_ingest_counts(bridge->ingest, &bridge->counts);
    bridge->journal_records = info.records;
    if (journal_report(bridge, &info, message, message_size) != 0) {
        return -1;
    }
    pgem_ingest_set_admit(bridge->ingest, journal_admit, bridge);
    return 0;
}

static int start(bridge_t *bridge, char *message, size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    /* With --compact the graph never holds more than 90 % of the capacities (the solver thread
     * compacts as it adds), so what waits in the queue may go past them: the reception thread
     * admits up to half as much again, room for a solver thread that falls behind a burst
     * (a loaded or slow machine) without refusing poses for capacity. */
    const uint32_t admit_poses = o->compact ? o->max_poses + o->max_poses / 2u : o->max_poses;
    const uint32_t admit_edges = o->compact ? o->max_edges + o->max_edges / 2u : o->max_edges;
    pgem_ingest_config_t ingest_config = {o->dimension, admit_poses, admit_edges,
                                          o->max_pending, o->max_sources,
                                          (int64_t)(o->pending_timeout * 1e6),
                                          o->snapshot_dir != NULL, o->compact};
    bridge->ingest = pgem_ingest_create(&ingest_config, emit, bridge);
    bridge->queue_capacity = (uint64_t)admit_poses + admit_edges + BATCH;
    bridge->queue = calloc((size_t)bridge->queue_capacity, sizeof *bridge->queue);
    if (bridge->ingest == NULL || bridge->queue == NULL) {
        snprintf(message, message_size, "out of memory for %u poses and %u edges",
                 (unsigned)o->max_poses, (unsigned)o->max_edges);
        return -1;
    }
    if (bridge_graph_init(bridge, message, message_size) != 0) {
        return -1;
    }
    if (o->snapshot_dir != NULL) {
        bridge->snapshots = calloc(o->snapshot_limit, sizeof *bridge->snapshots);
        if (bridge->snapshots == NULL) {
            snprintf(message, message_size, "out of memory for --snapshot-limit %u",
                     (unsigned)o->snapshot_limit);
            return -1;
        }
        bridge->snapshot_dir = open(o->snapshot_dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
        if (bridge->snapshot_dir < 0) {
            snprintf(message, message_size, "--snapshot-dir %s: cannot open the folder: %s",
                     o->snapshot_dir, strerror(errno));
            return -1;
        }
    }
    if (o->journal != NULL && open_journal(bridge, message, message_size) != 0) {
        return -1;
    }
    if (o->snapshot_dir != NULL) {
        pgem_ingest_set_snapshot_check(bridge->ingest, bridge_snapshot_check, bridge);
    }
    bridge->lcm = o->lcm != NULL ? o->lcm : lcm_create(o->url);
    if (bridge->lcm == NULL) {
        const char *url = o->url != NULL ? o->url : getenv("LCM_DEFAULT_URL");
        snprintf(message, message_size, "cannot open LCM at %s", url != NULL ? url : "LCM's default URL");
        return -1;
    }
    const char *channels[3] = {o->channels.pose, o->channels.edge, o->channels.command};
    for (int i = 0; i < 3; ++i) {
        lcm_subscription_t *subscription = lcm_subscribe(bridge->lcm, channels[i], on_message,
                                                         bridge);
        if (subscription == NULL) {
            snprintf(message, message_size, "cannot subscribe to %s", channels[i]);
            return -1;
        }
        lcm_subscription_set_queue_capacity(subscription, LCM_QUEUE_CAPACITY);
    }
    return 0;
}

static void finish(bridge_t *bridge)
{
    if (bridge->snapshot_dir >= 0) {
        close(bridge->snapshot_dir);
    }
    if (bridge->lcm != NULL && bridge->lcm != bridge->options.lcm) {
        lcm_destroy(bridge->lcm);
    }
    pgem_journal_close(bridge->journal);
    bridge_graph_free(bridge);
    pgem_ingest_destroy(bridge->ingest);
    free(bridge->queue);
    free(bridge->snapshots);
    pthread_cond_destroy(&bridge->wake);
    pthread_mutex_destroy(&bridge->lock);
}

int pgem_bridge_run(const pgem_bridge_options_t *options, int (*stop)(void), char *message,
                    size_t message_size)
{
    bridge_t *bridge = calloc(1, sizeof *bridge);
    if (bridge == NULL) {
        snprintf(message, message_size, "out of memory");
        return -1;
    }
    bridge->options = *options;
    bridge->snapshot_dir = -1;
    pgem_bridge_defaults(&bridge->options);
    pthread_mutex_init(&bridge->lock, NULL);
    pthread_condattr_t attributes;
    pthread_condattr_init(&attributes);
    pthread_condattr_setclock(&attributes, CLOCK_MONOTONIC);
    pthread_cond_init(&bridge->wake, &attributes);
    pthread_condattr_destroy(&attributes);

    int status = start(bridge, message, message_size);
    pthread_t solver;
    if (status == 0 && pthread_create(&solver, NULL, solver_main, bridge) != 0) {
        snprintf(message, message_size, "cannot start the solver thread");
        status = -1;
    }
    if (status != 0) {
        finish(bridge);
        free(bridge);
        return -1;
    }
    const pgem_bridge_options_t *o = &bridge->options;
    bridge_log(bridge,
               "listening: %s (poses), %s (edges), %s (commands); publishing %s and %s; "
               "%dD, %u poses, %u edges, core block %.1f MiB%s",
               o->channels.pose, o->channels.edge, o->channels.command, o->channels.graph,
               o->channels.status, o->dimension, (unsigned)o->max_poses,
               (unsigned)o->max_edges, (double)bridge->core_block_size / 1048576.0,
               bridge->pass_on ? ", live EM pass block" : "");
    if (bridge->pass_on) {
        bridge_log(bridge, "live EM passes on: the copy's block %.1f MiB (--no-live-em: none)",
                   (double)bridge->pass.block_size / 1048576.0);
    }
    double next_status = bridge_now();
    int journal_away = 0;
    while (!stop()) {
        double now = bridge_now();
        if (now >= next_status) {
            expire_quietly(bridge);
            bridge_journal_watch(bridge, &journal_away);
            bridge_publish_status(bridge);
            next_status = now + o->status_period;
        }
        int wait_ms = (int)ceil((next_status - now) * 1000.0);
        if (wait_ms > 100) {
            wait_ms = 100; /* notice the stop flag soon */
        }
        if (lcm_handle_timeout(bridge->lcm, wait_ms < 1 ? 1 : wait_ms) < 0 && !stop()) {
            bridge_note(bridge, "LCM reception failed; retrying");
            struct timespec pause = {0, 100000000L};
            nanosleep(&pause, NULL);
        }
    }
    pthread_mutex_lock(&bridge->lock);
    bridge->stopping = 1;
    pthread_cond_broadcast(&bridge->wake);
    pthread_mutex_unlock(&bridge->lock);
    pthread_join(solver, NULL);
    bridge_publish_status(bridge);
    bridge_log(bridge, "stopped");
    finish(bridge);
    free(bridge);
    return 0;
}
