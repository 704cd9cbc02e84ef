/* The solver thread's solves: the incremental update per pose and the whole-graph EM solves
 * (restarts, the settle that gives way to arriving items), what each says of its loops, and
 * the graph published after it. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "bridge_internal.h"

/* 1 when a restart starts from the live estimate: on a compacted graph, unless a restart
 * from it failed (a live estimate the solve cannot use: the front-end's is the way back). */
static int restart_from_live(const bridge_t *bridge)
{
    return bridge->solver.compaction.count > 0u && !bridge->solver.live_failed;
}

/* Every pose back to the front-end's estimate and every loop closure back in: the solve that
 * follows is the one an offline tool would run on the same graph. A compacted graph keeps its
 * estimate: its composed edges are the removed poses' quadratic form about the estimate at
 * each compaction, and the front-end's dead-reckoned poses are far from there. */
static void restart_from_raw(bridge_t *bridge)
{
    size_t pose_size = (size_t)PGEM_POSE_SIZE(bridge->options.dimension);
    const uint32_t poses = restart_from_live(bridge) ? 0u : pgem_pose_count(bridge->solver.core);
    for (uint32_t i = 0; i < poses; ++i) {
        pgem_id_t id = 0;
        pgem_pose_at(bridge->solver.core, i, &id, NULL, NULL);
        pgem_set_pose(bridge->solver.core, id, bridge->solver.raw + i * pose_size);
    }
    pgem_robust_reset(bridge->solver.core);
    memset(bridge->solver.anchored, 0, bridge->options.max_poses);
    bridge->solver.solved_poses = 0;
}

/* 1 when the solve under way should stop: the bridge is stopping, or a settle that gives way
 * sees items waiting in the queue. */
static int should_stop(bridge_t *bridge)
{
    const int yields = bridge->solver.settle.yields;
    pthread_mutex_lock(&bridge->handoff.lock);
    const int stop = bridge->handoff.stopping ||
                     (yields && bridge->handoff.queue.visible != bridge->handoff.queue.head);
    pthread_mutex_unlock(&bridge->handoff.lock);
    return stop;
}

/* Stops a robust solve after a round, or a settle after any Gauss-Newton iteration. */
static int keep_going(const pgem_robust_progress_t *progress, void *user)
{
    (void)progress;
    return should_stop(user);
}

static int keep_iterating(const pgem_iteration_t *iteration, void *user)
{
    (void)iteration;
    return should_stop(user);
}

/* The bridge's part of what a settle that gives way puts back (the core's is
 * pgem_update_save's): the per-pose flags it changes, kept or (back) put back. */
static void settle_flags(bridge_t *bridge, int back)
{
    const size_t poses = pgem_pose_count(bridge->solver.core);
    uint8_t *const live[2] = {bridge->solver.anchored, bridge->solver.gauge_fixed};
    uint8_t *const kept[2] = {bridge->solver.settle.anchored, bridge->solver.settle.gauge};
    for (int k = 0; k < 2; ++k) {
        memcpy(back ? live[k] : kept[k], back ? kept[k] : live[k], poses);
    }
}

static void settle_save(bridge_t *bridge)
{
    pgem_update_save(bridge->solver.core, bridge->solver.settle.save,
                     bridge->solver.settle.save_size);
    settle_flags(bridge, 0);
    bridge->solver.settle.solved_poses = bridge->solver.solved_poses;
}

static void settle_restore(bridge_t *bridge)
{
    pgem_update_restore(bridge->solver.core, bridge->solver.settle.save,
                        bridge->solver.settle.save_size);
    settle_flags(bridge, 1);
    bridge->solver.solved_poses = bridge->solver.settle.solved_poses;
    bridge->solver.restart_pending = 0;
}

int bridge_solve_settle(bridge_t *bridge)
{
    /* It can give way when the incremental state it leaves is sound: no restart owed (else
     * the next solve restarts anyway, and might as well be this one). */
    (void)bridge_components_hold(bridge); /* held before the save: a settle that gives way
                                           * puts back the holds with the estimate */
    bridge->solver.settle.yields =
        bridge->solver.settle.save != NULL && !bridge->solver.restart_pending;
    if (bridge->solver.settle.yields) {
        settle_save(bridge);
    }
    bridge_log(bridge, "settle: EM on the whole graph (%u poses, %u edges) from %s%s",
               pgem_pose_count(bridge->solver.core), pgem_edge_count(bridge->solver.core),
               restart_from_live(bridge) ? "the live estimate (the graph is compacted)"
                                         : "the front-end's estimates",
               bridge->solver.settle.yields ? ", giving way to arriving items" : "");
    bridge->solver.restart_pending = 1; /* the solve starts from the front-end's estimates */
    bridge->solver.settle.gave_way = 0;
    bridge_solve(bridge, "settle");
    bridge->solver.settle.yields = 0;
    return !bridge->solver.settle.gave_way;
}

/* A successful solve's degenerate outcome in words (the graph's stats message and the
 * status), empty when loop closures were accepted. */
