/* pgem_compact: poses removed in the block, each one's two odometry edges composed into one
 * and its loop closures carried onto a kept neighbour (graph/compose.c does the algebra).
 * The online layer owns it (a long mission's stream): a loop's verdict (weight, state) decides
 * whether the loop is carried or dropped, and the incremental factor must be told. Scratch: the
 * robust layer's copies for a failed solve (pose_initial, edge_weight_saved) and the loop distances
 * (edge_distance), none of which outlives a call: per pose its new index, its first edge end
 * and the sweep that last changed it (of the 24 bytes or more pose_initial holds); per edge
 * its new index (4 of edge_weight_saved's 8 bytes) and, per edge end, the next end of the
 * same pose (edge_distance's 8 bytes); fusing, per pose, the pose and loop that last reached
 * it (20 bytes a pose in all). */
#include <string.h>

#include "online/factor.h"

#define PGEM_COMPACT_TAIL 32u
/* A pose with more edges than this stays (the list of what it carries lives on the stack). */
#define PGEM_COMPACT_DEGREE 24
#define PGEM_COMPACT_GONE UINT32_MAX

typedef struct pgem_compactor {
    const pgem_online_parts_t *parts;
    uint32_t *pose_new; /* PGEM_COMPACT_GONE once removed */
    int32_t *first;     /* a pose's first edge end (2 k + side), -1 none */
    uint32_t *touched;  /* the sweep in which a pose's edges last changed */
    uint32_t *seen;     /* fusing: the pose whose loops last reached this one (+ 1) */
    uint32_t *seen_by;  /* fusing: the loop that did */
    uint32_t *edge_new; /* PGEM_COMPACT_GONE once removed */
    int32_t *next;      /* the next edge end of the same pose */
    uint32_t alive;
    uint32_t sweep;
    int keep_pruned;    /* pruned loops are carried too (options->keep_pruned) */
    pgem_compact_summary_t *summary;
} pgem_compactor_t;

/* What removing one pose takes: its two odometry edges (k1 to u, k2 to v) and its loops. */
typedef struct pgem_removal {
    uint32_t p, u, v, k1, k2;
    uint32_t loops[PGEM_COMPACT_DEGREE]; /* accepted or dormant: carried */
    int loop_count;
    uint32_t pruned[PGEM_COMPACT_DEGREE]; /* dropped */
    int pruned_count;
    int carried_u, carried_v; /* loops carried onto u (through k1) and onto v (through k2) */
} pgem_removal_t;

static uint32_t pgem_end_pose(const pgem_store_t *store, int32_t end)
{
    const uint32_t k = (uint32_t)end >> 1;
    return (end & 1) ? store->edge_to[k] : store->edge_from[k];
}

static void pgem_compact_push(pgem_compactor_t *c, int32_t end, uint32_t p)
{
    c->next[end] = c->first[p];
    c->first[p] = end;
}

/* The other pose of edge k than p. */
static uint32_t pgem_other(const pgem_store_t *store, uint32_t k, uint32_t p)
{
    return store->edge_from[k] == p ? store->edge_to[k] : store->edge_from[k];
}

