/* The solver's parts of the graph joined by odometry, kept up to date as poses and edges
 * arrive (new ones only: O(new) per solve), and the gauge pose that holds each part. */
#include <string.h>

#include "bridge_internal.h"
#include "union_find.h"

void bridge_components_reset(bridge_t *bridge)
{
    bridge->solver.parts.poses = 0;
    bridge->solver.parts.edges = 0;
    bridge->solver.parts.with_edges = 0;
    bridge->solver.parts.main_anchor = UINT32_MAX;
}

/* The id of pose index i. */
static pgem_id_t id_of(const bridge_t *bridge, uint32_t i)
{
    pgem_id_t id = 0;
    pgem_pose_at(bridge->solver.core, i, &id, NULL, NULL);
    return id;
}

/* Holds pose index i as a part's gauge: want BRIDGE_HOLD_FIXED fixes it (the part with the
 * smallest pose id: the gauge the offline tools hold), BRIDGE_HOLD_GAUGE holds the gauge of
 * another part (pgem_hold_gauge: the pose free, its block damped, so loop closures to the
 * rest place the part), 0 frees it; UINT32_MAX: no pose. */
static void hold_gauge(bridge_t *bridge, uint32_t i, uint8_t want)
{
    if (i == UINT32_MAX || bridge->solver.gauge_fixed[i] == want) {
        return;
    }
    const pgem_id_t id = id_of(bridge, i);
    if (want == BRIDGE_HOLD_GAUGE) {
        pgem_hold_gauge(bridge->solver.core, id, 1);
    } else {
        pgem_fix_pose(bridge->solver.core, id, want == BRIDGE_HOLD_FIXED);
    }
    bridge->solver.gauge_fixed[i] = want;
}

/* Holds a part's anchor: fixed when it is the main part's (the smallest id of all anchors),
 * else its gauge; a new anchor with a smaller id than the main one's takes its place. */
static void hold_part(bridge_t *bridge, uint32_t anchor)
{
    if (anchor == UINT32_MAX) {
        return;
    }
    if (bridge->solver.parts.main_anchor == UINT32_MAX ||
        (anchor != bridge->solver.parts.main_anchor &&
         id_of(bridge, anchor) < id_of(bridge, bridge->solver.parts.main_anchor))) {
        const uint32_t before = bridge->solver.parts.main_anchor;
        bridge->solver.parts.main_anchor = anchor;
        hold_gauge(bridge, before, BRIDGE_HOLD_GAUGE);
    }
    hold_gauge(bridge, anchor,
               anchor == bridge->solver.parts.main_anchor ? BRIDGE_HOLD_FIXED : BRIDGE_HOLD_GAUGE);
}

/* The anchor of two joined parts: none (UINT32_MAX) if the front-end fixed a pose in either,
 * else the one with the smaller pose id. */
static uint32_t merged_anchor(const bridge_t *bridge, uint32_t a, uint32_t b)
{
    if (a == UINT32_MAX || b == UINT32_MAX) {
        return UINT32_MAX;
    }
    return id_of(bridge, a) < id_of(bridge, b) ? a : b;
}

/* Marks the part rooted at root as having an edge (counted once). */
static void part_has_edge(bridge_t *bridge, uint32_t root)
{
    if (!bridge->solver.parts.has_edge[root]) {
        bridge->solver.parts.has_edge[root] = 1;
        bridge->solver.parts.with_edges++;
    }
}

/* Edge k's view and the pose indices of its two ends; 0 if it has none (a bad index). */
static int edge_ends(const bridge_t *bridge, uint32_t k, pgem_edge_view_t *view, uint32_t ends[2])
{
    return pgem_edge_at(bridge->solver.core, k, view) == PGEM_OK &&
           pgem_pose_index(bridge->solver.core, view->from, &ends[0]) == PGEM_OK &&
           pgem_pose_index(bridge->solver.core, view->to, &ends[1]) == PGEM_OK;
}

/* The part rooted at root, solved at its own gauge, moved as one so that the odometry edge
 * (view) joining it to another part holds exactly: every pose X of it becomes T X, where T
 * takes its end of the edge to where the other end and the measurement put it. The next
 * update rebuilds at the moved poses (pgem_set_pose marks them) and starts near the joined
 * optimum, instead of from a part displaced by whatever its gauge was. O(poses); parts join
 * rarely (odometry that arrived late, or was lost and sent again). */
static void move_part(bridge_t *bridge, uint32_t root, const pgem_edge_view_t *view, int moving_to)
{
    const int three = bridge->options.dimension == 3;
    double from[PGEM_POSE_SIZE_MAX], to[PGEM_POSE_SIZE_MAX], want[PGEM_POSE_SIZE_MAX];
    double inverse[PGEM_POSE_SIZE_MAX], step[PGEM_POSE_SIZE_MAX], moved[PGEM_POSE_SIZE_MAX];
    double pose[PGEM_POSE_SIZE_MAX];
    pgem_pose(bridge->solver.core, view->from, from);
    pgem_pose(bridge->solver.core, view->to, to);
    if (moving_to) { /* want = from z; T = want to^-1 */
        (three ? pgem_se3_compose : pgem_se2_compose)(from, view->measurement, want);
        (three ? pgem_se3_inverse : pgem_se2_inverse)(to, inverse);
    } else { /* want = to z^-1; T = want from^-1 */
        (three ? pgem_se3_inverse : pgem_se2_inverse)(view->measurement, step);
        (three ? pgem_se3_compose : pgem_se2_compose)(to, step, want);
        (three ? pgem_se3_inverse : pgem_se2_inverse)(from, inverse);
    }
    (three ? pgem_se3_compose : pgem_se2_compose)(want, inverse, step);
    for (uint32_t i = 0; i < bridge->solver.parts.poses; ++i) {
        if (pgem_part_root(bridge->solver.parts.parent, i) != root) {
            continue;
        }
        pgem_id_t id = 0;
        pgem_pose_at(bridge->solver.core, i, &id, pose, NULL);
        (three ? pgem_se3_compose : pgem_se2_compose)(step, pose, moved);
        pgem_set_pose(bridge->solver.core, id, moved);
    }
}

