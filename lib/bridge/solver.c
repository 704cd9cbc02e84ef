/* The solver thread: its state (allocated at start from the capacities) and its loop, which
 * waits for work, drains the queue in batches into the graph (apply.c), steps the incremental
 * updates and decides when to solve (the schedule; solve.c), writes snapshots (snapshot.c) and
 * tends the live EM passes (pass_adopt.c). */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bridge_internal.h"

#define OPTIMIZE_INTERVAL 1.0     /* s from the end of a command solve to the next (issue 31) */

/* ---- the solver thread's state ------------------------------------------------------------ */

int bridge_solver_init(bridge_t *bridge, char *message, size_t message_size)
{
    bridge_solver_t *const solver = &bridge->solver;
    const pgem_bridge_options_t *o = &bridge->options;
    memset(&solver->core_config, 0, sizeof solver->core_config);
    solver->core_config.dimension = o->dimension;
    solver->core_config.max_poses = o->max_poses;
    solver->core_config.max_edges = o->max_edges;
    solver->core_config.fill_budget = o->fill_budget;
    if (!o->full) { /* the incremental factor's room: twice the core's default fill */
        const uint64_t b = (uint64_t)PGEM_TANGENT_SIZE(o->dimension);
        const uint64_t fill = 2u * (uint64_t)PGEM_DEFAULT_FILL_PER_POSE * b * b * o->max_poses;
        solver->core_config.online_fill = fill > (uint64_t)INT32_MAX ? (uint32_t)INT32_MAX
                                                                       : (uint32_t)fill;
    }
    solver->core_block_size = pgem_memory_size(&solver->core_config);
    if (solver->core_block_size == 0) {
        snprintf(message, message_size, "invalid capacities (%u poses, %u edges, fill %u)",
                 (unsigned)o->max_poses, (unsigned)o->max_edges, (unsigned)o->fill_budget);
        return -1;
    }
    solver->core_block = malloc(solver->core_block_size);
    solver->outcome = PGEM_ROBUST_NO_LOOPS; /* an empty graph's, until the first solve */
    size_t poses = o->max_poses;
    size_t edges = o->max_edges;
    size_t sources = o->max_sources;
    size_t pose_size = (size_t)PGEM_POSE_SIZE(o->dimension);
    solver->edge_source = calloc(edges, sizeof *solver->edge_source);
    solver->edge_sequence = calloc(edges, sizeof *solver->edge_sequence);
    solver->source_last = calloc(sources, sizeof *solver->source_last);
    solver->anchored = calloc(poses, 1);
    solver->user_fixed = calloc(poses, 1);
    solver->gauge_fixed = calloc(poses, 1);
    solver->parts.parent = calloc(poses, sizeof *solver->parts.parent);
    solver->parts.anchor = calloc(poses, sizeof *solver->parts.anchor);
    solver->raw = calloc(poses * pose_size, sizeof *solver->raw);
    solver->parts.has_edge = calloc(poses, 1);
    solver->compaction.pose_map = calloc(poses, sizeof *solver->compaction.pose_map);
    solver->compaction.edge_map = calloc(edges, sizeof *solver->compaction.edge_map);
    solver->compaction.ids = calloc(poses, sizeof *solver->compaction.ids);
    solver->compaction.anchors = calloc(poses, sizeof *solver->compaction.anchors);
    solver->compaction.relative =
        calloc(poses * pose_size, sizeof *solver->compaction.relative);
    solver->compaction.before =
        calloc(poses * pose_size, sizeof *solver->compaction.before);
    solver->compaction.edges = calloc(edges, sizeof *solver->compaction.edges);
    solver->out.ids = calloc(poses, sizeof *solver->out.ids);
    solver->out.anchors = calloc(poses, sizeof *solver->out.anchors);
    solver->out.values = calloc(poses * pose_size, sizeof *solver->out.values);
    solver->out.rows = calloc(poses, sizeof *solver->out.rows);
    solver->out.loops = calloc(edges, sizeof *solver->out.loops);
    solver->out.sources = calloc(sources, sizeof *solver->out.sources);
    solver->out.names = calloc(sources, PGEM_SOURCE_MAX);
    solver->out.last = calloc(sources, sizeof *solver->out.last);
    bridge_team_t *team = &solver->team;
    team->parent = calloc(poses, sizeof *team->parent);
    team->robot = calloc(poses, sizeof *team->robot);
    team->label = calloc(poses, sizeof *team->label);
    team->bits = calloc(poses, sizeof *team->bits);
    team->first = calloc(sources, sizeof *team->first);
    team->count = calloc(sources, sizeof *team->count);
    team->names = calloc(sources, sizeof *team->names);
    team->poses = calloc(sources, sizeof *team->poses);
    team->first_ids = calloc(sources, sizeof *team->first_ids);
    team->part = calloc(sources, sizeof *team->part);
    team->anchored = calloc(sources, sizeof *team->anchored);
    team->frames = calloc(sources, sizeof *team->frames);
    team->frame_values = calloc(sources * pose_size, sizeof *team->frame_values);
    if (solver->core_block == NULL || solver->edge_source == NULL ||
        solver->edge_sequence == NULL || solver->source_last == NULL ||
        solver->anchored == NULL || solver->user_fixed == NULL ||
        solver->gauge_fixed == NULL || solver->parts.parent == NULL ||
        solver->parts.anchor == NULL || solver->raw == NULL ||
        solver->parts.has_edge == NULL || solver->out.ids == NULL ||
        solver->out.anchors == NULL || solver->out.values == NULL ||
        solver->out.rows == NULL || solver->out.loops == NULL ||
        solver->out.sources == NULL || solver->out.names == NULL ||
        solver->out.last == NULL || solver->compaction.pose_map == NULL ||
        solver->compaction.edge_map == NULL || solver->compaction.ids == NULL ||
        solver->compaction.anchors == NULL || solver->compaction.relative == NULL ||
        solver->compaction.before == NULL || solver->compaction.edges == NULL ||
        team->parent == NULL || team->robot == NULL || team->label == NULL ||
        team->bits == NULL || team->first == NULL || team->count == NULL ||
        team->names == NULL || team->poses == NULL || team->first_ids == NULL ||
        team->part == NULL || team->anchored == NULL || team->frames == NULL ||
        team->frame_values == NULL) {
        snprintf(message, message_size, "out of memory for %u poses and %u edges",
                 (unsigned)o->max_poses, (unsigned)o->max_edges);
        return -1;
    }
    for (size_t i = 0; i < poses; ++i) {
        solver->out.rows[i] = solver->out.values + i * pose_size;
    }
    for (size_t s = 0; s < sources; ++s) {
        solver->source_last[s] = -1;
        team->frames[s] = team->frame_values + s * pose_size;
    }
    bridge_components_reset(bridge);
    int status = pgem_init(&solver->core, &solver->core_config,
                           solver->core_block, solver->core_block_size);
    if (status != PGEM_OK) {
        snprintf(message, message_size, "cannot initialise the core: %s",
                 pgem_error_name(status));
        return -1;
    }
    solver->live_em.on = !o->full && !o->no_live_em && o->robust.kernel != PGEM_KERNEL_NONE;
    if (solver->live_em.on &&
        bridge_pass_init(&solver->live_em.pass, &solver->core_config, &o->robust,
                         &bridge->handoff.lock, &bridge->handoff.wake, message,
                         message_size) != 0) {
        solver->live_em.on = 0;
        return -1;
    }
    if (!o->full) { /* the settle's way back: sized once, for the capacities */
        solver->settle.save_size = pgem_update_save_size(solver->core);
        solver->settle.save = malloc(solver->settle.save_size);
        solver->settle.anchored = malloc(poses + 1u);
        solver->settle.gauge = malloc(poses + 1u);
        if (solver->settle.save == NULL || solver->settle.anchored == NULL ||
            solver->settle.gauge == NULL) {
            snprintf(message, message_size, "out of memory for %u poses and %u edges",
                     (unsigned)o->max_poses, (unsigned)o->max_edges);
            return -1;
        }
    }
    return 0;
}