void bridge_solve_describe(const pgem_robust_summary_t *summary, char *text, size_t size)
{
    if (summary->outcome == PGEM_ROBUST_ALL_REJECTED) {
        snprintf(text, size, "warning: all %u loop closures rejected: the map is the odometry's "
                             "alone", summary->loops);
    } else if (summary->outcome == PGEM_ROBUST_MOST_REJECTED) {
        snprintf(text, size, "warning: %u of %u loop closures rejected (more than 90%%)",
                 summary->rejected, summary->loops);
    }
}

/* After a solve or an update: the poses it solved (none re-anchored since) and the outcome
 * in words, or why it failed. */
void bridge_solve_done(bridge_t *bridge, int status, const pgem_robust_summary_t *summary,
                       char *why, size_t why_size)
{
    if (status == PGEM_OK) {
        bridge->solver.solved_poses = pgem_pose_count(bridge->solver.core);
        memset(bridge->solver.anchored, 0, bridge->solver.solved_poses);
        bridge_solve_describe(summary, why, why_size);
    } else {
        snprintf(why, why_size, "%s: %s", pgem_error_name(status),
                 pgem_last_error(bridge->solver.core));
    }
}

/* Passes that take longer than this (copy to result) turn the pending gate off until one is
 * quicker again. */
#define PASS_PENDING_SECONDS 1.0

/* The update's options from the robust ones: its gate on new loop closures with their gate
 * and inflation; kernel none keeps every loop in. */
static void update_options(const bridge_t *bridge, pgem_update_options_t *options)
{
    memset(options, 0, sizeof *options);
    options->robust = bridge->options.robust.kernel != PGEM_KERNEL_NONE;
    options->gate = bridge->options.robust.gate;
    options->odometry_inflation = bridge->options.robust.odometry_inflation;
    /* The pass judges what the map cannot yet (docs/design/live-em.md), while passes
     * come within a second: a loop held back waits up to two passes, and passes slower than
     * that (a large map on a slow or busy machine) left the live map drifting for want of
     * the loops held back, and the bridge behind the stream. */
    options->pending =
        bridge->solver.live_em.on && bridge->solver.live_em.took <= PASS_PENDING_SECONDS ? 10.0
                                                                                         : 0.0;
}

/* One incremental update, and the pruned loop closures and outcome after it: the update's
 * summary carries them (the core keeps the counts: O(new edges) per update). */
static int update_run(bridge_t *bridge)
{
    pgem_update_options_t options;
    update_options(bridge, &options);
    pgem_update_summary_t update;
    const int status = pgem_update(bridge->solver.core, &options, &update);
    bridge->solver.pruned_count = update.loops_pruned;
    bridge->solver.outcome = update.outcome;
    return status;
}

void bridge_solve_step(bridge_t *bridge)
{
    if (bridge->solver.restart_pending) {
        return; /* the next solve restarts: it decides */
    }
    (void)bridge_components_hold(bridge); /* each part held at its own gauge */
    int status = update_run(bridge);
    if (status == PGEM_ERR_FILL_BUDGET && bridge->options.compact &&
        bridge_compact_further(bridge)) {
        /* the graph fits its poses and edges but its factor has outgrown the fill budget
         * (carried loops concentrate on the poses kept): a smaller graph, then the update */
        bridge_log(bridge, "the incremental factor outgrew its fill budget: compacted to %u poses",
                   pgem_pose_count(bridge->solver.core));
        (void)bridge_components_hold(bridge);
        status = update_run(bridge);
    }
    if (status != PGEM_OK) {
        bridge->solver.restart_pending =
            1; /* the next solve restarts from the front-end's estimates */
        bridge_log(bridge, "incremental update failed: %s (%s); the next solve restarts from the "
                           "front-end's estimates", pgem_error_name(status),
                   pgem_last_error(bridge->solver.core));
        return;
    }
    bridge->solver.solved_poses = pgem_pose_count(bridge->solver.core);
    memset(bridge->solver.anchored, 0, bridge->solver.solved_poses);
}

/* What a robust solve's summary would say of the loops, from the last update's (or solve's)
 * counts and outcome; chi2 not computed (NaN): that visits every edge, and an update's cost
 * must not grow with the map. */
void bridge_solve_loops(const bridge_t *bridge, pgem_robust_summary_t *summary)
{
    summary->loops = bridge->solver.loop_count;
    summary->pruned = bridge->solver.pruned_count;
    summary->rejected = summary->pruned;
    summary->final_chi2 = (double)NAN;
    summary->final_chi2_all = (double)NAN;
    summary->initial_chi2 = (double)NAN;
    summary->outcome = bridge->solver.outcome;
}

/* One incremental update; the summary gets what a robust solve's would say of the loops. Its
 * chi2 is not computed (NaN): that visits every edge, and the updates' cost must not grow
 * with the map; the settle and --full solves report it. */
int bridge_solve_update(bridge_t *bridge, pgem_robust_summary_t *summary)
{
    const int status = update_run(bridge);
    bridge_solve_loops(bridge, summary);
    summary->usable = status == PGEM_OK;
    summary->estimate_changed = status == PGEM_OK;
    return status;
}

