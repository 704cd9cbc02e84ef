/* The bridge's start, run and stop: the options' defaults, the two threads' state set up from
 * the capacities, the reception thread's loop (LCM's handlers, the periodic status), the
 * solver thread started and joined (reception.c, solver.c). */
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

#define DEFAULT_MAX_POSES 20000u
#define DEFAULT_EDGES_PER_POSE 4u
#define LCM_QUEUE_CAPACITY 100000 /* messages LCM may hold for a handler */

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

static int start(bridge_t *bridge, char *message, size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    if (bridge_reception_init(bridge, message, message_size) != 0) {
        return -1;
    }
    if (bridge_solver_init(bridge, message, message_size) != 0) {
        return -1;
    }
    if (o->snapshot_dir != NULL) {
        bridge->handoff.snapshots.ring =
            calloc(o->snapshot_limit, sizeof *bridge->handoff.snapshots.ring);
        if (bridge->handoff.snapshots.ring == NULL) {
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
    if (o->journal != NULL && bridge_reception_open_journal(bridge, message, message_size) != 0) {
        return -1;
    }
    if (o->snapshot_dir != NULL) {
        pgem_ingest_set_snapshot_check(bridge->handoff.ingest, bridge_snapshot_check, bridge);
    }
    bridge->lcm = o->lcm != NULL ? o->lcm : lcm_create(o->url);
    if (bridge->lcm == NULL) {
        const char *url = o->url != NULL ? o->url : getenv("LCM_DEFAULT_URL");
        snprintf(message, message_size, "cannot open LCM at %s",
                 url != NULL ? url : "LCM's default URL");
        return -1;
    }
    const char *channels[3] = {o->channels.pose, o->channels.edge, o->channels.command};
    for (int i = 0; i < 3; ++i) {
        lcm_subscription_t *subscription = lcm_subscribe(bridge->lcm, channels[i],
                                                         bridge_reception_message, bridge);
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
    bridge_reception_free(bridge);
    bridge_solver_free(bridge);
    free(bridge->handoff.snapshots.ring);
    pthread_cond_destroy(&bridge->handoff.wake);
    pthread_mutex_destroy(&bridge->handoff.lock);
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
    pthread_mutex_init(&bridge->handoff.lock, NULL);
    pthread_condattr_t attributes;
    pthread_condattr_init(&attributes);
    pthread_condattr_setclock(&attributes, CLOCK_MONOTONIC);
    pthread_cond_init(&bridge->handoff.wake, &attributes);
    pthread_condattr_destroy(&attributes);

    int status = start(bridge, message, message_size);
    /* What the first lines say of the solver thread's blocks, read before it runs. */
    const double core_mib = (double)bridge->solver.core_block_size / 1048576.0;
    const int pass_on = bridge->solver.live_em.on;
    const double pass_mib = (double)bridge->solver.live_em.pass.block_size / 1048576.0;
    pthread_t solver;
    if (status == 0 && pthread_create(&solver, NULL, bridge_solver_main, bridge) != 0) {
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
               "listening: %s (poses), %s (edges), %s (commands); publishing %s, %s and %s; "
               "%dD, %u poses, %u edges, core block %.1f MiB%s",
               o->channels.pose, o->channels.edge, o->channels.command, o->channels.graph,
               o->channels.team, o->channels.status, o->dimension, (unsigned)o->max_poses,
               (unsigned)o->max_edges, core_mib, pass_on ? ", live EM pass block" : "");
    if (pass_on) {
        bridge_log(bridge, "live EM passes on: the copy's block %.1f MiB (--no-live-em: none)",
                   pass_mib);
    }
    double next_status = bridge_now();
    int journal_away = 0;
    while (!stop()) {
        double now = bridge_now();
        if (now >= next_status) {
            bridge_reception_expire(bridge);
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
    pthread_mutex_lock(&bridge->handoff.lock);
    bridge->handoff.stopping = 1;
    pthread_cond_broadcast(&bridge->handoff.wake);
    pthread_mutex_unlock(&bridge->handoff.lock);
    pthread_join(solver, NULL);
    bridge_publish_status(bridge);
    bridge_log(bridge, "stopped");
    finish(bridge);
    free(bridge);
    return 0;
}
