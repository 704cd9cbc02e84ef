/* A whole-graph robust pass taken back into the incremental graph (pgem_update_adopt): the
 * pass solved a copy of the graph as it was when the copy was taken, while updates went on
 * adding poses and edges; its estimate and loop decisions replace the updates' for what it
 * holds, and what arrived since moves with it. */
#include <string.h>

#include "online/factor.h"

/* Refuses the adoption: nothing changed. */
static int pgem_adopt_refused(char *message, const char *what, uint64_t index, const char *why)
{
    message[0] = '\0';
    pgem_text_append(message, PGEM_MESSAGE_SIZE, "pgem_update_adopt: ");
    pgem_text_append(message, PGEM_MESSAGE_SIZE, what);
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, index);
    pgem_text_append(message, PGEM_MESSAGE_SIZE, why);
    pgem_text_append(message, PGEM_MESSAGE_SIZE, ": nothing adopted");
    return PGEM_ERR_INVALID_ARGUMENT;
}

/* The pass must hold a prefix of the graph: the same poses (ids) and edges (ends, kinds) in
 * the same order. Held flags may differ (a pass holds the poses no edge reached yet). */
static int pgem_adopt_check(const pgem_store_t *g, const pgem_store_t *s, char *message)
{
    if (s->pose_count > g->pose_count) {
        return pgem_adopt_refused(message, "the pass holds ", s->pose_count,
                                  " poses, more than the graph");
    }
    if (s->edge_count > g->edge_count) {
        return pgem_adopt_refused(message, "the pass holds ", s->edge_count,
                                  " edges, more than the graph");
    }
    for (uint32_t p = 0; p < s->pose_count; p++) {
        if (s->pose_id[p] != g->pose_id[p]) {
            return pgem_adopt_refused(message, "pose index ", p,
                                      " has another id in the pass than in the graph");
        }
    }
    for (uint32_t k = 0; k < s->edge_count; k++) {
        if (s->edge_from[k] != g->edge_from[k] || s->edge_to[k] != g->edge_to[k] ||
            s->edge_kind[k] != g->edge_kind[k]) {
            return pgem_adopt_refused(message, "edge index ", k,
                                      " differs between the pass and the graph (ends or kind)");
        }
    }
    return PGEM_OK;
}

/* Pose x, new since the pass, placed as the graph had it relative to pose y (whose new value
 * is in store.pose, old one in old): new(x) = new(y) old(y)^-1 old(x). */
static void pgem_adopt_carry(const pgem_online_parts_t *parts, const double *old, uint32_t x,
                             uint32_t y)
{
    const size_t size = (size_t)parts->pose_size;
    double inverse[PGEM_POSE_SIZE_MAX], relative[PGEM_POSE_SIZE_MAX];
    double *pose = parts->store->pose;
    if (parts->tangent == 6) {
        pgem_se3_inverse(old + y * size, inverse);
        pgem_se3_compose(inverse, old + x * size, relative);
        pgem_se3_compose(pose + y * size, relative, pose + x * size);
    } else {
        pgem_se2_inverse(old + y * size, inverse);
        pgem_se2_compose(inverse, old + x * size, relative);
        pgem_se2_compose(pose + y * size, relative, pose + x * size);
    }
}

/* The poses added since the pass follow the correction: each is carried along by the first
 * edge joining it to a pose already placed (odometry edges first, in arrival order, so a
 * trajectory is carried down its chain); held poses stay; a pose no edge reaches stays. */
static uint32_t pgem_adopt_carry_new(const pgem_online_parts_t *parts, const double *old,
                                     uint32_t placed_poses, uint32_t first_edge, int *placed)
{
    const pgem_store_t *store = parts->store;
    uint32_t carried = 0;
    for (uint32_t p = placed_poses; p < store->pose_count; p++) {
        placed[p] = store->pose_fixed[p] == PGEM_POSE_FIXED;
    }
    for (int sweep = 0; sweep < 2; sweep++) {
        for (uint32_t k = first_edge; k < store->edge_count; k++) {
            if (sweep == 0 && store->edge_kind[k] != PGEM_EDGE_ODOMETRY) {
                continue;
            }
            const uint32_t a = store->edge_from[k], b = store->edge_to[k];
            const int known_a = a < placed_poses || placed[a];
            const int known_b = b < placed_poses || placed[b];
            if (known_a != known_b) {
                const uint32_t x = known_a ? b : a;
                pgem_adopt_carry(parts, old, x, known_a ? a : b);
                placed[x] = 1;
                carried++;
            }
        }
    }
    return carried;
}

int pgem_online_adopt(const pgem_online_entry_t *entry, const pgem_store_t *from,
                      const pgem_robust_state_t *from_robust, int from_dimension,
                      pgem_adopt_summary_t *summary)
{
    const pgem_online_parts_t *parts = &entry->factor;
    char *message = parts->message;
    if (parts->config->dimension != from_dimension) {
        return pgem_text_fail(message, PGEM_ERR_DIMENSION,
                              "pgem_update_adopt: the instances' dimensions differ");
    }
    pgem_online_t *online = parts->online;
    if (online->pool_blocks == 0u) {
        return pgem_text_fail(message, PGEM_ERR_CONFIG,
                              "pgem_update_adopt needs config.online_fill (the incremental "
                              "factor's room)");
    }
    pgem_store_t *store = parts->store;
    int status = pgem_adopt_check(store, from, message);
    if (status != PGEM_OK) {
        return status;
    }
    const pgem_robust_state_t *robust = entry->robust.state;
    const size_t size = (size_t)parts->pose_size;
    /* The updates' estimate, kept where the next update's rebuild takes its points from anew. */
    memcpy(online->lin, store->pose, (size_t)store->pose_count * size * sizeof(double));
    memcpy(store->pose, from->pose, (size_t)from->pose_count * size * sizeof(double));
    const uint32_t carried = pgem_adopt_carry_new(parts, online->lin, from->pose_count,
                                                  from->edge_count, online->next);
    uint32_t changed = 0;
    for (uint32_t k = 0; k < from->edge_count; k++) {
        const uint8_t state = from->edge_active[k] == PGEM_EDGE_PRUNED ? PGEM_EDGE_PRUNED
                                                                       : PGEM_EDGE_ACTIVE;
        changed += store->edge_kind[k] == PGEM_EDGE_LOOP &&
                   (store->edge_active[k] == PGEM_EDGE_PRUNED) != (state == PGEM_EDGE_PRUNED);
        store->edge_active[k] = state;
        store->edge_weight[k] = from->edge_weight[k];
        robust->edge_distance[k] = from_robust->edge_distance[k];
        robust->edge_checked[k] = from_robust->edge_checked[k];
    }
    /* The loops that arrived since keep the updates' verdicts until the next pass judges
     * them: gating them again here would leave them out of the rebuild's ordering and put
     * them in by rank updates after it, and hundreds of loops put in that way fill the factor
     * (a pass 1000 poses behind on a 10000-pose Manhattan walk: 330 blocks a column instead
     * of 10, and the pool full). */
    online->ready = 0;
    store->topology++; /* loops changed state: the next analysis is anew */
    pgem_linear_invalidate(parts->linear);
    message[0] = '\0';
    if (summary != NULL) {
        summary->poses_adopted = from->pose_count;
        summary->poses_carried = carried;
        summary->edges_adopted = from->edge_count;
        summary->loops_changed = changed;
    }
    return PGEM_OK;
}
