/* The solver thread's compaction (--compact): near its capacities the graph loses its oldest
 * poses (pgem_compact), the bridge's per-pose and per-edge arrays follow, and the ingest learns
 * the removed poses' anchors. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <string.h>

#include "bridge_internal.h"

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
    const uint32_t *map = bridge->solver.compaction.pose_map;
    uint32_t solved = 0;
    for (uint32_t i = 0; i < before; ++i) {
        const uint32_t j = map[i];
        if (j == UINT32_MAX) {
            continue;
        }
        solved += i < bridge->solver.solved_poses;
        memmove(bridge->solver.raw + j * pose_size, bridge->solver.raw + i * pose_size,
                pose_size * sizeof(double));
        bridge->solver.anchored[j] = bridge->solver.anchored[i];
        bridge->solver.user_fixed[j] = bridge->solver.user_fixed[i];
        bridge->solver.gauge_fixed[j] = bridge->solver.gauge_fixed[i];
    }
    bridge->solver.solved_poses = solved;
}

/* Compacts to target_poses and the low mark of the edges (see bridge_compact). */
static int compact_to(bridge_t *bridge, uint32_t target_poses);

int bridge_compact(bridge_t *bridge)
{
    const pgem_bridge_options_t *o = &bridge->options;
    const uint32_t poses = pgem_pose_count(bridge->solver.core),
                   edges = pgem_edge_count(bridge->solver.core);
    if (!o->compact || ((double)poses < COMPACT_HIGH * o->max_poses &&
                          (double)edges < COMPACT_HIGH * o->max_edges)) {
        return 0;
    }
    return compact_to(bridge, (uint32_t)(COMPACT_LOW * o->max_poses));
}

int bridge_compact_further(bridge_t *bridge)
{
    return compact_to(bridge, (uint32_t)(COMPACT_LOW * pgem_pose_count(bridge->solver.core)));
}

static int compact_to(bridge_t *bridge, uint32_t target_poses)
{
    const pgem_bridge_options_t *o = &bridge->options;
    pgem_t *core = bridge->solver.core;
    const uint32_t poses = pgem_pose_count(core), edges = pgem_edge_count(core);
    const double start = bridge_now();
    const size_t pose_size = (size_t)PGEM_POSE_SIZE(o->dimension);
    for (uint32_t i = 0; i < poses; ++i) { /* ids and estimates before: the ingest's anchors */
        pgem_pose_at(core, i, &bridge->solver.compaction.ids[i],
                     bridge->solver.compaction.before + i * pose_size, NULL);
    }
    pgem_compact_options_t options;
    memset(&options, 0, sizeof options);
    options.tail = o->compact_tail != 0u ? o->compact_tail : COMPACT_TAIL;
    options.pose_map = bridge->solver.compaction.pose_map;
    options.edge_map = bridge->solver.compaction.edge_map;
    pgem_compact_summary_t summary;
    options.target_edges = (uint32_t)(COMPACT_LOW * o->max_edges);
    options.keep_pruned = 1; /* the gate's verdicts are provisional: a live EM pass decides */
    pgem_compact(core, target_poses, &options, &summary);
    uint32_t removed_ids = 0, removed_edges = 0, kept = UINT32_MAX;
    for (uint32_t i = 0; i < poses; ++i) { /* each removed pose's anchor: the kept one before */
        if (bridge->solver.compaction.pose_map[i] != UINT32_MAX) {
            kept = i;
            continue;
        }
        uint32_t anchor = kept;
        for (uint32_t j = i + 1; anchor == UINT32_MAX && j < poses; ++j) {
            anchor = bridge->solver.compaction.pose_map[j] != UINT32_MAX ? j : UINT32_MAX;
        }
        bridge->solver.compaction.anchors[removed_ids] = bridge->solver.compaction.ids[anchor];
        (o->dimension == 3 ? pgem_se3_between : pgem_se2_between)(
            bridge->solver.compaction.before + i * pose_size,
            bridge->solver.compaction.before + anchor * pose_size,
            bridge->solver.compaction.relative + removed_ids * pose_size);
        bridge->solver.compaction.ids[removed_ids++] = bridge->solver.compaction.ids[i];
    }
    for (uint32_t k = 0; k < edges; ++k) {
        const uint32_t j = bridge->solver.compaction.edge_map[k];
        if (j == UINT32_MAX) {
            bridge->solver.compaction.edges[removed_edges].source = bridge->solver.edge_source[k];
            bridge->solver.compaction.edges[removed_edges++].sequence =
                bridge->solver.edge_sequence[k];
            continue;
        }
        bridge->solver.edge_source[j] = bridge->solver.edge_source[k];
        bridge->solver.edge_sequence[j] = bridge->solver.edge_sequence[k];
    }
    compact_pose_arrays(bridge, poses);
    /* the parts again from the kept poses and edges (the holds stay where they were) */
    bridge_components_reset(bridge);
    (void)bridge_components_hold(bridge);
    bridge_pass_drop(bridge);
    bridge->solver.loop_count = 0; /* the loops kept, and of them pruned (the next update
                                    * rebuilds, and counts them too) */
    bridge->solver.pruned_count = 0;
    for (uint32_t k = 0; k < pgem_edge_count(core); ++k) {
        pgem_edge_view_t view;
        pgem_edge_at(core, k, &view);
        bridge->solver.loop_count += view.kind == PGEM_EDGE_LOOP;
        bridge->solver.pruned_count += view.kind == PGEM_EDGE_LOOP && !view.active;
    }
    bridge->solver.live_em.loops = 0;
    bridge_solver_counts(bridge);
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
    pgem_ingest_release(bridge->handoff.ingest, bridge->solver.compaction.ids,
                        bridge->solver.compaction.anchors, bridge->solver.compaction.relative,
                        removed_ids, bridge->solver.compaction.edges, removed_edges);
    if (full) {
        pgem_ingest_set_full(bridge->handoff.ingest, o->max_poses, o->max_edges, why);
    } else {
        pgem_ingest_set_full(bridge->handoff.ingest, 0u, 0u, NULL);
    }
    pthread_mutex_unlock(&bridge->handoff.lock);
    bridge->solver.compaction.count++;
    bridge_publish_compaction(bridge, &summary, removed_ids, full);
    bridge_log(bridge,
               "compaction %llu: %u -> %u poses, %u -> %u edges (%u odometry pairs composed, %u "
               "loop closures carried, %u pruned ones dropped) in %.1f ms; later edges to a "
               "removed pose enter on the kept pose before it",
               (unsigned long long)bridge->solver.compaction.count, summary.poses_before,
               summary.poses_after, summary.edges_before, summary.edges_after,
               summary.edges_composed, summary.loops_carried, summary.loops_dropped,
               1e3 * (bridge_now() - start));
    if (full && !bridge->solver.compaction.full) {
        bridge_note(bridge, "compaction cannot bring the graph under 90 %% of its capacities (%s): "
                            "poses and edges beyond the block will be refused as full", why);
    }
    bridge->solver.compaction.full = full;
    return 1;
}
