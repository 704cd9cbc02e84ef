/* pgem_update_covariance: one pose's marginal from the incremental factor pgem_update keeps,
 * in the tangent of the covariance calls (solver/covariance.c turns it into the body's). */
#include <string.h>

#include "online/factor.h"
#include "pgem/covariance.h"
#include "solver/solver.h"

int pgem_update_covariance(pgem_t *graph, pgem_id_t id, double *covariance)
{
    if (graph == NULL || covariance == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    pgem_online_sync(graph);
    const pgem_online_t *online = graph->online;
    if (online->pool_blocks == 0u) {
        return pgem_fail(graph, PGEM_ERR_CONFIG, "pgem_update_covariance needs config.online_fill "
                                                 "(the incremental factor's room)");
    }
    uint32_t p = 0;
    int status = pgem_covariance_pose(&graph->store, graph->message, id, &p);
    if (status != PGEM_OK) {
        return status;
    }
    if (!online->ready || online->topology_after != graph->store.topology ||
        online->revision_after != graph->store.revision) {
        return pgem_fail(graph, PGEM_ERR_NO_FACTOR,
                         "the incremental factor is not current: call pgem_update after the last "
                         "change to the graph, its estimate or its weights");
    }
    const int n = graph->tangent;
    const pgem_online_parts_t parts = pgem_online_parts_of(graph);
    if (!pgem_online_covariance(&parts, p, covariance)) {
        if (!PGEM_POSE_HELD(&graph->store, p)) {
            pgem_message_clear(graph);
            pgem_message_text(graph, "pose ");
            pgem_message_u64(graph, id);
            pgem_message_text(graph, " is not in the incremental factor: no edge of it is");
            return PGEM_ERR_NO_FACTOR;
        }
        memset(covariance, 0, (size_t)(n * n) * sizeof(double)); /* held: certain */
    }
    if (graph->config.dimension == 2) {
        pgem_covariance_to_body(&graph->store, p, 3, 0, covariance);
    }
    pgem_message_clear(graph);
    return PGEM_OK;
}