/* 1 if pose p can go now (loops: whether live loop closures may be carried); fills r. */
static int pgem_compact_candidate(const pgem_compactor_t *c, uint32_t p, int loops,
                                  pgem_removal_t *r)
{
    const pgem_store_t *store = c->parts->store;
    if (store->pose_fixed[p] != 0u || PGEM_POSE_HELD(store, p)) {
        return 0;
    }
    int odometry = 0, edges = 0;
    uint32_t odo[2] = {0u, 0u};
    r->loop_count = 0;
    r->pruned_count = 0;
    for (int32_t end = c->first[p]; end >= 0; end = c->next[end]) {
        const uint32_t k = (uint32_t)end >> 1;
        if (c->edge_new[k] == PGEM_COMPACT_GONE || pgem_end_pose(store, end) != p) {
            continue;
        }
        if (++edges > PGEM_COMPACT_DEGREE) {
            return 0;
        }
        if (store->edge_kind[k] == PGEM_EDGE_ODOMETRY) {
            if (odometry == 2) {
                return 0;
            }
            odo[odometry++] = k;
        } else if (store->edge_active[k] == PGEM_EDGE_PRUNED && !c->keep_pruned) {
            r->pruned[r->pruned_count++] = k;
        } else if (!loops) {
            return 0;
        } else {
            r->loops[r->loop_count++] = k;
        }
    }
    if (odometry != 2) {
        return 0;
    }
    /* k1: the edge from the pose before (p its end), when the chain runs that way */
    const int swap = store->edge_to[odo[0]] != p && store->edge_to[odo[1]] == p;
    r->p = p;
    r->k1 = odo[swap];
    r->k2 = odo[1 - swap];
    r->u = pgem_other(store, r->k1, p);
    r->v = pgem_other(store, r->k2, p);
    r->carried_u = r->carried_v = 0;
    for (int q = 0; q < r->loop_count; q++) { /* a loop to u goes to v, any other to u */
        if (store->edge_active[r->loops[q]] == PGEM_EDGE_PRUNED) {
            continue; /* out of the problem: it takes no share of the odometry */
        }
        const int to_v = pgem_other(store, r->loops[q], p) == r->u;
        r->carried_v += to_v;
        r->carried_u += !to_v;
    }
    return r->u != r->v;
}

/* Loop kl of the removal composed onto its neighbour (u, or v when its other end is u): the
 * edge through p to the neighbour first when p is the loop's first pose. Writes it when
 * write, else only checks it can be made. */
