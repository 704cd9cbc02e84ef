/* The solver thread's messages: each is encoded into one buffer sized as it grows and
 * published on its channel (graph_t after every solve or update, team.c's team_t right after
 * it, compaction_t after each compaction; covariance.c's covariance_t the same way). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bridge_internal.h"
#include "pgem_compaction_t.h"

int bridge_out_ready(bridge_t *bridge, int size, const char *what)
{
    if (size > 0 && (size_t)size <= bridge->solver.out.buffer_size) {
        return 1;
    }
    unsigned char *grown = size > 0 ? realloc(bridge->solver.out.buffer, (size_t)size) : NULL;
    if (grown == NULL) {
        bridge_note(bridge, "cannot encode %s (%d bytes)", what, size);
        return 0;
    }
    bridge->solver.out.buffer = grown;
    bridge->solver.out.buffer_size = (size_t)size;
    return 1;
}

void bridge_out_publish(bridge_t *bridge, const char *channel, const char *what, int size,
                        int encoded)
{
    if (encoded != size) {
        bridge_note(bridge, "cannot encode %s (%d bytes)", what, size);
        return;
    }
    if (lcm_publish(bridge->lcm, channel, bridge->solver.out.buffer, (unsigned)size) != 0) {
        bridge_note(bridge, "LCM refused to publish %s (%d bytes) on %s", what, size, channel);
    }
}

void bridge_publish_graph(bridge_t *bridge, const char *trigger,
                          const pgem_robust_summary_t *summary, int usable, const char *why,
                          int64_t solve_time_us)
{
    pgem_t *core = bridge->solver.core;
    int dimension = bridge->options.dimension;
    pgem_graph_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = bridge_utime();
    bridge->solver.out.graph_utime = msg.utime;
    msg.dimension = (int8_t)dimension;
    msg.num_poses = (int32_t)pgem_pose_count(core);
    msg.pose_size = PGEM_POSE_SIZE(dimension);
    for (uint32_t i = 0; i < (uint32_t)msg.num_poses; ++i) {
        pgem_id_t id = 0;
        pgem_pose_at(core, i, &id, bridge->solver.out.rows[i], NULL);
        bridge->solver.out.ids[i] = (int64_t)id;
    }
    msg.ids = bridge->solver.out.ids;
    msg.poses = bridge->solver.out.rows;
    uint32_t loops = 0;
    for (uint32_t k = 0; k < pgem_edge_count(core); ++k) {
        pgem_edge_view_t view;
        pgem_edge_at(core, k, &view);
        if (view.kind != PGEM_EDGE_LOOP) {
            continue;
        }
        pgem_loop_t *loop = &bridge->solver.out.loops[loops++];
        loop->source_index = bridge->solver.edge_source[k];
        loop->sequence = bridge->solver.edge_sequence[k];
        loop->from = (int64_t)view.from;
        loop->to = (int64_t)view.to;
        loop->weight = view.weight;
        loop->state = view.active ? PGEM_LOOP_T_ACCEPTED : PGEM_LOOP_T_PRUNED;
    }
    msg.num_loops = (int32_t)loops;
    msg.loops = bridge->solver.out.loops;
    /* The source names, copied under the lock: the reception thread may free a slot (a
     * source whose last waiting edge expired) or give it to a new name meanwhile. */
    pthread_mutex_lock(&bridge->handoff.lock);
    uint32_t sources = pgem_ingest_source_count(bridge->handoff.ingest);
    for (uint32_t s = 0; s < sources; ++s) {
        char *name = bridge->solver.out.names + (size_t)s * PGEM_SOURCE_MAX;
        snprintf(name, PGEM_SOURCE_MAX, "%s", pgem_ingest_source_name(bridge->handoff.ingest, s));
        bridge->solver.out.sources[s] = name;
        bridge->solver.out.last[s] = bridge->solver.source_last[s];
    }
    pthread_mutex_unlock(&bridge->handoff.lock);
    msg.num_sources = (int32_t)sources;
    msg.sources = bridge->solver.out.sources;
    msg.last_sequence = bridge->solver.out.last;
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
                    pgem_graph_t_encode(bridge->solver.out.buffer, 0, size, &msg));
    }
    bridge_publish_team(bridge, msg.utime, sources);
}


/* pgem.compaction_t: the poses one compaction removed, each with its anchor and where it lies
 * in the anchor's frame (compact_relative holds the reverse, for the ingest). */
void bridge_publish_compaction(bridge_t *bridge, const pgem_compact_summary_t *summary,
                               uint32_t removed, int full)
{
    const int dimension = bridge->options.dimension;
    const size_t pose_size = (size_t)PGEM_POSE_SIZE(dimension);
    for (uint32_t i = 0; i < removed; ++i) {
        const double *anchor_in_removed = bridge->solver.compaction.relative + i * pose_size;
        (dimension == 3 ? pgem_se3_inverse : pgem_se2_inverse)(anchor_in_removed,
                                                                bridge->solver.out.rows[i]);
        bridge->solver.out.ids[i] = (int64_t)bridge->solver.compaction.ids[i];
        bridge->solver.out.anchors[i] = (int64_t)bridge->solver.compaction.anchors[i];
    }
    pgem_compaction_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = bridge_utime();
    msg.compaction = (int64_t)bridge->solver.compaction.count;
    msg.dimension = (int8_t)dimension;
    msg.pose_size = (int32_t)pose_size;
    msg.num_removed = (int32_t)removed;
    msg.ids = bridge->solver.out.ids;
    msg.anchors = bridge->solver.out.anchors;
    msg.relative = bridge->solver.out.rows;
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
                    pgem_compaction_t_encode(bridge->solver.out.buffer, 0, size, &msg));
    }
}
