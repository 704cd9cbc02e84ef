/* pgem_update_covariance: one pose's marginal from the incremental factor pgem_update keeps,
 * in the tangent of the covariance calls (solver/covariance.c turns it into the body's). */
#include <string.h>

#include "online/factor.h"

int pgem_online_update_covariance(const pgem_online_entry_t *entry, pgem_id_t id,
                                  double *covariance)
{
    const pgem_online_parts_t *parts = &entry->factor;
    const pgem_store_t *store = parts->store;
    char *message = parts->message;
    pgem_online_sync(parts);
    const pgem_online_t *online = parts->online;
    if (online->pool_blocks == 0u) {
        return pgem_text_fail(message, PGEM_ERR_CONFIG,
                              "pgem_update_covariance needs config.online_fill "
                              "(the incremental factor's room)");
    }
    uint32_t p = 0;
    int status = pgem_covariance_pose(store, message, id, &p);
    if (status != PGEM_OK) {
        return status;
    }
    if (!online->ready || online->topology_after != store->topology ||
        online->revision_after != store->revision) {
        return pgem_text_fail(message, PGEM_ERR_NO_FACTOR,
                              "the incremental factor is not current: call pgem_update after "
                              "the last change to the graph, its estimate or its weights");
    }
    const int n = parts->tangent;
    if (!pgem_online_covariance(parts, p, covariance)) {
        if (!PGEM_POSE_HELD(store, p)) {
            message[0] = '\0';
            pgem_text_append(message, PGEM_MESSAGE_SIZE, "pose ");
            pgem_text_u64(message, PGEM_MESSAGE_SIZE, id);
            pgem_text_append(message, PGEM_MESSAGE_SIZE,
                             " is not in the incremental factor: no edge of it is");
            return PGEM_ERR_NO_FACTOR;
        }
        memset(covariance, 0, (size_t)(n * n) * sizeof(double)); /* held: certain */
    }
    if (parts->config->dimension == 2) {
        pgem_covariance_to_body(store, p, 3, 0, covariance);
    }
    message[0] = '\0';
    return PGEM_OK;
}
