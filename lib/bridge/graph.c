/* The solver thread's graph: items into the core, robust solves, graph_t publication and
 * snapshots. Only the solver thread calls these. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bridge_internal.h"
#include "pgem/io.h"
#include "pgem_compaction_t.h"

int bridge_graph_init(bridge_t *bridge, char *message, size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    memset(&bridge->solver.core_config, 0, sizeof bridge->solver.core_config);
    bridge->solver.core_config.dimension = o->dimension;
    bridge->solver.core_config.max_poses = o->max_poses;
    bridge->solver.core_config.max_edges = o->max_edges;
    bridge->solver.core_config.fill_budget = o->fill_budget;
    if (!o->full) { /* the incremental factor's room: twice the core's default fill */
        const uint64_t b = (uint64_t)PGEM_TANGENT_SIZE(o->dimension);
        const uint64_t fill = 2u * (uint64_t)PGEM_DEFAULT_FILL_PER_POSE * b * b * o->max_poses;
        bridge->solver.core_config.online_fill = fill > (uint64_t)INT32_MAX ? (uint32_t)INT32_MAX
                                                                       : (uint32_t)fill;
    }
    bridge->solver.core_block_size = pgem_memory_size(&bridge->solver.core_config);
    if (bridge->solver.core_block_size == 0) {
        snprintf(message, message_size, "invalid capacities (%u poses, %u edges, fill %u)",
                 (unsigned)o->max_poses, (unsigned)o->max_edges, (unsigned)o->fill_budget);
        return -1;
    }
    bridge->solver.core_block = malloc(bridge->solver.core_block_size);
    size_t poses = o->max_poses;
    size_t edges = o->max_edges;
    size_t sources = o->max_sources;
    size_t pose_size = (size_t)PGEM_POSE_SIZE(o->dimension);
    bridge->solver.edge_source = calloc(edges, sizeof *bridge->solver.edge_source);
    bridge->solver.edge_sequence = calloc(edges, sizeof *bridge->solver.edge_sequence);
    bridge->solver.source_last = calloc(sources, sizeof *bridge->solver.source_last);
    bridge->solver.anchored = calloc(poses, 1);
    bridge->solver.user_fixed = calloc(poses, 1);
    bridge->solver.gauge_fixed = calloc(poses, 1);
    bridge->solver.component = calloc(poses, sizeof *bridge->solver.component);
    bridge->solver.component_anchor = calloc(poses, sizeof *bridge->solver.component_anchor);
    bridge->solver.raw = calloc(poses * pose_size, sizeof *bridge->solver.raw);
    bridge->solver.part_edges = calloc(poses, 1);
    bridge->solver.compact_pose_map = calloc(poses, sizeof *bridge->solver.compact_pose_map);
    bridge->solver.compact_edge_map = calloc(edges, sizeof *bridge->solver.compact_edge_map);
    bridge->solver.compact_ids = calloc(poses, sizeof *bridge->solver.compact_ids);
    bridge->solver.compact_anchors = calloc(poses, sizeof *bridge->solver.compact_anchors);
    bridge->solver.compact_relative = calloc(poses * pose_size, sizeof *bridge->solver.compact_relative);
    bridge->solver.compact_before = calloc(poses * pose_size, sizeof *bridge->solver.compact_before);
    bridge->solver.compact_edges = calloc(edges, sizeof *bridge->solver.compact_edges);
    bridge->solver.out_ids = calloc(poses, sizeof *bridge->solver.out_ids);
    bridge->solver.out_last_anchor = calloc(poses, sizeof *bridge->solver.out_last_anchor);
    bridge->solver.out_values = calloc(poses * pose_size, sizeof *bridge->solver.out_values);
    bridge->solver.out_rows = calloc(poses, sizeof *bridge->solver.out_rows);
    bridge->solver.out_loops = calloc(edges, sizeof *bridge->solver.out_loops);
    bridge->solver.out_sources = calloc(sources, sizeof *bridge->solver.out_sources);
    bridge->solver.out_names = calloc(sources, PGEM_SOURCE_MAX);
    bridge->solver.out_last = calloc(sources, sizeof *bridge->solver.out_last);
    if (bridge->solver.core_block == NULL || bridge->solver.edge_source == NULL ||
        bridge->solver.edge_sequence == NULL || bridge->solver.source_last == NULL ||
        bridge->solver.anchored == NULL || bridge->solver.user_fixed == NULL || bridge->solver.gauge_fixed == NULL ||
        bridge->solver.component == NULL || bridge->solver.component_anchor == NULL || bridge->solver.raw == NULL || bridge->solver.part_edges == NULL ||
        bridge->solver.out_ids == NULL || bridge->solver.out_last_anchor == NULL || bridge->solver.out_values == NULL ||
        bridge->solver.out_rows == NULL || bridge->solver.out_loops == NULL || bridge->solver.out_sources == NULL ||
        bridge->solver.out_names == NULL ||
        bridge->solver.out_last == NULL || bridge->solver.compact_pose_map == NULL ||
        bridge->solver.compact_edge_map == NULL || bridge->solver.compact_ids == NULL ||
        bridge->solver.compact_anchors == NULL || bridge->solver.compact_relative == NULL ||
        bridge->solver.compact_before == NULL ||
        bridge->solver.compact_edges == NULL) {
        snprintf(message, message_size, "out of memory for %u poses and %u edges",
                 (unsigned)o->max_poses, (unsigned)o->max_edges);
        return -1;
    }
    for (size_t i = 0; i < poses; ++i) {
        bridge->solver.out_rows[i] = bridge->solver.out_values + i * pose_size;
    }
    for (size_t s = 0; s < sources; ++s) {
        bridge->solver.source_last[s] = -1;
    }
    bridge_components_reset(bridge);
    int status = pgem_init(&bridge->solver.core, &bridge->solver.core_config, bridge->solver.core_block,
                           bridge->solver.core_block_size);
    if (status != PGEM_OK) {
        snprintf(message, message_size, "cannot initialise the core: %s",
                 pgem_error_name(status));
        return -1;
    }
    bridge->solver.pass_on = !o->full && !o->no_live_em && o->robust.kernel != PGEM_KERNEL_NONE;
    if (bridge->solver.pass_on && bridge_pass_init(&bridge->solver.pass, &bridge->solver.core_config, &o->robust,
                                            &bridge->handoff.lock, &bridge->handoff.wake, message,
                                            message_size) != 0) {
        bridge->solver.pass_on = 0;
        return -1;
    }
    if (!o->full) { /* the settle's way back: sized once, for the capacities */
        bridge->solver.settle_save_size = pgem_update_save_size(bridge->solver.core);
        bridge->solver.settle_save = malloc(bridge->solver.settle_save_size);
        bridge->solver.settle_anchored = malloc(poses + 1u);
        bridge->solver.settle_gauge = malloc(poses + 1u);
        if (bridge->solver.settle_save == NULL || bridge->solver.settle_anchored == NULL ||
            bridge->solver.settle_gauge == NULL) {
            snprintf(message, message_size, "out of memory for %u poses and %u edges",
                     (unsigned)o->max_poses, (unsigned)o->max_edges);
            return -1;
        }
    }
    return 0;
}