void bridge_solve(bridge_t *bridge, const char *trigger)
{
    pthread_mutex_lock(&bridge->handoff.lock);
    bridge->handoff.graph.solving = 1;
    pthread_mutex_unlock(&bridge->handoff.lock);
    pgem_robust_options_t robust = bridge->options.robust;
    robust.on_round = keep_going;
    robust.user = bridge;
    pgem_robust_summary_t summary;
    memset(&summary, 0, sizeof summary);
    double start = bridge_now();
    uint32_t parts = bridge_components_hold(bridge);
    int restarted = bridge->solver.restart_pending;
    if (restarted) {
        restart_from_raw(bridge);
        bridge->solver.restart_pending = 0;
    }
    const int incremental = !bridge->options.full && !restarted &&
                            strcmp(trigger, "settle") != 0 && strcmp(trigger, "command") != 0 &&
                            strcmp(trigger, "recovery") != 0;
    if (!incremental) {
        bridge_components_hold_lone(bridge);
    }
    pgem_solve_options_t give_way; /* a settle that gives way looks after every iteration */
    memset(&give_way, 0, sizeof give_way);
    give_way.on_iteration = keep_iterating;
    give_way.user = bridge;
    const pgem_solve_options_t *solve = bridge->solver.settle.yields ? &give_way : NULL;
    int status = incremental ? bridge_solve_update(bridge, &summary)
                             : pgem_robust_optimize(bridge->solver.core, &robust, solve, &summary);
    if (bridge->solver.settle.yields && status == PGEM_OK &&
        summary.termination == PGEM_ROBUST_STOPPED && !bridge_stopping(bridge)) {
        settle_restore(
            bridge); /* items arrived: the incremental map goes on from the last update */
        bridge->solver.settle.gave_way = 1;
        pthread_mutex_lock(&bridge->handoff.lock);
        bridge->handoff.graph.solving = 0;
        pthread_mutex_unlock(&bridge->handoff.lock);
        bridge_log(bridge, "settle gave way to arriving items after %.1f ms (%u Gauss-Newton "
                           "iterations): the graph is as the last update left it, and the settle "
                           "waits for the next quiet time",
                   1e3 * (bridge_now() - start), summary.gn_iterations);
        return;
    }
    const int from_live = restarted && restart_from_live(bridge);
    if (restarted) { /* a failed restart from the live estimate: the next from the front-end's */
        bridge->solver.live_failed = status != PGEM_OK && from_live;
    }
    if (status != PGEM_OK) {
        bridge->solver.restart_pending = 1;
    }
    if (!incremental) { /* the estimate is the solve's */
        bridge_pass_drop(bridge);
    }
    int64_t micros = (int64_t)((bridge_now() - start) * 1e6);
    double solved = bridge_now();
    char why[256] = "";
    bridge_solve_done(bridge, status, &summary, why, sizeof why);
    if (!incremental) {
        bridge->solver.pruned_count = summary.pruned;
        bridge->solver.outcome = summary.outcome;
    }
    bridge_solver_counts(bridge);
    bridge_publish_graph(bridge, trigger, &summary, status == PGEM_OK, why, micros);
    double published = bridge_now();
    pthread_mutex_lock(&bridge->handoff.lock);
    bridge->handoff.graph.solving = 0;
    bridge->handoff.graph.solves++;
    pthread_mutex_unlock(&bridge->handoff.lock);
    if (status == PGEM_OK) { /* after the graph: it never waits for the covariance */
        bridge_covariance_publish(bridge, !incremental);
    }
    if (status == PGEM_OK) {
        /* parts by odometry (each held at its own gauge) and after the accepted loop closures
         * joined them, as the team message counts them */
        char parts_text[128] = "";
        const uint32_t joined = bridge->solver.team.parts;
        if (joined > 1u) {
            snprintf(parts_text, sizeof parts_text,
                     " (graph in %u parts after the accepted loop closures: each held at its own "
                     "gauge)", joined);
        } else if (parts > 1u) {
            snprintf(parts_text, sizeof parts_text,
                     " (%u parts by odometry, joined by accepted loop closures)", parts);
        }
        bridge_log(bridge,
                   "solve %lld (%s%s): %u poses, %u loops, %u pruned, chi2 %.6g, %u rounds, "
                   "%.1f ms (publishing %.1f ms)%s",
                   (long long)bridge->solver.solve_id, trigger,
                   restarted ? (from_live ? ", restarted from the live estimate, every loop back in"
                                          : ", restarted from the front-end's estimates")
                   : incremental ? ", incremental"
                                 : "",
                   pgem_pose_count(bridge->solver.core), summary.loops, summary.pruned,
                   summary.final_chi2, summary.rounds, 1e-3 * (double)micros,
                   1e3 * (published - solved), parts_text);
        if (why[0] != '\0') {
            bridge_note(bridge, "solve %lld: %s", (long long)bridge->solver.solve_id, why);
        }
    } else {
        bridge_note(bridge, "solve %lld (%s) failed: %s%s", (long long)bridge->solver.solve_id,
                    trigger, why,
                    bridge->solver.live_failed ? "; the next solve restarts from the front-end's "
                                                 "estimates"
                                               : "");
    }
    bridge_publish_status(bridge);
}