/* Edge k into the parts: both its parts have an edge; odometry joins them, and the joined
 * part keeps one gauge. */
static void join_edge(bridge_t *bridge, uint32_t k)
{
    pgem_edge_view_t view;
    uint32_t ends[2] = {0, 0};
    if (!edge_ends(bridge, k, &view, ends)) {
        return;
    }
    const uint32_t a = ends[0];
    const uint32_t b = ends[1];
    uint32_t *parent = bridge->solver.parts.parent;
    const uint32_t root_a = pgem_part_root(parent, a);
    const uint32_t root_b = pgem_part_root(parent, b);
    part_has_edge(bridge, root_a);
    part_has_edge(bridge, root_b);
    if (view.kind != PGEM_EDGE_ODOMETRY || root_a == root_b) {
        return;
    }
    uint32_t *anchor_of = bridge->solver.parts.anchor;
    const uint32_t anchor = merged_anchor(bridge, anchor_of[root_a], anchor_of[root_b]);
    for (int s = 0; s < 2; ++s) { /* a part held at its own gauge that loses it moves */
        const uint32_t own = anchor_of[s == 0 ? root_a : root_b];
        if (own != anchor && own != UINT32_MAX && bridge->solver.gauge_fixed[own]) {
            move_part(bridge, s == 0 ? root_a : root_b, &view, s == 1);
            bridge_pass_drop(bridge); /* a pass's copy holds it where it was */
            bridge_log(bridge, "odometry %llu -> %llu joined a part held at its own gauge to "
                               "another: the part moved as one onto it",
                       (unsigned long long)view.from, (unsigned long long)view.to);
        }
    }
    const uint32_t root = pgem_part_join(parent, root_a, root_b);
    bridge->solver.parts.with_edges--; /* two parts with edges became one */
    for (int s = 0; s < 2; ++s) {
        const uint32_t own = anchor_of[s == 0 ? root_a : root_b];
        if (own != anchor) {
            hold_gauge(bridge, own, 0);
            bridge->solver.parts.main_anchor =
                own == bridge->solver.parts.main_anchor ? anchor : bridge->solver.parts.main_anchor;
        }
    }
    anchor_of[root] = anchor;
    if (anchor != UINT32_MAX && bridge->solver.gauge_fixed[anchor] != 0) {
        hold_part(bridge, anchor); /* the joined part keeps the main part's hold if it had it */
    }
}

/* Holds every part of the graph joined by odometry that has an edge: a part without a pose the
 * front-end fixed gets its smallest pose id fixed (for one part that is the gauge the offline
 * tools use, whatever order the poses arrived in). Parts appear while edges wait for their
 * poses or when messages were lost; joined only by loop closures, which EM may prune, they
 * would leave the normal equations singular. A pose no edge touches yet (its odometry a few
 * milliseconds behind it) changes no other pose and is left free here: an incremental update
 * leaves it out of its factor, and fixing it only to free it when its odometry arrives would
 * make the next update rebuild the factor (bridge_components_hold_lone holds such poses for a
 * whole-graph solve). Flags change only when the parts do, so an unchanged graph keeps its
 * analysis. Only the poses and edges added since the last call are visited (parts only ever
 * join). Returns the number of parts that have edges. */
uint32_t bridge_components_hold(bridge_t *bridge)
{
    const uint32_t poses = pgem_pose_count(bridge->solver.core);
    for (uint32_t i = bridge->solver.parts.poses; i < poses; ++i) {
        bridge->solver.parts.parent[i] = i;
        bridge->solver.parts.anchor[i] = bridge->solver.user_fixed[i] ? UINT32_MAX : i;
        bridge->solver.parts.has_edge[i] = 0;
    }
    bridge->solver.parts.poses = poses;
    const uint32_t first = bridge->solver.parts.edges;
    const uint32_t edges = pgem_edge_count(bridge->solver.core);
    for (uint32_t k = first; k < edges; ++k) {
        join_edge(bridge, k);
    }
    bridge->solver.parts.edges = edges;
    for (uint32_t j = first; j < edges; ++j) { /* the parts that got an edge: their gauge */
        pgem_edge_view_t view;
        uint32_t ends[2] = {0, 0};
        if (!edge_ends(bridge, j, &view, ends)) {
            continue;
        }
        for (int s = 0; s < 2; ++s) {
            hold_part(
                bridge,
                bridge->solver.parts.anchor[pgem_part_root(bridge->solver.parts.parent, ends[s])]);
        }
    }
    return bridge->solver.parts.with_edges;
}

/* Before a whole-graph solve: every part without edges (a pose whose edges have not arrived)
 * held too, or its block of the normal equations would be empty. O(poses). */
void bridge_components_hold_lone(bridge_t *bridge)
{
    for (uint32_t i = 0; i < bridge->solver.parts.poses; ++i) {
        const uint32_t root = pgem_part_root(bridge->solver.parts.parent, i);
        if (!bridge->solver.parts.has_edge[root] && bridge->solver.parts.anchor[root] == i) {
            hold_gauge(bridge, i, BRIDGE_HOLD_FIXED); /* no edge: nothing to place it */
        }
    }
}