void bridge_graph_free(bridge_t *bridge)
{
    bridge_pass_free(&bridge->solver.pass); /* before the core it copies from goes */
    free(bridge->solver.core_block);
    free(bridge->solver.edge_source);
    free(bridge->solver.edge_sequence);
    free(bridge->solver.source_last);
    free(bridge->solver.anchored);
    free(bridge->solver.user_fixed);
    free(bridge->solver.gauge_fixed);
    free(bridge->solver.component);
    free(bridge->solver.component_anchor);
    free(bridge->solver.raw);
    free(bridge->solver.part_edges);
    free(bridge->solver.compact_pose_map);
    free(bridge->solver.compact_edge_map);
    free(bridge->solver.compact_ids);
    free(bridge->solver.compact_anchors);
    free(bridge->solver.compact_relative);
    free(bridge->solver.compact_before);
    free(bridge->solver.compact_edges);
    free(bridge->solver.out_ids);
    free(bridge->solver.out_values);
    free(bridge->solver.out_rows);
    free(bridge->solver.out_loops);
    free(bridge->solver.out_sources);
    free(bridge->solver.out_names);
    free(bridge->solver.out_last);
    free(bridge->solver.out_buffer);
    free(bridge->solver.out_last_anchor);
    free(bridge->solver.settle_save);
    free(bridge->solver.settle_anchored);
    free(bridge->solver.settle_gauge);
}

void bridge_graph_counts(bridge_t *bridge)
{
    pthread_mutex_lock(&bridge->handoff.lock);
    bridge->handoff.graph_poses = (int32_t)pgem_pose_count(bridge->solver.core);
    bridge->handoff.graph_edges = (int32_t)pgem_edge_count(bridge->solver.core);
    bridge->handoff.graph_loops = (int32_t)bridge->solver.loop_count;
    bridge->handoff.graph_pruned = (int32_t)bridge->solver.pruned_count;
    pthread_mutex_unlock(&bridge->handoff.lock);
}

static void core_refused(bridge_t *bridge, const char *what, int status)
{
    if (status == PGEM_ERR_CAPACITY && bridge->options.compact) {
        /* admitted beyond the block while compaction could free nothing */
        pthread_mutex_lock(&bridge->handoff.lock);
        bridge->handoff.full_rejections++;
        pthread_mutex_unlock(&bridge->handoff.lock);
        bridge_note(bridge, "rejected (full): %s: the block is full and compaction can free "
                            "nothing (%s)", what, pgem_last_error(bridge->solver.core));
        return;
    }
    pthread_mutex_lock(&bridge->handoff.lock);
    bridge->handoff.core_rejections++;
    pthread_mutex_unlock(&bridge->handoff.lock);
    bridge_note(bridge, "the core refused %s: %s (%s)", what, pgem_error_name(status),
                pgem_last_error(bridge->solver.core));
}

static int pose_settled(const bridge_t *bridge, uint32_t index)
{
    return index < bridge->solver.solved_poses || bridge->solver.anchored[index] || bridge->solver.gauge_fixed[index];
}

/* A pose that arrived after the last solve carries the front-end's estimate, in the front-end's
 * drifting frame; the solved poses have moved since. When an odometry edge joins a settled pose
 * to such a new one, the new pose is placed by the measurement from the settled one, so the
 * next solve starts near its optimum and the E-step judges new loop closures fairly. */
static void anchor(bridge_t *bridge, const pgem_item_t *item)
{
    uint32_t from = 0;
    uint32_t to = 0;
    if (bridge->solver.solved_poses == 0 || pgem_pose_index(bridge->solver.core, item->from, &from) != PGEM_OK ||
        pgem_pose_index(bridge->solver.core, item->to, &to) != PGEM_OK) {
        return;
    }
    int dimension = bridge->options.dimension;
    double base[PGEM_POSE_SIZE_MAX];
    double step[PGEM_POSE_SIZE_MAX];
    double placed[PGEM_POSE_SIZE_MAX];
    uint32_t target = 0;    /* index of the pose to place */
    pgem_id_t target_id = 0;
    if (pose_settled(bridge, from) && !pose_settled(bridge, to)) {
        target = to;
        target_id = item->to;
        pgem_get_pose(bridge->solver.core, item->from, base);
        memcpy(step, item->value, sizeof step);
    } else if (pose_settled(bridge, to) && !pose_settled(bridge, from)) {
        target = from;
        target_id = item->from;
        pgem_get_pose(bridge->solver.core, item->to, base);
        if (dimension == 3) {
            pgem_se3_inverse(item->value, step);
        } else {
            pgem_se2_inverse(item->value, step);
        }
    } else {
        return;
    }
    int fixed = 0;
    pgem_pose_at(bridge->solver.core, target, NULL, NULL, &fixed);
    if (fixed) {
        return;
    }
    if (dimension == 3) {
        pgem_se3_compose(base, step, placed);
    } else {
        pgem_se2_compose(base, step, placed);
    }
    if (pgem_set_pose(bridge->solver.core, target_id, placed) == PGEM_OK) {
        bridge->solver.anchored[target] = 1;
    }
}

/* The estimate was replaced other than by an update or a pass (a reset, a whole-graph solve):
 * a pass of an older copy stops after its round and is dropped when it ends. */
void bridge_graph_drop_pass(bridge_t *bridge)
{
    bridge->solver.generation++;
    bridge->solver.pass.cancel = 1;
}

static void reset_graph(bridge_t *bridge)
{
    pgem_init(&bridge->solver.core, &bridge->solver.core_config, bridge->solver.core_block, bridge->solver.core_block_size);
    memset(bridge->solver.anchored, 0, bridge->options.max_poses);
    memset(bridge->solver.user_fixed, 0, bridge->options.max_poses);
    memset(bridge->solver.gauge_fixed, 0, bridge->options.max_poses);
    for (uint32_t s = 0; s < bridge->options.max_sources; ++s) {
        bridge->solver.source_last[s] = -1;
    }
    bridge->solver.solved_poses = 0;
    bridge->solver.restart_pending = 0;
    bridge_graph_drop_pass(bridge);
    bridge->solver.pass_loops = 0;
    bridge_components_reset(bridge);
    bridge->solver.loop_count = 0;
    bridge->solver.pruned_count = 0;
    bridge->solver.counted_edges = 0;
    bridge_graph_counts(bridge);
}

