/* The bridge's two threads: reception (LCM handlers: ingest, journal, queue) and the solver
 * (drain the queue into the core, decide when to solve, publish). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bridge_internal.h"
#include "pgem_command_t.h"

#define DEFAULT_MAX_POSES 20000u
#define DEFAULT_EDGES_PER_POSE 4u
#define BATCH 256
#define LCM_QUEUE_CAPACITY 100000 /* messages LCM may hold for a handler */
#define REJECTIONS_LOGGED 20      /* then one line per 1000 */

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
                                   options->max_pending, options->max_sources};
    pgem_ingest_config_resolve(&ingest);
    options->max_pending = ingest.max_pending;
    options->max_sources = ingest.max_sources;
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
    if (options->robust.kernel == PGEM_KERNEL_NONE) {
        options->robust.kernel = PGEM_KERNEL_EM;
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

/* Journals what changed the graph; a failed write is reported, and the item still goes to
 * the solver (it is accepted; only its durability is lost). */
static void journal_accepted(bridge_t *bridge, const char *channel, const void *data,
                             size_t size, int64_t utime)
{
    char message[512];
    if (pgem_journal_append(bridge->journal, channel, data, size, utime, message,
                            sizeof message) != 0) {
        bridge_note(bridge, "journal: %s", message);
    }
}

static void on_message(const lcm_recv_buf_t *buffer, const char *channel, void *user)
{
    bridge_t *bridge = user;
    pgem_ingest_result_t result;
    pgem_role_t role = role_of_channel(bridge, channel);
    pthread_mutex_lock(&bridge->lock);
    pgem_ingest_message(bridge->ingest, role, buffer->data, buffer->data_size, &result);
    pthread_mutex_unlock(&bridge->lock);

    int changed = result.verdict == PGEM_VERDICT_ACCEPTED ||
                  (result.verdict == PGEM_VERDICT_COMMAND &&
                   result.command == PGEM_COMMAND_T_RESET);
    if (changed && bridge->journal != NULL) {
        journal_accepted(bridge, channel, buffer->data, buffer->data_size, buffer->recv_utime);
    }
    if (result.verdict == PGEM_VERDICT_REJECTED) {
        log_rejection(bridge, &result);
    } else if (result.verdict == PGEM_VERDICT_COMMAND) {
        static const char *const names[] = {"", "OPTIMIZE", "RESET", "SNAPSHOT"};
        bridge_log(bridge, "command %s%s%s", names[result.command],
                   result.path[0] != '\0' ? " " : "", result.path);
    }

    pthread_mutex_lock(&bridge->lock);
    bridge->visible = bridge->tail;
    pgem_ingest_counts(bridge->ingest, &bridge->counts);
    if (bridge->journal != NULL) {
        bridge->journal_records = pgem_journal_records(bridge->journal);
    }
    if (result.verdict == PGEM_VERDICT_REJECTED) {
        snprintf(bridge->last_message, sizeof bridge->last_message, "rejected (%s): %.340s",
                 pgem_reject_name(result.reason), result.message);
    } else if (result.verdict == PGEM_VERDICT_COMMAND) {
        if (result.command == PGEM_COMMAND_T_OPTIMIZE) {
            bridge->optimize_requested = 1;
        } else if (result.command == PGEM_COMMAND_T_SNAPSHOT) {
            bridge->snapshot_requested = 1;
            memcpy(bridge->snapshot_path, result.path, sizeof bridge->snapshot_path);
        }
    }
    pthread_cond_signal(&bridge->wake);
    pthread_mutex_unlock(&bridge->lock);
}

static void on_journal_record(void *user, const char *channel, const void *data, size_t size,
                              int64_t utime)
{
    (void)channel;
    (void)utime;
    bridge_t *bridge = user;
    pgem_ingest_result_t result;
    pgem_ingest_message(bridge->ingest, PGEM_ROLE_ANY, data, size, &result);
    if (result.verdict == PGEM_VERDICT_REJECTED) {
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
    const char *trigger;
} schedule_t;

/* When the pending loop closures are to be solved: after the debounce quiet time, but no later
 * than max_delay after the first of them; and never sooner than 1 / max_rate after the last
 * solve started. */
static double solve_due(const bridge_t *bridge, const schedule_t *s)
{
    const pgem_bridge_options_t *o = &bridge->options;
    double due = s->dirty      ? fmin(s->last_loop + o->debounce, s->first_loop + o->max_delay)
                 : s->unsolved ? s->last_item + o->idle_solve
                               : fmax(s->last_item, s->last_end) + o->idle_solve; /* settle */
    return fmax(due, s->last_start + 1.0 / o->max_rate);
}

static int solve_owed(const schedule_t *s)
{
    return s->dirty || s->unsolved || s->unsettled;
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
           !bridge->snapshot_requested) {
        if (solve_owed(s)) {
            double due = solve_due(bridge, s);
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
        int optimize = bridge->optimize_requested;
        int recovery = bridge->recovery_pending && drained;
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
        for (int i = 0; i < count; ++i) {
            if (batch[i].type == PGEM_ITEM_RESET) {
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
            if (settle) {
                bridge_graph_settle(bridge);
            } else {
                bridge_graph_solve(bridge, optimize ? "command"
                                           : recovery ? "recovery"
                                           : s.dirty  ? s.trigger
                                                      : "idle");
            }
            s.last_end = bridge_now();
            s.unsettled = !settle; /* (after a recovery too: it may have been a split graph) */
            s.dirty = 0;
            s.unsolved = 0;
        } else if (due) {
            s.unsolved = 0; /* poses without edges: nothing to solve */
            s.unsettled = 0;
        }
        if (snapshot) {
            bridge_graph_snapshot(bridge, path);
        }
    }
    return NULL;
}

/* ---- start, run, stop ---------------------------------------------------------------------- */

static int start(bridge_t *bridge, char *message, size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    pgem_ingest_config_t ingest_config = {o->dimension, o->max_poses, o->max_edges,
                                          o->max_pending, o->max_sources};
    bridge->ingest = pgem_ingest_create(&ingest_config, emit, bridge);
    bridge->queue_capacity = (uint64_t)o->max_poses + o->max_edges + BATCH;
    bridge->queue = calloc((size_t)bridge->queue_capacity, sizeof *bridge->queue);
    if (bridge->ingest == NULL || bridge->queue == NULL) {
        snprintf(message, message_size, "out of memory for %u poses and %u edges",
                 (unsigned)o->max_poses, (unsigned)o->max_edges);
        return -1;
    }
    if (bridge_graph_init(bridge, message, message_size) != 0) {
        return -1;
    }
    if (o->journal != NULL) {
        pgem_journal_info_t info;
        bridge->journal = pgem_journal_open(o->journal, o->journal_sync, on_journal_record,
                                            bridge, &info, message, message_size);
        if (bridge->journal == NULL) {
            return -1;
        }
        bridge->recovered = info.records;
        bridge->visible = bridge->tail;
        bridge->recovery_pending = info.records > 0;
        pgem_ingest_counts(bridge->ingest, &bridge->counts);
        bridge->journal_records = info.records;
        const pgem_ingest_counts_t counts = bridge->counts;
        bridge_log(bridge, "journal %s: %lld records replayed (%lld poses, %lld edges)",
                   o->journal, (long long)info.records, (long long)counts.accepted_poses,
                   (long long)counts.accepted_edges);
        if (info.torn_bytes > 0 || info.skipped_bytes > 0) {
            bridge_note(bridge, "journal %s: cut %lld bytes of a torn last record, skipped "
                        "%lld damaged bytes", o->journal, (long long)info.torn_bytes,
                        (long long)info.skipped_bytes);
        }
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
    if (bridge->lcm != NULL && bridge->lcm != bridge->options.lcm) {
        lcm_destroy(bridge->lcm);
    }
    pgem_journal_close(bridge->journal);
    bridge_graph_free(bridge);
    pgem_ingest_destroy(bridge->ingest);
    free(bridge->queue);
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
               "%dD, %u poses, %u edges, core block %.1f MiB",
               o->channels.pose, o->channels.edge, o->channels.command, o->channels.graph,
               o->channels.status, o->dimension, (unsigned)o->max_poses,
               (unsigned)o->max_edges, (double)bridge->core_block_size / 1048576.0);
    double next_status = bridge_now();
    while (!stop()) {
        double now = bridge_now();
        if (now >= next_status) {
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
