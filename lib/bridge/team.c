/* pgem.team_t, published right after each graph_t: each robot (a source) with its poses, its
 * part over the odometry and the accepted loop closures, whether that part holds the team's
 * anchor, and its frame (its own odometry frame into the map's). Computed from the graph as
 * it is, O(poses + edges), as the graph itself is. Solver thread only. */
#include <string.h>

#include "bridge_internal.h"
#include "pgem_team_t.h"
#include "union_find.h"

#define TEAM_NONE UINT32_MAX
#define TEAM_STRONG 0x80000000u /* robot[i]: set by the odometry edge from the pose before */

/* Bits of team.bits[i]: of pose i itself, and (ROOT_*) of the part rooted at i. */
#define TEAM_EDGE 1u      /* an edge touches the pose */
#define TEAM_HELD 2u      /* the pose is held: fixed by its front-end or by the bridge */
#define TEAM_ROOT_EDGE 4u /* the part has an edge */
#define TEAM_ROOT_HELD 8u /* the part holds a held pose */

/* Pose indices of edge k's ends and its view; 0 when it has none. */
static int team_ends(const bridge_t *bridge, uint32_t k, pgem_edge_view_t *view, uint32_t *a,
                     uint32_t *b)
{
    return pgem_edge_at(bridge->solver.core, k, view) == PGEM_OK &&
           pgem_pose_index(bridge->solver.core, view->from, a) == PGEM_OK &&
           pgem_pose_index(bridge->solver.core, view->to, b) == PGEM_OK;
}

/* The edges: parts joined by odometry and accepted loop closures, each pose's robot. A pose
 * belongs to the source of the odometry edge joining it to the pose before it (by id: the
 * robot that moved there); failing one, to the source of the first odometry edge to the pose
 * after it (a robot's first pose). */
static void team_edges(bridge_t *bridge, uint32_t poses)
{
    bridge_team_t *team = &bridge->solver.team;
    for (uint32_t i = 0; i < poses; ++i) {
        team->parent[i] = i;
        team->robot[i] = TEAM_NONE;
        team->label[i] = TEAM_NONE;
        team->bits[i] = bridge->solver.user_fixed[i] ||
                                bridge->solver.gauge_fixed[i] == BRIDGE_HOLD_FIXED
                            ? TEAM_HELD
                            : 0u;
    }
    const uint32_t edges = pgem_edge_count(bridge->solver.core);
    for (uint32_t k = 0; k < edges; ++k) {
        pgem_edge_view_t view;
        uint32_t a = 0, b = 0;
        if (!team_ends(bridge, k, &view, &a, &b)) {
            continue;
        }
        team->bits[a] |= TEAM_EDGE;
        team->bits[b] |= TEAM_EDGE;
        const int odometry = view.kind == PGEM_EDGE_ODOMETRY;
        if (odometry || view.active) {
            (void)pgem_part_join(team->parent, pgem_part_root(team->parent, a),
                                 pgem_part_root(team->parent, b));
        }
        if (!odometry) {
            continue;
        }
        const uint32_t source = bridge->solver.edge_source[k];
        const uint32_t later = view.to > view.from ? b : a;
        const uint32_t earlier = later == b ? a : b;
        team->robot[later] = source | TEAM_STRONG;
        if (team->robot[earlier] == TEAM_NONE) {
            team->robot[earlier] = source;
        }
    }
}

/* Each part's bits at its root; returns the parts that have an edge. */
static uint32_t team_parts(bridge_team_t *team, uint32_t poses)
{
    for (uint32_t i = 0; i < poses; ++i) {
        const uint32_t root = pgem_part_root(team->parent, i);
        team->bits[root] |= (team->bits[i] & (TEAM_EDGE | TEAM_HELD)) << 2;
    }
    uint32_t parts = 0;
    for (uint32_t i = 0; i < poses; ++i) {
        parts += team->parent[i] == i && (team->bits[i] & TEAM_ROOT_EDGE) != 0u;
    }
    return parts;
}

/* The frame of the robot whose first pose is index i: X(i) X0(i)^-1, X0 the front-end's
 * estimate. */
static void team_frame(const bridge_t *bridge, uint32_t i, double *frame)
{
    const int three = bridge->options.dimension == 3;
    const size_t pose_size = (size_t)PGEM_POSE_SIZE(bridge->options.dimension);
    double pose[PGEM_POSE_SIZE_MAX], inverse[PGEM_POSE_SIZE_MAX];
    pgem_pose_at(bridge->solver.core, i, NULL, pose, NULL);
    (three ? pgem_se3_inverse : pgem_se2_inverse)(bridge->solver.raw + i * pose_size, inverse);
    (three ? pgem_se3_compose : pgem_se2_compose)(pose, inverse, frame);
}

void bridge_publish_team(bridge_t *bridge, int64_t utime, uint32_t sources)
{
    bridge_team_t *team = &bridge->solver.team;
    const uint32_t poses = pgem_pose_count(bridge->solver.core);
    team_edges(bridge, poses);
    team->parts = team_parts(team, poses);
    for (uint32_t s = 0; s < sources; ++s) {
        team->count[s] = 0;
        team->first[s] = TEAM_NONE;
    }
    for (uint32_t i = 0; i < poses; ++i) {
        const uint32_t s = team->robot[i] & ~TEAM_STRONG;
        if (team->robot[i] != TEAM_NONE && s < sources) {
            team->first[s] = team->count[s]++ == 0 ? i : team->first[s];
        }
    }
    int32_t robots = 0;
    int32_t parts = 0;
    for (uint32_t s = 0; s < sources; ++s) {
        if (team->count[s] == 0) {
            continue;
        }
        const uint32_t first = team->first[s];
        const uint32_t root = pgem_part_root(team->parent, first);
        if (team->label[root] == TEAM_NONE) {
            team->label[root] = (uint32_t)parts++;
        }
        pgem_id_t id = 0;
        pgem_pose_at(bridge->solver.core, first, &id, NULL, NULL);
        team->names[robots] = bridge->solver.out.sources[s];
        team->poses[robots] = team->count[s];
        team->first_ids[robots] = (int64_t)id;
        team->part[robots] = (int32_t)team->label[root];
        team->anchored[robots] = (int8_t)((team->bits[root] & TEAM_ROOT_HELD) != 0u);
        team_frame(bridge, first, team->frames[robots]);
        robots++;
    }
    pgem_team_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = utime;
    msg.solve_id = bridge->solver.solve_id;
    msg.dimension = (int8_t)bridge->options.dimension;
    msg.pose_size = PGEM_POSE_SIZE(bridge->options.dimension);
    msg.num_parts = parts;
    msg.num_robots = robots;
    msg.sources = team->names;
    msg.poses = team->poses;
    msg.first_ids = team->first_ids;
    msg.parts = team->part;
    msg.anchored = team->anchored;
    msg.frames = team->frames;
    const int size = pgem_team_t_encoded_size(&msg);
    if (bridge_out_ready(bridge, size, "the team")) {
        bridge_out_publish(bridge, bridge->options.channels.team, "the team", size,
                           pgem_team_t_encode(bridge->solver.out.buffer, 0, size, &msg));
    }
}
