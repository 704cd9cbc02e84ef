/* The solver thread's items into the core: a pose (its raw estimate kept, placed by its
 * odometry from a solved pose), an edge (its source and sequence kept; onto its anchor when a
 * compaction removed its pose while it waited), a reset. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <string.h>

#include "bridge_internal.h"

static void core_refused(bridge_t *bridge, const char *what, int status)
{
    if (status == PGEM_ERR_CAPACITY && bridge->options.compact) {
        /* admitted beyond the block while compaction could free nothing */
        pthread_mutex_lock(&bridge->handoff.lock);
        bridge->handoff.graph.full_rejections++;
        pthread_mutex_unlock(&bridge->handoff.lock);
        bridge_note(bridge, "rejected (full): %s: the block is full and compaction can free "
                            "nothing (%s)", what, pgem_last_error(bridge->solver.core));
        return;
    }
    pthread_mutex_lock(&bridge->handoff.lock);
    bridge->handoff.graph.core_rejections++;
    pthread_mutex_unlock(&bridge->handoff.lock);
    bridge_note(bridge, "the core refused %s: %s (%s)", what, pgem_error_name(status),
                pgem_last_error(bridge->solver.core));
}

static int pose_settled(const bridge_t *bridge, uint32_t index)
{
    return index < bridge->solver.solved_poses || bridge->solver.anchored[index] ||
           bridge->solver.gauge_fixed[index];
}

/* A pose that arrived after the last solve carries the front-end's estimate, in the front-end's
 * drifting frame; the solved poses have moved since. When an odometry edge joins a settled pose
 * to such a new one, the new pose is placed by the measurement from the settled one, so the
 * next solve starts near its optimum and the E-step judges new loop closures fairly. */
static void anchor(bridge_t *bridge, const pgem_item_t *item)
{
    uint32_t from = 0;
    uint32_t to = 0;
    if (bridge->solver.solved_poses == 0 ||
        pgem_pose_index(bridge->solver.core, item->from, &from) != PGEM_OK ||
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
        pgem_pose(bridge->solver.core, item->from, base);
        memcpy(step, item->value, sizeof step);
    } else if (pose_settled(bridge, to) && !pose_settled(bridge, from)) {
        target = from;
        target_id = item->from;
        pgem_pose(bridge->solver.core, item->to, base);
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


static void reset_graph(bridge_t *bridge)
{
    pgem_init(&bridge->solver.core, &bridge->solver.core_config, bridge->solver.core_block,
              bridge->solver.core_block_size);
    memset(bridge->solver.anchored, 0, bridge->options.max_poses);
    memset(bridge->solver.user_fixed, 0, bridge->options.max_poses);
    memset(bridge->solver.gauge_fixed, 0, bridge->options.max_poses);
    for (uint32_t s = 0; s < bridge->options.max_sources; ++s) {
        bridge->solver.source_last[s] = -1;
    }
    bridge->solver.solved_poses = 0;
    bridge->solver.restart_pending = 0;
    bridge_pass_drop(bridge);
    bridge->solver.live_em.loops = 0;
    bridge_components_reset(bridge);
    bridge->solver.loop_count = 0;
    bridge->solver.pruned_count = 0;
    bridge->solver.outcome = PGEM_ROBUST_NO_LOOPS;
    bridge_solver_counts(bridge);
}

int bridge_apply(bridge_t *bridge, const pgem_item_t *item)
{
    char what[160];
    if (item->type == PGEM_ITEM_RESET) {
        reset_graph(bridge);
        bridge_publish_graph(bridge, "reset", NULL, 0, "the graph was reset", 0);
        bridge_note(bridge, "reset: the graph is empty");
        return 0;
    }
    if (item->type == PGEM_ITEM_POSE) {
        int status = pgem_add_pose(bridge->solver.core, item->from, item->value);
        const uint32_t index = pgem_pose_count(bridge->solver.core) - 1;
        if (status == PGEM_OK) {
            size_t pose_size = (size_t)PGEM_POSE_SIZE(bridge->options.dimension);
            memcpy(bridge->solver.raw + index * pose_size, item->value,
                   pose_size * sizeof(double));
            /* A new pose starts unanchored, unfixed and unheld, whatever pose sat at its index
             * before a compaction freed it: a stale hold flag counted a new part's gauge as
             * held while the core's pose was free (the factor singular), a stale 'anchored'
             * counted the pose as settled (not placed by its odometry). */
            bridge->solver.anchored[index] = 0;
            bridge->solver.user_fixed[index] = 0;
            bridge->solver.gauge_fixed[index] = 0;
        }
        if (status == PGEM_OK && item->kind) {
            status = pgem_fix_pose(bridge->solver.core, item->from, 1);
            bridge->solver.user_fixed[index] = 1;
        }
        if (status != PGEM_OK) {
            snprintf(what, sizeof what, "pose %llu", (unsigned long long)item->from);
            core_refused(bridge, what, status);
        } else {
            (void)bridge_compact(bridge);
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
            status = pgem_add_edge(bridge->solver.core, moved.from, moved.to, moved.value,
                                   information, (pgem_edge_kind_t)moved.kind, &index);
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
