/* The solver thread's loop: waits for work, drains the queue in batches into the graph,
 * steps the incremental updates, decides when to solve (the schedule), writes snapshots and
 * runs the live EM passes. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <string.h>
#include <time.h>

#include "bridge_internal.h"

#define OPTIMIZE_INTERVAL 1.0     /* s from the end of a command solve to the next (issue 31) */

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
    bridge_handoff_t *const h = &bridge->handoff;
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
    pthread_cond_timedwait(&h->wake, &h->lock, &deadline);
}

/* Waits (lock held) until there is work: items, a request, a due solve, or the stop. */
static void wait_for_work(bridge_t *bridge, const schedule_t *s)
{
    bridge_handoff_t *const h = &bridge->handoff;
    while (!h->stopping && h->visible == h->head && !h->optimize_requested &&
           !h->snapshot_requested && bridge->solver.pass.state != BRIDGE_PASS_DONE) {
        const double pass_due = bridge_graph_pass_due(bridge);
        if (solve_owed(s) || isfinite(pass_due)) {
            const double due = fmin(solve_owed(s) ? solve_due(bridge, s) : (double)INFINITY, pass_due);
            if (bridge_now() >= due) {
                return;
            }
            wait_until(bridge, due);
        } else {
            pthread_cond_wait(&h->wake, &h->lock);
        }
    }
}

void *bridge_solver_main(void *user)
{
    bridge_t *bridge = user;
    bridge_handoff_t *const h = &bridge->handoff;
    schedule_t s;
    memset(&s, 0, sizeof s);
    s.last_start = -1e300;
    s.command_end = -1e300;
    pgem_item_t batch[BRIDGE_BATCH];
    for (;;) {
        pthread_mutex_lock(&h->lock);
        wait_for_work(bridge, &s);
        if (h->stopping) {
            pthread_mutex_unlock(&h->lock);
            break;
        }
        int count = 0;
        while (count < BRIDGE_BATCH && h->head < h->visible) {
            batch[count++] = h->queue[h->head % h->queue_capacity];
            h->head++;
        }
        int drained = h->head == h->visible;
        /* Behind: more than a batch waits. Then the batch's poses are stepped once, at its
         * end, not one by one: a solver thread that falls behind a burst (a dense graph, a
         * loaded machine) catches up instead of the queue outgrowing its room. */
        const int behind = h->visible - h->head > BRIDGE_BATCH;
        int optimize = h->optimize_requested; /* taken below when due */
        int recovery = h->recovery_pending && drained;
        const int replaying = h->recovery_pending; /* one full solve follows: no steps */
        int snapshot = h->snapshot_requested && drained;
        char path[PGEM_PATH_MAX];
        if (snapshot) {
            memcpy(path, h->snapshot_path, sizeof path);
            h->snapshot_requested = 0;
        }
        h->optimize_requested = 0;
        if (recovery) {
            h->recovery_pending = 0;
        }
        pthread_mutex_unlock(&h->lock);

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
        if ((optimize || recovery || due) && pgem_edge_count(bridge->solver.core) > 0) {
            /* Quiet for idle_solve after incremental solves: one solve of the whole graph from
             * the front-end's estimates, which is what the offline tools compute. */
            int settle = !optimize && !recovery && !s.dirty && !s.unsolved;
            s.last_start = now;
            if (optimize) {
                pthread_mutex_lock(&h->lock);
                const int64_t commands = h->optimize_commands;
                h->optimize_commands = 0;
                pthread_mutex_unlock(&h->lock);
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