static int pgem_compact_carry(pgem_compactor_t *c, const pgem_removal_t *r, uint32_t kl, int write)
{
    pgem_store_t *store = c->parts->store;
    const int n = c->parts->tangent;
    const uint32_t other = pgem_other(store, kl, r->p);
    const uint32_t target = other == r->u ? r->v : r->u;
    const uint32_t kt = target == r->u ? r->k1 : r->k2;
    const int p_first = store->edge_from[kl] == r->p;
    uint32_t from = 0, to = 0;
    double z[PGEM_POSE_SIZE_MAX], information[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    const double share = store->edge_active[kl] == PGEM_EDGE_PRUNED
                             ? 1.0
                             : 1.0 / (double)(1 + (target == r->u ? r->carried_u : r->carried_v));
    if (!(p_first ? pgem_edge_compose(store, kt, share, kl, 1.0, r->p, &from, &to, z,
                                      information, n)
                  : pgem_edge_compose(store, kl, 1.0, kt, share, r->p, &from, &to, z,
                                      information, n))) {
        return 0;
    }
    if (write) {
        store->edge_from[kl] = from;
        store->edge_to[kl] = to;
        memcpy(store->edge_measurement + (size_t)kl * (size_t)c->parts->pose_size, z,
               (size_t)c->parts->pose_size * sizeof(double));
        memcpy(store->edge_information + (size_t)kl * (size_t)(n * n), information,
               (size_t)(n * n) * sizeof(double));
        pgem_compact_push(c, (int32_t)(2u * kl + (p_first ? 0u : 1u)), target);
    }
    return 1;
}

/* The two odometry edges made one in k1's place (its end at u stays; the end at p goes to v). */
static int pgem_compact_merge(pgem_compactor_t *c, const pgem_removal_t *r, int write)
{
    pgem_store_t *store = c->parts->store;
    const int n = c->parts->tangent;
    const int u_first = store->edge_from[r->k1] == r->u;
    uint32_t from = 0, to = 0;
    double z[PGEM_POSE_SIZE_MAX], information[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    const double share_1 = 1.0 / (double)(1 + r->carried_u), share_2 = 1.0 / (double)(1 + r->carried_v);
    if (!(u_first ? pgem_edge_compose(store, r->k1, share_1, r->k2, share_2, r->p, &from, &to, z,
                                      information, n)
                  : pgem_edge_compose(store, r->k2, share_2, r->k1, share_1, r->p, &from, &to, z,
                                      information, n))) {
        return 0;
    }
    if (write) {
        store->edge_from[r->k1] = from;
        store->edge_to[r->k1] = to;
        memcpy(store->edge_measurement + (size_t)r->k1 * (size_t)c->parts->pose_size, z,
               (size_t)c->parts->pose_size * sizeof(double));
        memcpy(store->edge_information + (size_t)r->k1 * (size_t)(n * n), information,
               (size_t)(n * n) * sizeof(double));
        pgem_compact_push(c, (int32_t)(2u * r->k1 + (u_first ? 1u : 0u)), r->v);
    }
    return 1;
}

/* Removes r.p when every edge it takes can be made: 1 if it went. */
static int pgem_compact_remove(pgem_compactor_t *c, const pgem_removal_t *r)
{
    for (int q = 0; q < r->loop_count; q++) {
        if (!pgem_compact_carry(c, r, r->loops[q], 0)) {
            return 0;
        }
    }
    if (!pgem_compact_merge(c, r, 0)) {
        return 0;
    }
    for (int q = 0; q < r->loop_count; q++) { /* the loops first: they compose with k1, k2 */
        (void)pgem_compact_carry(c, r, r->loops[q], 1);
    }
    (void)pgem_compact_merge(c, r, 1);
    c->edge_new[r->k2] = PGEM_COMPACT_GONE;
    for (int q = 0; q < r->pruned_count; q++) {
        c->edge_new[r->pruned[q]] = PGEM_COMPACT_GONE;
    }
    c->pose_new[r->p] = PGEM_COMPACT_GONE;
    c->touched[r->u] = c->touched[r->v] = c->sweep;
    c->alive--;
    c->summary->edges_composed++;
    c->summary->loops_carried += (uint32_t)r->loop_count;
    c->summary->loops_dropped += (uint32_t)r->pruned_count;
    return 1;
}

/* Sweeps over the poses older than the tail until the target is met or a sweep removes none;
 * in one sweep a pose whose neighbour went waits for the next, so removals spread. */
static void pgem_compact_sweeps(pgem_compactor_t *c, uint32_t target, uint32_t limit, int loops)
{
    int removed = 1;
    while (removed && c->alive > target) {
        removed = 0;
        c->sweep++;
        for (uint32_t p = 0; p < limit && c->alive > target; p++) {
            pgem_removal_t r;
            if (c->pose_new[p] == PGEM_COMPACT_GONE || c->touched[p] == c->sweep ||
                !pgem_compact_candidate(c, p, loops, &r)) {
                continue;
            }
            removed += pgem_compact_remove(c, &r);
        }
    }
}

/* Loop closures in the problem (accepted or dormant) that join the same two kept poses, most
 * often loops carried onto the same pair, fused into the first of them: their measurements
 * where they agree best, their weighted information together, weight 1. A block holds a
 * long mission's loop closures only so: carried, they pile up between the poses kept. */
static void pgem_compact_fuse(pgem_compactor_t *c)
{
    pgem_store_t *store = c->parts->store;
    const int n = c->parts->tangent;
    for (uint32_t a = 0; a < store->pose_count; a++) {
        c->seen[a] = 0u;
    }
    for (uint32_t a = 0; a < store->pose_count; a++) {
        if (c->pose_new[a] == PGEM_COMPACT_GONE) {
            continue;
        }
        for (int32_t end = c->first[a]; end >= 0; end = c->next[end]) {
            const uint32_t k = (uint32_t)end >> 1;
            if (c->edge_new[k] == PGEM_COMPACT_GONE || pgem_end_pose(store, end) != a ||
                store->edge_kind[k] != PGEM_EDGE_LOOP || store->edge_active[k] == PGEM_EDGE_PRUNED) {
                continue;
            }
            const uint32_t b = pgem_other(store, k, a);
            if (b < a) {
                continue; /* the pair is met from its first pose */
            }
            if (c->seen[b] != a + 1u) {
                c->seen[b] = a + 1u;
                c->seen_by[b] = k;
                continue;
            }
            const uint32_t keep = c->seen_by[b];
            double z[PGEM_POSE_SIZE_MAX], information[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
            if (!pgem_edge_fuse(store, keep, store->edge_weight[keep], k, store->edge_weight[k], z,
                                information, n)) {
                continue;
            }
            memcpy(store->edge_measurement + (size_t)keep * (size_t)c->parts->pose_size, z,
                   (size_t)c->parts->pose_size * sizeof(double));
            memcpy(store->edge_information + (size_t)keep * (size_t)n * (size_t)n, information,
                   (size_t)n * (size_t)n * sizeof(double));
            store->edge_weight[keep] = 1.0;
            store->edge_active[keep] = PGEM_EDGE_ACTIVE;
            c->edge_new[k] = PGEM_COMPACT_GONE;
            c->summary->loops_fused++;
        }
    }
}

/* Chain poses first, then (loops) poses with loop closures, whose carried loops are fused. */
static void pgem_compact_stage(pgem_compactor_t *c, uint32_t target, uint32_t limit, int loops)
{
    pgem_compact_sweeps(c, target, limit, 0);
    if (loops) {
        pgem_compact_sweeps(c, target, limit, 1);
        pgem_compact_fuse(c);
    }
}

static uint32_t pgem_compact_edges_alive(const pgem_compactor_t *c)
{
    uint32_t alive = 0u;
    for (uint32_t k = 0; k < c->parts->store->edge_count; k++) {
        alive += c->edge_new[k] != PGEM_COMPACT_GONE;
    }
    return alive;
}

/* Closes up the arrays in order and rebuilds the id map; the maps out when asked. */
static void pgem_compact_close(pgem_compactor_t *c, const pgem_online_entry_t *entry,
                               const pgem_compact_options_t *options)
{
    const pgem_online_parts_t *parts = &entry->factor;
    pgem_store_t *store = parts->store;
    const size_t size = (size_t)parts->pose_size;
    const size_t nn = (size_t)parts->tangent * (size_t)parts->tangent;
    pgem_online_t *online = parts->online;
    uint32_t poses = 0, seen_poses = 0;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (c->pose_new[p] == PGEM_COMPACT_GONE) {
            continue;
        }
        seen_poses += p < online->poses_seen;
        c->pose_new[p] = poses;
        store->pose_id[poses] = store->pose_id[p];
        memmove(store->pose + poses * size, store->pose + p * size, size * sizeof(double));
        store->pose_fixed[poses] = store->pose_fixed[p];
        poses++;
    }
    uint32_t edges = 0, seen_edges = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (c->edge_new[k] == PGEM_COMPACT_GONE) {
            continue;
        }
        seen_edges += k < online->edges_seen;
        c->edge_new[k] = edges;
        store->edge_from[edges] = c->pose_new[store->edge_from[k]];
        store->edge_to[edges] = c->pose_new[store->edge_to[k]];
        memmove(store->edge_measurement + edges * size, store->edge_measurement + k * size,
                size * sizeof(double));
        memmove(store->edge_information + edges * nn, store->edge_information + k * nn,
                nn * sizeof(double));
        store->edge_kind[edges] = store->edge_kind[k];
        store->edge_active[edges] = store->edge_active[k];
        store->edge_weight[edges] = store->edge_weight[k];
        edges++;
    }
    if (options != NULL && options->pose_map != NULL) {
        memcpy(options->pose_map, c->pose_new, store->pose_count * sizeof(uint32_t));
    }
    if (options != NULL && options->edge_map != NULL) {
        memcpy(options->edge_map, c->edge_new, store->edge_count * sizeof(uint32_t));
    }
    store->pose_count = poses;
    store->edge_count = edges;
    memset(store->map_slot, 0, ((size_t)store->map_mask + 1u) * sizeof(uint32_t));
    for (uint32_t p = 0; p < poses; p++) {
        pgem_map_insert(store, store->pose_id[p], p);
    }
    const pgem_robust_state_t *robust = entry->robust.state;
    memset(robust->edge_distance, 0, (size_t)parts->config->max_edges * sizeof(double));
    memset(robust->edge_checked, 0, parts->config->max_edges);
    store->topology++;
    store->edited_low = 0u;
    /* the incremental factor: rebuilt at the next update, over what it had seen */
    online->ready = 0;
    online->poses_linked = 0u;
    online->edges_linked = 0u;
    online->poses_seen = seen_poses;
    online->edges_seen = seen_edges;
}

int pgem_online_compact(const pgem_online_entry_t *entry, uint32_t target_poses,
                        const pgem_compact_options_t *options, pgem_compact_summary_t *summary)
{
    pgem_compact_summary_t local = {0};
    pgem_compact_summary_t *out = summary != NULL ? summary : &local;
    memset(out, 0, sizeof *out);
    const pgem_online_parts_t *parts = &entry->factor;
    const pgem_robust_state_t *robust = entry->robust.state;
    pgem_store_t *store = parts->store;
    out->poses_before = out->poses_after = store->pose_count;
    out->edges_before = out->edges_after = store->edge_count;
    parts->message[0] = '\0';
    if (store->pose_count <= target_poses &&
        (options == NULL || options->target_edges == 0u || store->edge_count <= options->target_edges)) {
        return PGEM_OK;
    }
    const uint32_t max_poses = parts->config->max_poses;
    pgem_compactor_t c;
    c.parts = parts;
    c.pose_new = (uint32_t *)(void *)robust->pose_initial;
    c.first = (int32_t *)(void *)(c.pose_new + max_poses);
    c.touched = (uint32_t *)(void *)(c.first + max_poses);
    c.seen = c.touched + max_poses;
    c.seen_by = c.seen + max_poses;
    c.edge_new = (uint32_t *)(void *)robust->edge_weight_saved;
    c.next = (int32_t *)(void *)robust->edge_distance;
    c.alive = store->pose_count;
    c.sweep = 0u;
    c.keep_pruned = options != NULL && options->keep_pruned;
    c.summary = out;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        c.pose_new[p] = 0u;
        c.first[p] = -1;
        c.touched[p] = 0u;
    }
    for (uint32_t k = 0; k < store->edge_count; k++) {
        c.edge_new[k] = 0u;
        pgem_compact_push(&c, (int32_t)(2u * k), store->edge_from[k]);
        pgem_compact_push(&c, (int32_t)(2u * k + 1u), store->edge_to[k]);
    }
    const uint32_t tail = options != NULL && options->tail != 0u ? options->tail : PGEM_COMPACT_TAIL;
    const uint32_t limit = store->pose_count > tail ? store->pose_count - tail : 0u;
    const int loops = options == NULL || !options->chain_only;
    pgem_compact_stage(&c, target_poses, limit, loops);
    /* the edge target: a tenth more of the poses at a time until the edges fit or none can go
     * (a pose removed takes one odometry edge with it; its loops fuse once carried) */
    const uint32_t target_edges = options != NULL ? options->target_edges : 0u;
    while (target_edges != 0u && pgem_compact_edges_alive(&c) > target_edges) {
        const uint32_t before = c.alive;
        const uint32_t step = c.alive / 10u > 0u ? c.alive / 10u : 1u;
        pgem_compact_stage(&c, c.alive > step ? c.alive - step : 0u, limit, loops);
        if (c.alive == before) {
            break;
        }
    }
    pgem_compact_close(&c, entry, options);
    out->poses_after = store->pose_count;
    out->edges_after = store->edge_count;
    return PGEM_OK;
}