int bridge_graph_apply(bridge_t *bridge, const pgem_item_t *item)
{
    char what[160];
    if (item->type == PGEM_ITEM_RESET) {
        reset_graph(bridge);
        bridge_graph_publish(bridge, "reset", NULL, 0, "the graph was reset", 0);
        bridge_note(bridge, "reset: the graph is empty");
        return 0;
    }
    if (item->type == PGEM_ITEM_POSE) {
        int status = pgem_add_pose(bridge->solver.core, item->from, item->value);
        if (status == PGEM_OK) {
            size_t pose_size = (size_t)PGEM_POSE_SIZE(bridge->options.dimension);
            memcpy(bridge->solver.raw + (pgem_pose_count(bridge->solver.core) - 1) * pose_size, item->value,
                   pose_size * sizeof(double));
        }
        if (status == PGEM_OK && item->kind) {
            status = pgem_fix_pose(bridge->solver.core, item->from, 1);
            bridge->solver.user_fixed[pgem_pose_count(bridge->solver.core) - 1] = 1;
        }
        if (status != PGEM_OK) {
            snprintf(what, sizeof what, "pose %llu", (unsigned long long)item->from);
            core_refused(bridge, what, status);
        } else {
            (void)bridge_graph_compact(bridge);
        }
        return 0;
    }
    int n = PGEM_TANGENT_SIZE(bridge->options.dimension);
    double information[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    pgem_upper_to_full(item->information, n, information);
    uint32_t index = 0;
    int status = pgem_add_edge(bridge->solver.core, item->from, item->to, item->value, information,
                               (pgem_edge_kind_t)item->kind, &index);
    pgem_item_t moved;
    if (status == PGEM_ERR_UNKNOWN_ID && bridge->options.compact) {
        /* a pose compaction removed while the edge waited in the queue: onto its anchor */
        moved = *item;
        pthread_mutex_lock(&bridge->handoff.lock);
        const int anchored = pgem_ingest_reanchor(bridge->handoff.ingest, &moved);
        pthread_mutex_unlock(&bridge->handoff.lock);
        if (anchored) {
            status = pgem_add_edge(bridge->solver.core, moved.from, moved.to, moved.value, information,
                                   (pgem_edge_kind_t)moved.kind, &index);
            item = &moved;
        }
    }
    if (status != PGEM_OK) {
        snprintf(what, sizeof what, "edge %llu -> %llu (sequence %lld)",
                 (unsigned long long)item->from, (unsigned long long)item->to,
                 (long long)item->sequence);
        core_refused(bridge, what, status);
        return 0;
    }
    bridge->solver.edge_source[index] = item->source;
    bridge->solver.edge_sequence[index] = item->sequence;
    if (item->source < bridge->options.max_sources &&
        item->sequence > bridge->solver.source_last[item->source]) {
        bridge->solver.source_last[item->source] = item->sequence;
    }
    if (item->kind == PGEM_EDGE_ODOMETRY) {
        anchor(bridge, item);
        return 0;
    }
    bridge->solver.loop_count++;
    return 1;
}

/* 1 when a restart starts from the live estimate: on a compacted graph, unless a restart
 * from it failed (a live estimate the solve cannot use: the front-end's is the way back). */
static int restart_from_live(const bridge_t *bridge)
{
    return bridge->solver.compactions > 0u && !bridge->solver.live_failed;
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
    const int yields = bridge->solver.settle_yields;
    pthread_mutex_lock(&bridge->handoff.lock);
    const int stop = bridge->handoff.stopping ||
                     (yields && bridge->handoff.visible != bridge->handoff.head);
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
    uint8_t *const kept[2] = {bridge->solver.settle_anchored, bridge->solver.settle_gauge};
    for (int k = 0; k < 2; ++k) {
        memcpy(back ? live[k] : kept[k], back ? kept[k] : live[k], poses);
    }
}

static void settle_save(bridge_t *bridge)
{
    pgem_update_save(bridge->solver.core, bridge->solver.settle_save, bridge->solver.settle_save_size);
    settle_flags(bridge, 0);
    bridge->solver.settle_solved_poses = bridge->solver.solved_poses;
}

static void settle_restore(bridge_t *bridge)
{
    pgem_update_restore(bridge->solver.core, bridge->solver.settle_save, bridge->solver.settle_save_size);
    settle_flags(bridge, 1);
    bridge->solver.solved_poses = bridge->solver.settle_solved_poses;
    bridge->solver.restart_pending = 0;
}

int bridge_graph_settle(bridge_t *bridge)
{
    /* It can give way when the incremental state it leaves is sound: no restart owed (else
     * the next solve restarts anyway, and might as well be this one). */
    (void)bridge_components_hold(bridge); /* held before the save: a settle that gives way
                                           * puts back the holds with the estimate */
    bridge->solver.settle_yields = bridge->solver.settle_save != NULL && !bridge->solver.restart_pending;
    if (bridge->solver.settle_yields) {
        settle_save(bridge);
    }
    bridge_log(bridge, "settle: EM on the whole graph (%u poses, %u edges) from %s%s",
               pgem_pose_count(bridge->solver.core), pgem_edge_count(bridge->solver.core),
               restart_from_live(bridge) ? "the live estimate (the graph is compacted)"
                                         : "the front-end's estimates",
               bridge->solver.settle_yields ? ", giving way to arriving items" : "");
    bridge->solver.restart_pending = 1; /* the solve starts from the front-end's estimates */
    bridge->solver.settle_gave_way = 0;
    bridge_graph_solve(bridge, "settle");
    bridge->solver.settle_yields = 0;
    return !bridge->solver.settle_gave_way;
}

/* A successful solve's degenerate outcome in words (the graph's stats message and the
 * status), empty when loop closures were accepted. */
static void describe_outcome(const pgem_robust_summary_t *summary, char *text, size_t size)
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
static void solved_or_not(bridge_t *bridge, int status, const pgem_robust_summary_t *summary,
                          char *why, size_t why_size)
{
    if (status == PGEM_OK) {
        bridge->solver.solved_poses = pgem_pose_count(bridge->solver.core);
        memset(bridge->solver.anchored, 0, bridge->solver.solved_poses);
        describe_outcome(summary, why, why_size);
    } else {
        snprintf(why, why_size, "%s: %s", pgem_error_name(status), pgem_last_error(bridge->solver.core));
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
    options->pending = bridge->solver.pass_on && bridge->solver.pass_took <= PASS_PENDING_SECONDS ? 10.0 : 0.0;
}

/* The pruned loop closures among the edges pruned_count has not seen yet, added to it. */
static void count_new_pruned(bridge_t *bridge)
{
    const uint32_t edges = pgem_edge_count(bridge->solver.core);
    for (uint32_t k = bridge->solver.counted_edges; k < edges; ++k) {
        pgem_edge_view_t view;
        pgem_edge_at(bridge->solver.core, k, &view);
        bridge->solver.pruned_count += view.kind == PGEM_EDGE_LOOP && !view.active;
    }
    bridge->solver.counted_edges = edges;
}

/* The loop closures pruned after an update, from the count before it: the new loops it pruned,
 * less the pruned ones it took back (no other loop changes state in an update). O(new). */
static void count_pruned(bridge_t *bridge, const pgem_update_summary_t *update)
{
    count_new_pruned(bridge);
    bridge->solver.pruned_count -= update->loops_readmitted < bridge->solver.pruned_count
                                ? update->loops_readmitted
                                : bridge->solver.pruned_count;
}

static void recount_pruned(bridge_t *bridge);

/* Compaction's water marks: at 90 % of the poses (or of the edges) the graph is compacted to
 * 70 % of the poses. The 10 % above leaves room for what the reception thread admitted and
 * queued meanwhile (2000 poses at the default capacity); 20 % removed at a time makes the
 * factor's rebuild after it rare (once every 0.2 x max_poses poses). */
#define COMPACT_HIGH 0.9
#define COMPACT_LOW 0.7
#define COMPACT_TAIL 64u

/* Per-pose arrays of the bridge closed up as the core's were (map: old index -> new). */
static void compact_pose_arrays(bridge_t *bridge, uint32_t before)
{
    const size_t pose_size = (size_t)PGEM_POSE_SIZE(bridge->options.dimension);
    const uint32_t *map = bridge->solver.compact_pose_map;
    uint32_t solved = 0;
    for (uint32_t i = 0; i < before; ++i) {
        const uint32_t j = map[i];
        if (j == UINT32_MAX) {
            continue;
        }
        solved += i < bridge->solver.solved_poses;
        memmove(bridge->solver.raw + j * pose_size, bridge->solver.raw + i * pose_size, pose_size * sizeof(double));
        bridge->solver.anchored[j] = bridge->solver.anchored[i];
        bridge->solver.user_fixed[j] = bridge->solver.user_fixed[i];
        bridge->solver.gauge_fixed[j] = bridge->solver.gauge_fixed[i];
    }
    bridge->solver.solved_poses = solved;
}

/* pgem.compaction_t: the poses one compaction removed, each with its anchor and where it lies
 * in the anchor's frame (compact_relative holds the reverse, for the ingest). */
static void publish_compaction(bridge_t *bridge, const pgem_compact_summary_t *summary,
                               uint32_t removed, int full)
{
    const int dimension = bridge->options.dimension;
    const size_t pose_size = (size_t)PGEM_POSE_SIZE(dimension);
    for (uint32_t i = 0; i < removed; ++i) {
        const double *anchor_in_removed = bridge->solver.compact_relative + i * pose_size;
        (dimension == 3 ? pgem_se3_inverse : pgem_se2_inverse)(anchor_in_removed,
                                                                bridge->solver.out_rows[i]);
        bridge->solver.out_ids[i] = (int64_t)bridge->solver.compact_ids[i];
        bridge->solver.out_last_anchor[i] = (int64_t)bridge->solver.compact_anchors[i];
    }
    pgem_compaction_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = bridge_utime();
    msg.compaction = (int64_t)bridge->solver.compactions;
    msg.dimension = (int8_t)dimension;
    msg.pose_size = (int32_t)pose_size;
    msg.num_removed = (int32_t)removed;
    msg.ids = bridge->solver.out_ids;
    msg.anchors = bridge->solver.out_last_anchor;
    msg.relative = bridge->solver.out_rows;
    msg.poses_before = (int32_t)summary->poses_before;
    msg.poses_after = (int32_t)summary->poses_after;
    msg.edges_before = (int32_t)summary->edges_before;
    msg.edges_after = (int32_t)summary->edges_after;
    msg.edges_composed = (int32_t)summary->edges_composed;
    msg.loops_carried = (int32_t)summary->loops_carried;
    msg.loops_dropped = (int32_t)summary->loops_dropped;
    msg.loops_fused = (int32_t)summary->loops_fused;
    msg.full = (int8_t)full;
    const int size = pgem_compaction_t_encoded_size(&msg);
    if (bridge_out_ready(bridge, size, "the compaction")) {
        bridge_out_publish(bridge, bridge->options.channels.compaction, "the compaction", size,
                    pgem_compaction_t_encode(bridge->solver.out_buffer, 0, size, &msg));
    }
}

/* Compacts to target_poses and the low mark of the edges (see bridge_graph_compact). */
static int compact_to(bridge_t *bridge, uint32_t target_poses);

int bridge_graph_compact(bridge_t *bridge)
{
    const pgem_bridge_options_t *o = &bridge->options;
    const uint32_t poses = pgem_pose_count(bridge->solver.core), edges = pgem_edge_count(bridge->solver.core);
    if (!o->compact || ((double)poses < COMPACT_HIGH * o->max_poses &&
                          (double)edges < COMPACT_HIGH * o->max_edges)) {
        return 0;
    }
    return compact_to(bridge, (uint32_t)(COMPACT_LOW * o->max_poses));
}

static int compact_to(bridge_t *bridge, uint32_t target_poses)
{
    const pgem_bridge_options_t *o = &bridge->options;
    pgem_t *core = bridge->solver.core;
    const uint32_t poses = pgem_pose_count(core), edges = pgem_edge_count(core);
    const double start = bridge_now();
    const size_t pose_size = (size_t)PGEM_POSE_SIZE(o->dimension);
    for (uint32_t i = 0; i < poses; ++i) { /* ids and estimates before: the ingest's anchors */
        pgem_pose_at(core, i, &bridge->solver.compact_ids[i], bridge->solver.compact_before + i * pose_size, NULL);
    }
    pgem_compact_options_t options;
    memset(&options, 0, sizeof options);
    options.tail = o->compact_tail != 0u ? o->compact_tail : COMPACT_TAIL;
    options.pose_map = bridge->solver.compact_pose_map;
    options.edge_map = bridge->solver.compact_edge_map;
    pgem_compact_summary_t summary;
    options.target_edges = (uint32_t)(COMPACT_LOW * o->max_edges);
    options.keep_pruned = 1; /* the gate's verdicts are provisional: a live EM pass decides */
    pgem_compact(core, target_poses, &options, &summary);
    uint32_t removed_ids = 0, removed_edges = 0, kept = UINT32_MAX;
    for (uint32_t i = 0; i < poses; ++i) { /* each removed pose's anchor: the kept one before */
        if (bridge->solver.compact_pose_map[i] != UINT32_MAX) {
            kept = i;
            continue;
        }
        uint32_t anchor = kept;
        for (uint32_t j = i + 1; anchor == UINT32_MAX && j < poses; ++j) {
            anchor = bridge->solver.compact_pose_map[j] != UINT32_MAX ? j : UINT32_MAX;
        }
        bridge->solver.compact_anchors[removed_ids] = bridge->solver.compact_ids[anchor];
        (o->dimension == 3 ? pgem_se3_between : pgem_se2_between)(
            bridge->solver.compact_before + i * pose_size, bridge->solver.compact_before + anchor * pose_size,
            bridge->solver.compact_relative + removed_ids * pose_size);
        bridge->solver.compact_ids[removed_ids++] = bridge->solver.compact_ids[i];
    }
    for (uint32_t k = 0; k < edges; ++k) {
        const uint32_t j = bridge->solver.compact_edge_map[k];
        if (j == UINT32_MAX) {
            bridge->solver.compact_edges[removed_edges].source = bridge->solver.edge_source[k];
            bridge->solver.compact_edges[removed_edges++].sequence = bridge->solver.edge_sequence[k];
            continue;
        }
        bridge->solver.edge_source[j] = bridge->solver.edge_source[k];
        bridge->solver.edge_sequence[j] = bridge->solver.edge_sequence[k];
    }
    compact_pose_arrays(bridge, poses);
    /* the parts again from the kept poses and edges (the holds stay where they were) */
    bridge_components_reset(bridge);
    (void)bridge_components_hold(bridge);
    bridge_graph_drop_pass(bridge);
    bridge->solver.loop_count = 0;
    for (uint32_t k = 0; k < pgem_edge_count(core); ++k) {
        pgem_edge_view_t view;
        pgem_edge_at(core, k, &view);
        bridge->solver.loop_count += view.kind == PGEM_EDGE_LOOP;
    }
    bridge->solver.pass_loops = 0;
    recount_pruned(bridge);
    bridge_graph_counts(bridge);
    /* above the high mark still: nothing more can go, so the block is what the graph has */
    const int full = (double)summary.poses_after >= COMPACT_HIGH * o->max_poses ||
                     (double)summary.edges_after >= COMPACT_HIGH * o->max_edges;
    char why[160];
    snprintf(why, sizeof why, "every pose is held, among the newest %u, or joined by other than "
             "two odometry edges; %u poses and %u edges in the graph", options.tail,
             summary.poses_after, summary.edges_after);
    pthread_mutex_lock(&bridge->handoff.lock);
    while (bridge->handoff.admitting) { /* not under a message the ingest is admitting */
        pthread_cond_wait(&bridge->handoff.wake, &bridge->handoff.lock);
    }
    pgem_ingest_release(bridge->handoff.ingest, bridge->solver.compact_ids, bridge->solver.compact_anchors,
                        bridge->solver.compact_relative, removed_ids, bridge->solver.compact_edges,
                        removed_edges);
    if (full) {
        pgem_ingest_set_full(bridge->handoff.ingest, o->max_poses, o->max_edges, why);
    } else {
        pgem_ingest_set_full(bridge->handoff.ingest, 0u, 0u, NULL);
    }
    pthread_mutex_unlock(&bridge->handoff.lock);
    bridge->solver.compactions++;
    publish_compaction(bridge, &summary, removed_ids, full);
    bridge_log(bridge,
               "compaction %llu: %u -> %u poses, %u -> %u edges (%u odometry pairs composed, %u "
               "loop closures carried, %u pruned ones dropped) in %.1f ms; later edges to a "
               "removed pose enter on the kept pose before it",
               (unsigned long long)bridge->solver.compactions, summary.poses_before, summary.poses_after,
               summary.edges_before, summary.edges_after, summary.edges_composed,
               summary.loops_carried, summary.loops_dropped, 1e3 * (bridge_now() - start));
    if (full && !bridge->solver.compaction_full) {
        bridge_note(bridge, "compaction cannot bring the graph under 90 %% of its capacities (%s): "
                            "poses and edges beyond the block will be refused as full", why);
    }
    bridge->solver.compaction_full = full;
    return 1;
}

/* One incremental update and the pruned count after it. */
static int update_run(bridge_t *bridge)
{
    pgem_update_options_t options;
    update_options(bridge, &options);
    pgem_update_summary_t update;
    const int status = pgem_update(bridge->solver.core, &options, &update);
    if (status == PGEM_OK) {
        count_pruned(bridge, &update);
    }
    return status;
}

void bridge_graph_step(bridge_t *bridge)
{
    if (bridge->solver.restart_pending) {
        return; /* the next solve restarts: it decides */
    }
    (void)bridge_components_hold(bridge); /* each part held at its own gauge */
    int status = update_run(bridge);
    if (status == PGEM_ERR_FILL_BUDGET && bridge->options.compact &&
        compact_to(bridge, (uint32_t)(COMPACT_LOW * pgem_pose_count(bridge->solver.core)))) {
        /* the graph fits its poses and edges but its factor has outgrown the fill budget
         * (carried loops concentrate on the poses kept): a smaller graph, then the update */
        bridge_log(bridge, "the incremental factor outgrew its fill budget: compacted to %u poses",
                   pgem_pose_count(bridge->solver.core));
        (void)bridge_components_hold(bridge);
        status = update_run(bridge);
    }
    if (status != PGEM_OK) {
        bridge->solver.restart_pending = 1; /* the next solve restarts from the front-end's estimates */
        bridge_log(bridge, "incremental update failed: %s (%s); the next solve restarts from the "
                           "front-end's estimates", pgem_error_name(status),
                   pgem_last_error(bridge->solver.core));
        return;
    }
    bridge->solver.solved_poses = pgem_pose_count(bridge->solver.core);
    memset(bridge->solver.anchored, 0, bridge->solver.solved_poses);
}

/* What a robust solve's summary would say of the loops, from the bridge's counts (loops,
 * pruned, the outcome a robust solve would give for them); chi2 not computed (NaN): that
 * visits every edge, and an update's cost must not grow with the map. */
static void counts_summary(const bridge_t *bridge, pgem_robust_summary_t *summary)
{
    summary->loops = bridge->solver.loop_count;
    summary->pruned = bridge->solver.pruned_count;
    summary->rejected = summary->pruned;
    summary->final_chi2 = (double)NAN;
    summary->final_chi2_all = (double)NAN;
    summary->initial_chi2 = (double)NAN;
    summary->outcome = summary->loops == 0u                  ? PGEM_ROBUST_NO_LOOPS
                       : summary->pruned == summary->loops   ? PGEM_ROBUST_ALL_REJECTED
                       : 10u * summary->pruned > 9u * summary->loops ? PGEM_ROBUST_MOST_REJECTED
                                                             : PGEM_ROBUST_LOOPS_ACCEPTED;
}

/* One incremental update; the summary gets what a robust solve's would say of the loops. Its
 * chi2 is not computed (NaN): that visits every edge, and the updates' cost must not grow
 * with the map; the settle and --full solves report it. */
static int update_solve(bridge_t *bridge, pgem_robust_summary_t *summary)
{
    const int status = update_run(bridge);
    counts_summary(bridge, summary);
    summary->usable = status == PGEM_OK;
    summary->estimate_changed = status == PGEM_OK;
    return status;
}

void bridge_graph_solve(bridge_t *bridge, const char *trigger)
{
    pthread_mutex_lock(&bridge->handoff.lock);
    bridge->handoff.solving = 1;
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
    const pgem_solve_options_t *solve = bridge->solver.settle_yields ? &give_way : NULL;
    int status = incremental ? update_solve(bridge, &summary)
                             : pgem_robust_optimize(bridge->solver.core, &robust, solve, &summary);
    if (bridge->solver.settle_yields && status == PGEM_OK &&
        summary.termination == PGEM_ROBUST_STOPPED && !bridge_stopping(bridge)) {
        settle_restore(bridge); /* items arrived: the incremental map goes on from the last update */
        bridge->solver.settle_gave_way = 1;
        pthread_mutex_lock(&bridge->handoff.lock);
        bridge->handoff.solving = 0;
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
        bridge_graph_drop_pass(bridge);
    }
    int64_t micros = (int64_t)((bridge_now() - start) * 1e6);
    double solved = bridge_now();
    char why[256] = "";
    solved_or_not(bridge, status, &summary, why, sizeof why);
    if (!incremental) {
        bridge->solver.pruned_count = summary.pruned;
        bridge->solver.counted_edges = pgem_edge_count(bridge->solver.core);
    }
    bridge_graph_counts(bridge);
    bridge_graph_publish(bridge, trigger, &summary, status == PGEM_OK, why, micros);
    double published = bridge_now();
    pthread_mutex_lock(&bridge->handoff.lock);
    bridge->handoff.solving = 0;
    bridge->handoff.solves++;
    pthread_mutex_unlock(&bridge->handoff.lock);
    if (status == PGEM_OK) { /* after the graph: it never waits for the covariance */
        bridge_covariance_publish(bridge, !incremental);
    }
    if (status == PGEM_OK) {
        bridge_log(bridge,
                   "solve %lld (%s%s): %u poses, %u loops, %u pruned, chi2 %.6g, %u rounds, "
                   "%.1f ms (publishing %.1f ms)%s",
                   (long long)bridge->solver.solve_id, trigger,
                   restarted   ? (from_live
                                      ? ", restarted from the live estimate, every loop back in"
                                      : ", restarted from the front-end's estimates")
                   : incremental ? ", incremental"
                                 : "",
                   pgem_pose_count(bridge->solver.core), summary.loops, summary.pruned,
                   summary.final_chi2, summary.rounds, 1e-3 * (double)micros,
                   1e3 * (published - solved), parts > 1 ? " (graph in several parts: each held at its own gauge)" : "");
        if (why[0] != '\0') {
            bridge_note(bridge, "solve %lld: %s", (long long)bridge->solver.solve_id, why);
        }
    } else {
        bridge_note(bridge, "solve %lld (%s) failed: %s%s", (long long)bridge->solver.solve_id, trigger,
                    why, bridge->solver.live_failed ? "; the next solve restarts from the front-end's "
                                               "estimates" : "");
    }
    bridge_publish_status(bridge);
}

/* Loop closures pruned, counted over the whole graph (after a pass changed verdicts
 * anywhere): O(edges), once per pass. */
static void recount_pruned(bridge_t *bridge)
{
    bridge->solver.pruned_count = 0;
    bridge->solver.counted_edges = 0;
    count_new_pruned(bridge);
}

/* 1 when every loop closure the pass judged has the same verdict in the live map (accepted or
 * pruned): adopting it would change only the estimate, by EM's soft weights, and cost the
 * update a rebuild. O(edges of the pass). */
static int same_verdicts(const pgem_t *live, const pgem_t *pass)
{
    const uint32_t edges = pgem_edge_count(pass);
    if (edges > pgem_edge_count(live)) {
        return 0;
    }
    for (uint32_t k = 0; k < edges; ++k) {
        pgem_edge_view_t a, b;
        pgem_edge_at(live, k, &a);
        pgem_edge_at(pass, k, &b);
        /* accepted: in, above the prune threshold's default (pgem eval's --reject-below) */
        const int in_live = a.active && a.weight >= 0.01, in_pass = b.active && b.weight >= 0.01;
        if (a.kind == PGEM_EDGE_LOOP && in_live != in_pass) {
            return 0;
        }
    }
    return 1;
}

/* A finished pass into the live map, when the graph it copied is still the live one's prefix:
 * its estimate and verdicts (pgem_update_adopt), then an update at them (a rebuild; loops
 * that arrived since keep the gate's verdicts), published; a pass that agrees with the live
 * verdicts is only logged and its graph published again. */
static void adopt_pass(bridge_t *bridge)
{
    bridge_pass_t *pass = &bridge->solver.pass;
    const double start = bridge_now();
    if (pass->status != PGEM_OK || pass->summary.termination == PGEM_ROBUST_STOPPED ||
        pass->generation != bridge->solver.generation || bridge->solver.restart_pending) {
        bridge_log(bridge, "live EM pass dropped (%s)",
                   pass->status != PGEM_OK ? pgem_error_name(pass->status)
                   : pass->generation != bridge->solver.generation ? "the graph was re-solved or reset since its copy"
                   : pass->summary.termination == PGEM_ROBUST_STOPPED ? "stopped"
                                                                       : "a restart is owed");
        return;
    }
    if (same_verdicts(bridge->solver.core, pass->core)) {
        /* The live map holds what the pass found: no rebuild for nothing. Its graph goes out
         * again, so a consumer knows a pass confirmed the map up to then. */
        pass->agreed++;
        pass->passes++;
        pgem_robust_summary_t same;
        memset(&same, 0, sizeof same);
        counts_summary(bridge, &same);
        same.rounds = pass->summary.rounds;
        char why[256] = "";
        describe_outcome(&same, why, sizeof why);
        bridge_graph_publish(bridge, "em-pass", &same, 1, why, 0);
        bridge_covariance_publish(bridge, 0);
        bridge_log(bridge,
                   "live EM pass %llu: EM on %u poses and %u loops (%u pruned, %u rounds) in "
                   "%.0f ms: the live map has the same verdicts, nothing to adopt",
                   (unsigned long long)pass->passes, pgem_pose_count(pass->core),
                   pass->loops_at_copy, pass->summary.pruned, pass->summary.rounds,
                   1e3 * pass->solve_took);
        return;
    }
    pgem_adopt_summary_t adopted;
    int status = pgem_update_adopt(bridge->solver.core, pass->core, &adopted);
    if (status != PGEM_OK) {
        bridge_note(bridge, "live EM pass not adopted: %s", pgem_last_error(bridge->solver.core));
        return;
    }
    pgem_robust_summary_t summary;
    memset(&summary, 0, sizeof summary);
    const double adopted_at = bridge_now();
    status = update_solve(bridge, &summary);
    const double updated_at = bridge_now();
    recount_pruned(bridge);
    counts_summary(bridge, &summary);
    summary.rounds = pass->summary.rounds;
    char why[256] = "";
    solved_or_not(bridge, status, &summary, why, sizeof why);
    if (status != PGEM_OK) {
        bridge->solver.restart_pending = 1; /* the next solve says why, from the front-end's estimates */
    }
    pass->passes++;
    const int64_t micros = (int64_t)((bridge_now() - start) * 1e6);
    bridge_graph_counts(bridge);
    bridge_graph_publish(bridge, "em-pass", &summary, status == PGEM_OK, why, micros);
    if (status == PGEM_OK) {
        bridge_covariance_publish(bridge, 0);
    }
    bridge_log(bridge,
               "live EM pass %llu: EM on %u poses and %u loops (%u pruned, %u rounds) in %.0f ms, "
               "%.0f ms after its copy; adopted: %u verdicts changed, %u later poses carried; "
               "now %u of %u loops pruned (%.1f ms: adopt %.1f, update %.1f)",
               (unsigned long long)pass->passes, adopted.poses_adopted, pass->loops_at_copy,
               pass->summary.pruned, pass->summary.rounds, 1e3 * pass->solve_took,
               1e3 * pass->took, adopted.loops_changed, adopted.poses_carried,
               bridge->solver.pruned_count, bridge->solver.loop_count,
               1e-3 * (double)micros, 1e3 * (adopted_at - start), 1e3 * (updated_at - adopted_at));
    if (status != PGEM_OK) {
        bridge_note(bridge, "the update after live EM pass %llu failed: %s",
                    (unsigned long long)pass->passes, why);
    }
    bridge_publish_status(bridge);
}

double bridge_graph_pass_due(const bridge_t *bridge)
{
    return bridge->solver.pass_on && bridge->solver.pass.state == BRIDGE_PASS_IDLE &&
                   bridge->solver.loop_count != bridge->solver.pass_loops
               ? bridge->solver.pass_next
               : (double)INFINITY;
}

void bridge_graph_pass(bridge_t *bridge)
{
    if (!bridge->solver.pass_on) {
        return;
    }
    const int state = bridge_pass_state(&bridge->solver.pass);
    if (state == BRIDGE_PASS_RUNNING) {
        return;
    }
    const double now = bridge_now();
    if (state == BRIDGE_PASS_DONE) {
        adopt_pass(bridge);
        bridge->solver.pass_took = bridge->solver.pass.took;
        bridge->solver.pass_next = now + bridge->solver.pass_took; /* at most half the time in passes */
        bridge_pass_release(&bridge->solver.pass);
    }
    /* The next one: when loop closures arrived since the last copy, the map is up to date (no
     * restart owed), and the last pass's time has passed since it ended. */
    if (now < bridge->solver.pass_next || bridge->solver.loop_count == bridge->solver.pass_loops) {
        return;
    }
    (void)bridge_components_hold(bridge); /* the copy holds each part where the live map does */
    if (bridge->solver.restart_pending || bridge->solver.solved_poses != pgem_pose_count(bridge->solver.core)) {
        bridge->solver.pass_next = now + 0.05; /* not now: look again a little later */
        return;
    }
    if (bridge_pass_start(&bridge->solver.pass, bridge->solver.core,
                          bridge->solver.compactions == 0u ? bridge->solver.raw : NULL, bridge->solver.generation, now) != 0) {
        bridge_note(bridge, "live EM pass: cannot copy the graph: %s",
                    pgem_last_error(bridge->solver.pass.core));
        bridge->solver.pass_on = 0;
        return;
    }
    bridge->solver.pass_loops = bridge->solver.loop_count;
}

int bridge_out_ready(bridge_t *bridge, int size, const char *what)
{
    if (size > 0 && (size_t)size <= bridge->solver.out_buffer_size) {
        return 1;
    }
    unsigned char *grown = size > 0 ? realloc(bridge->solver.out_buffer, (size_t)size) : NULL;
    if (grown == NULL) {
        bridge_note(bridge, "cannot encode %s (%d bytes)", what, size);
        return 0;
    }
    bridge->solver.out_buffer = grown;
    bridge->solver.out_buffer_size = (size_t)size;
    return 1;
}

void bridge_out_publish(bridge_t *bridge, const char *channel, const char *what, int size,
                        int encoded)
{
    if (encoded != size) {
        bridge_note(bridge, "cannot encode %s (%d bytes)", what, size);
        return;
    }
    if (lcm_publish(bridge->lcm, channel, bridge->solver.out_buffer, (unsigned)size) != 0) {
        bridge_note(bridge, "LCM refused to publish %s (%d bytes) on %s", what, size, channel);
    }
}

void bridge_graph_publish(bridge_t *bridge, const char *trigger,
                          const pgem_robust_summary_t *summary, int usable, const char *why,
                          int64_t solve_time_us)
{
    pgem_t *core = bridge->solver.core;
    int dimension = bridge->options.dimension;
    pgem_graph_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = bridge_utime();
    bridge->solver.graph_utime = msg.utime;
    msg.dimension = (int8_t)dimension;
    msg.num_poses = (int32_t)pgem_pose_count(core);
    msg.pose_size = PGEM_POSE_SIZE(dimension);
    for (uint32_t i = 0; i < (uint32_t)msg.num_poses; ++i) {
        pgem_id_t id = 0;
        pgem_pose_at(core, i, &id, bridge->solver.out_rows[i], NULL);
        bridge->solver.out_ids[i] = (int64_t)id;
    }
    msg.ids = bridge->solver.out_ids;
    msg.poses = bridge->solver.out_rows;
    uint32_t loops = 0;
    for (uint32_t k = 0; k < pgem_edge_count(core); ++k) {
        pgem_edge_view_t view;
        pgem_edge_at(core, k, &view);
        if (view.kind != PGEM_EDGE_LOOP) {
            continue;
        }
        pgem_loop_t *loop = &bridge->solver.out_loops[loops++];
        loop->source_index = bridge->solver.edge_source[k];
        loop->sequence = bridge->solver.edge_sequence[k];
        loop->from = (int64_t)view.from;
        loop->to = (int64_t)view.to;
        loop->weight = view.weight;
        loop->state = view.active ? PGEM_LOOP_T_ACCEPTED : PGEM_LOOP_T_PRUNED;
    }
    msg.num_loops = (int32_t)loops;
    msg.loops = bridge->solver.out_loops;
    /* The source names, copied under the lock: the reception thread may free a slot (a
     * source whose last waiting edge expired) or give it to a new name meanwhile. */
    pthread_mutex_lock(&bridge->handoff.lock);
    uint32_t sources = pgem_ingest_source_count(bridge->handoff.ingest);
    for (uint32_t s = 0; s < sources; ++s) {
        char *name = bridge->solver.out_names + (size_t)s * PGEM_SOURCE_MAX;
        snprintf(name, PGEM_SOURCE_MAX, "%s", pgem_ingest_source_name(bridge->handoff.ingest, s));
        bridge->solver.out_sources[s] = name;
        bridge->solver.out_last[s] = bridge->solver.source_last[s];
    }
    pthread_mutex_unlock(&bridge->handoff.lock);
    msg.num_sources = (int32_t)sources;
    msg.sources = bridge->solver.out_sources;
    msg.last_sequence = bridge->solver.out_last;
    msg.edges_included = pgem_edge_count(core);
    char trigger_text[32];
    char why_text[256];
    snprintf(trigger_text, sizeof trigger_text, "%s", trigger);
    snprintf(why_text, sizeof why_text, "%s", why != NULL ? why : "");
    msg.stats.solve_id = ++bridge->solver.solve_id;
    msg.stats.trigger = trigger_text;
    msg.stats.usable = (int8_t)usable;
    msg.stats.message = why_text;
    if (summary != NULL) {
        msg.stats.initial_chi2 = summary->initial_chi2;
        msg.stats.chi2 = summary->final_chi2;
        msg.stats.em_rounds = (int32_t)summary->rounds;
        msg.stats.em_iterations = (int32_t)summary->em_iterations;
        msg.stats.gn_iterations = (int32_t)summary->gn_iterations;
        msg.stats.pruned = (int32_t)summary->pruned;
    }
    msg.stats.solve_time_us = solve_time_us;
    msg.stats.poses = msg.num_poses;
    msg.stats.edges = (int32_t)msg.edges_included;
    msg.stats.loops = msg.num_loops;
    const int size = pgem_graph_t_encoded_size(&msg);
    if (bridge_out_ready(bridge, size, "the graph")) {
        bridge_out_publish(bridge, bridge->options.channels.graph, "the graph", size,
                    pgem_graph_t_encode(bridge->solver.out_buffer, 0, size, &msg));
    }
}

/* What a snapshot file holds, written to a stream. */
typedef int (*snapshot_writer_fn)(FILE *stream, const pgem_t *core);

static int write_graph(FILE *stream, const pgem_t *core)
{
    pgem_io_graph_t graph;
    int status = pgem_io_from_instance(core, &graph);
    if (status == PGEM_OK) {
        status = pgem_io_write_stream(stream, PGEM_FORMAT_G2O, &graph);
        pgem_io_graph_free(&graph);
    }
    return status;
}

/* Writes a new hidden temporary file in the snapshot folder for NAME (O_EXCL | O_NOFOLLOW,
 * so nothing planted there is followed or reused), synced; its name into temporary and its
 * size into *bytes. 0, or -1 with message (nothing left behind). */
static int snapshot_temporary(const bridge_t *bridge, const char *name,
                              snapshot_writer_fn writer, char *temporary, size_t temporary_size,
                              uint64_t *bytes, char *message, size_t message_size)
{
    int dir = bridge->snapshot_dir;
    int fd = -1;
    for (unsigned attempt = 0; fd < 0 && attempt < 100; ++attempt) {
        snprintf(temporary, temporary_size, ".%s.%ld.%u.tmp", name, (long)getpid(), attempt);
        fd = openat(dir, temporary, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
        if (fd < 0 && errno != EEXIST) {
            break;
        }
    }
    if (fd < 0) {
        snprintf(message, message_size, "%s: cannot create a temporary file: %s", name,
                 strerror(errno));
        return -1;
    }
    FILE *stream = fdopen(fd, "w");
    struct stat info;
    int failed = stream == NULL || writer(stream, bridge->solver.core) != PGEM_OK ||
                 fflush(stream) != 0 || fsync(fd) != 0 || fstat(fd, &info) != 0;
    int saved = errno;
    if (stream != NULL ? fclose(stream) != 0 : close(fd) != 0) {
        failed = 1;
        saved = errno;
    }
    if (failed) {
        unlinkat(dir, temporary, 0);
        snprintf(message, message_size, "%s: cannot write: %s", name, strerror(saved));
        return -1;
    }
    *bytes = (uint64_t)info.st_size;
    return 0;
}

/* A name in the snapshot folder a snapshot may replace: absent, a file or a symlink (a
 * rename replaces a symlink, never writes through it). 1, or 0 with the reason. */
static int snapshot_target_ok(const bridge_t *bridge, const char *name, char *message,
                              size_t message_size)
{
    struct stat info;
    if (fstatat(bridge->snapshot_dir, name, &info, AT_SYMLINK_NOFOLLOW) != 0 ||
        S_ISREG(info.st_mode) || S_ISLNK(info.st_mode)) {
        return 1;
    }
    snprintf(message, message_size, "%s is %s, not a file a snapshot may replace", name,
             S_ISDIR(info.st_mode) ? "a folder" : "a special file");
    return 0;
}

/* A snapshot is whole or absent (issue 31): NAME and NAME.weights are both written to
 * temporary files first; only when both are complete are they renamed into place, the
 * weights first, then the graph; if the graph's rename fails the new NAME.weights is removed,
 * so a failure leaves no new half (an older NAME or NAME.weights stays as it was, unless
 * that removal is what replaced it). A folder or special file at either name refuses the
 * snapshot before anything is written. */
void bridge_graph_snapshot(bridge_t *bridge, const char *name)
{
    char message[PGEM_PATH_MAX + 512] = "";
    char weights[PGEM_SNAPSHOT_NAME_MAX + 16];
    char graph_temporary[PGEM_SNAPSHOT_NAME_MAX + 64] = "";
    char weights_temporary[PGEM_SNAPSHOT_NAME_MAX + 80] = "";
    snprintf(weights, sizeof weights, "%s.weights", name);
    uint64_t graph_bytes = 0;
    uint64_t weights_bytes = 0;
    const int dir = bridge->snapshot_dir;
    int done = snapshot_target_ok(bridge, name, message, sizeof message) &&
               snapshot_target_ok(bridge, weights, message, sizeof message) &&
               snapshot_temporary(bridge, name, write_graph, graph_temporary,
                                  sizeof graph_temporary, &graph_bytes, message,
                                  sizeof message) == 0;
    if (done && snapshot_temporary(bridge, weights, pgem_io_write_weights, weights_temporary,
                                   sizeof weights_temporary, &weights_bytes, message,
                                   sizeof message) != 0) {
        unlinkat(dir, graph_temporary, 0);
        done = 0;
    }
    if (done && renameat(dir, weights_temporary, dir, weights) != 0) {
        snprintf(message, sizeof message, "%s: cannot write: %s", weights, strerror(errno));
        unlinkat(dir, weights_temporary, 0);
        unlinkat(dir, graph_temporary, 0);
        done = 0;
    }
    if (done && renameat(dir, graph_temporary, dir, name) != 0) {
        snprintf(message, sizeof message, "%s: cannot write: %s (the new %s removed again)",
                 name, strerror(errno), weights);
        unlinkat(dir, graph_temporary, 0);
        unlinkat(dir, weights, 0);
        done = 0;
    }
    if (done) {
        pthread_mutex_lock(&bridge->handoff.lock);
        bridge_snapshot_written(bridge, graph_bytes + weights_bytes);
        pthread_mutex_unlock(&bridge->handoff.lock);
        bridge_note(bridge, "snapshot: %s/%s (%u poses, %u edges) and %s, %.1f MiB",
                    bridge->options.snapshot_dir, name, pgem_pose_count(bridge->solver.core),
                    pgem_edge_count(bridge->solver.core), weights,
                    (double)(graph_bytes + weights_bytes) / 1048576.0);
    } else {
        bridge_note(bridge, "snapshot failed, nothing written: %s/%s",
                    bridge->options.snapshot_dir, message);
    }
}
