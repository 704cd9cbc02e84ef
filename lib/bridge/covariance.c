/* The newest pose's marginal covariance, published after each graph (pgem.covariance_t): from
 * the incremental factor after an update (a solve of one block, microseconds), from a factor at
 * the estimate after a whole-graph solve (one factorisation). Solver thread only. */
#include <stddef.h>
#include <string.h>

#include "bridge_internal.h"
#include "pgem_covariance_t.h"
#include "union_find.h"

#define COVARIANCE_FAILURES_LOGGED 20

/* The newest pose an edge reaches (its part has edges): its index, or 0 when there is none. */
static int newest_pose(bridge_t *bridge, uint32_t *index)
{
    for (uint32_t i = bridge->solver.parts.poses; i-- > 0u;) {
        if (bridge->solver.parts.has_edge[pgem_part_root(bridge->solver.parts.parent, i)]) {
            *index = i;
            return 1;
        }
    }
    return 0;
}

/* The covariance of pose id into values (n x n): after a whole-graph solve from a factor at the
 * estimate (pgem_covariance_prepare; *current 1), else from the update's incremental factor
 * (*current 0) or, when no update came since a whole-graph solve, from that solve's factor if
 * nothing changed since (*current 1). */
static int newest_covariance(bridge_t *bridge, pgem_id_t id, int whole, double *values,
                             int *current)
{
    *current = 1;
    if (!whole) {
        const int status = pgem_update_covariance(bridge->solver.core, id, values);
        if (status != PGEM_ERR_NO_FACTOR) {
            *current = 0;
            return status;
        }
        return pgem_covariance(bridge->solver.core, id, values);
    }
    const int status = pgem_covariance_prepare(bridge->solver.core);
    return status == PGEM_OK ? pgem_covariance(bridge->solver.core, id, values) : status;
}

void bridge_covariance_publish(bridge_t *bridge, int whole)
{
    uint32_t index = 0;
    if (bridge->options.no_covariance || !newest_pose(bridge, &index)) {
        return;
    }
    const double start = bridge_now();
    const int dimension = bridge->options.dimension;
    const int n = PGEM_TANGENT_SIZE(dimension);
    double pose[PGEM_POSE_SIZE_MAX];
    double values[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double *rows[PGEM_TANGENT_SIZE_MAX];
    pgem_id_t id = 0;
    pgem_pose_at(bridge->solver.core, index, &id, pose, NULL);
    int current = 0;
    const int status = newest_covariance(bridge, id, whole, values, &current);
    if (status != PGEM_OK) {
        if (bridge->solver.covariance.failures++ < COVARIANCE_FAILURES_LOGGED) {
            bridge_log(bridge, "no covariance for pose %llu after graph %lld: %s (%s)",
                       (unsigned long long)id, (long long)bridge->solver.solve_id,
                       pgem_error_name(status), pgem_last_error(bridge->solver.core));
        }
        return;
    }
    for (int i = 0; i < n; ++i) { /* symmetric to the last bit (the frame's rotation is not) */
        rows[i] = values + (ptrdiff_t)i * n;
        for (int j = 0; j < i; ++j) {
            values[i * n + j] = values[j * n + i] = 0.5 * (values[i * n + j] + values[j * n + i]);
        }
    }
    pgem_covariance_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = bridge->solver.out.graph_utime;
    msg.solve_id = bridge->solver.solve_id;
    msg.id = (int64_t)id;
    msg.dimension = (int8_t)dimension;
    msg.pose_size = PGEM_POSE_SIZE(dimension);
    msg.pose = pose;
    msg.size = n;
    msg.covariance = rows;
    msg.current = (int8_t)current;
    const int size = pgem_covariance_t_encoded_size(&msg);
    if (bridge_out_ready(bridge, size, "the covariance")) {
        bridge_out_publish(bridge, bridge->options.channels.covariance, "the covariance", size,
                           pgem_covariance_t_encode(bridge->solver.out.buffer, 0, size, &msg));
    }
    const double took = bridge_now() - start;
    bridge->solver.covariance.count[whole != 0]++;
    bridge->solver.covariance.seconds[whole != 0] += took;
    if (whole) {
        const uint64_t updates = bridge->solver.covariance.count[0];
        bridge_log(bridge,
                   "covariance of pose %llu (graph %lld) in %.2f ms from a factor at the estimate; "
                   "%llu from the incremental factor so far, %.1f us each",
                   (unsigned long long)id, (long long)bridge->solver.solve_id, 1e3 * took,
                   (unsigned long long)updates,
                   updates > 0u ? 1e6 * bridge->solver.covariance.seconds[0] / (double)updates
                                : 0.0);
    }
}