void bridge_solver_free(bridge_t *bridge)
{
    bridge_solver_t *const solver = &bridge->solver;
    bridge_pass_free(&solver->live_em.pass); /* before the core it copies from goes */
    free(solver->core_block);
    free(solver->edge_source);
    free(solver->edge_sequence);
    free(solver->source_last);
    free(solver->anchored);
    free(solver->user_fixed);
    free(solver->gauge_fixed);
    free(solver->parts.parent);
    free(solver->parts.anchor);
    free(solver->raw);
    free(solver->parts.has_edge);
    free(solver->compaction.pose_map);
    free(solver->compaction.edge_map);
    free(solver->compaction.ids);
    free(solver->compaction.anchors);
    free(solver->compaction.relative);
    free(solver->compaction.before);
    free(solver->compaction.edges);
    free(solver->out.ids);
    free(solver->out.values);
    free(solver->out.rows);
    free(solver->out.loops);
    free(solver->out.sources);
    free(solver->out.names);
    free(solver->out.last);
    free(solver->out.buffer);
    free(solver->out.anchors);
    free(solver->team.parent);
    free(solver->team.robot);
    free(solver->team.label);
    free(solver->team.bits);
    free(solver->team.first);
    free(solver->team.count);
    free(solver->team.names);
    free(solver->team.poses);
    free(solver->team.first_ids);
    free(solver->team.part);
    free(solver->team.anchored);
    free(solver->team.frames);
    free(solver->team.frame_values);
    free(solver->settle.save);
    free(solver->settle.anchored);
    free(solver->settle.gauge);
}

void bridge_solver_counts(bridge_t *bridge)
{
    pthread_mutex_lock(&bridge->handoff.lock);
    bridge->handoff.graph.poses = (int32_t)pgem_pose_count(bridge->solver.core);
    bridge->handoff.graph.edges = (int32_t)pgem_edge_count(bridge->solver.core);
    bridge->handoff.graph.loops = (int32_t)bridge->solver.loop_count;
    bridge->handoff.graph.pruned = (int32_t)bridge->solver.pruned_count;
    pthread_mutex_unlock(&bridge->handoff.lock);
}


/* ---- the loop ------------------------------------------------------------------------------ */

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
    while (!h->stopping && h->queue.visible == h->queue.head && !h->requests.optimize &&
           !h->requests.snapshot && bridge->solver.live_em.pass.state != BRIDGE_PASS_DONE) {
        const double pass_due = bridge_pass_due(bridge);
        if (solve_owed(s) || isfinite(pass_due)) {
            const double due =
                fmin(solve_owed(s) ? solve_due(bridge, s) : (double)INFINITY, pass_due);
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
        while (count < BRIDGE_BATCH && h->queue.head < h->queue.visible) {
            batch[count++] = h->queue.items[h->queue.head % h->queue.capacity];
            h->queue.head++;
        }
        int drained = h->queue.head == h->queue.visible;
        /* Behind: more than a batch waits. Then the batch's poses are stepped once, at its
         * end, not one by one: a solver thread that falls behind a burst (a dense graph, a
         * loaded machine) catches up instead of the queue outgrowing its room. */
        const int behind = h->queue.visible - h->queue.head > BRIDGE_BATCH;
        int optimize = h->requests.optimize; /* taken below when due */
        int recovery = h->requests.recovery && drained;
        const int replaying = h->requests.recovery; /* one full solve follows: no steps */
        int snapshot = h->requests.snapshot && drained;
        char path[PGEM_PATH_MAX];
        if (snapshot) {
            memcpy(path, h->requests.snapshot_path, sizeof path);
            h->requests.snapshot = 0;
        }
        h->requests.optimize = 0;
        if (recovery) {
            h->requests.recovery = 0;
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
                bridge_solve_step(bridge); /* the edges of the poses before this one */
                s.stepped = 0;
            }
            s.stepped |= batch[i].type == PGEM_ITEM_EDGE;
            if (batch[i].type == PGEM_ITEM_RESET) {
                s.stepped = 0;
                s.dirty = 0;
                s.unsolved = 0;
                s.unsettled = 0;
            }
            if (bridge_apply(bridge, &batch[i])) {
                if (!s.dirty) {
                    s.first_loop = now;
                    s.trigger = "loops";
                }
                s.dirty = 1;
                s.last_loop = now;
            }
        }
        if (behind && !bridge->options.full && !replaying && s.stepped) {
            bridge_solve_step(bridge);
            s.stepped = 0;
        }
        if (count > 0) {
            bridge_solver_counts(bridge);
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
                const int64_t commands = h->requests.optimize_commands;
                h->requests.optimize_commands = 0;
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
                settle = bridge_solve_settle(bridge); /* 0: it gave way, and is still owed */
            } else {
                bridge_solve(bridge, optimize   ? "command"
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
            bridge_snapshot_write(bridge, path);
        }
        if (!bridge->options.full && !replaying) {
            bridge_pass_schedule(bridge); /* adopt a finished live EM pass, start the next */
        }
    }
    return NULL;
}
