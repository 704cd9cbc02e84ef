/* Adding and reading edges, each input checked before anything changes (pgem_add_edge and
 * pgem_edge_at are these over the instance's store, instance/graph.c). */
#include <string.h>

#include "graph/graph.h"

static void pgem_edge_note(char *message, const char *text)
{
    pgem_text_append(message, PGEM_MESSAGE_SIZE, text);
}

static int pgem_edge_fail_ids(char *message, int code, pgem_id_t from, pgem_id_t to)
{
    pgem_edge_note(message, " (edge ");
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, from);
    pgem_edge_note(message, " -> ");
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, to);
    pgem_edge_note(message, ")");
    return code;
}

static int pgem_edge_check_ends(const pgem_store_t *store, pgem_id_t from, pgem_id_t to,
                                int64_t *from_index, int64_t *to_index, char *message)
{
    *from_index = pgem_map_find(store, from);
    *to_index = pgem_map_find(store, to);
    if (*from_index < 0 || *to_index < 0) {
        message[0] = '\0';
        pgem_edge_note(message, "no pose with id ");
        pgem_text_u64(message, PGEM_MESSAGE_SIZE, *from_index < 0 ? from : to);
        return pgem_edge_fail_ids(message, PGEM_ERR_UNKNOWN_ID, from, to);
    }
    if (from == to) {
        message[0] = '\0';
        pgem_edge_note(message, "an edge must join two different poses");
        return pgem_edge_fail_ids(message, PGEM_ERR_SELF_LOOP, from, to);
    }
    return PGEM_OK;
}

static int pgem_edge_capacity(uint32_t max_edges, pgem_id_t from, pgem_id_t to, char *message)
{
    message[0] = '\0';
    pgem_edge_note(message, "edge exceeds the edge capacity (max_edges = ");
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, max_edges);
    pgem_edge_note(message, ")");
    return pgem_edge_fail_ids(message, PGEM_ERR_CAPACITY, from, to);
}

int pgem_store_add_edge(pgem_store_t *store, const pgem_config_t *config, pgem_id_t from,
                        pgem_id_t to, const double *measurement, const double *information,
                        pgem_edge_kind_t kind, uint32_t *edge_index, char *message)
{
    double checked[PGEM_POSE_SIZE_MAX];
    int64_t from_index, to_index;
    if (measurement == NULL || information == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (kind != PGEM_EDGE_ODOMETRY && kind != PGEM_EDGE_LOOP) {
        message[0] = '\0';
        pgem_edge_note(message, "edge kind must be odometry or loop");
        return pgem_edge_fail_ids(message, PGEM_ERR_INVALID_ARGUMENT, from, to);
    }
    if (store->edge_count >= config->max_edges) {
        return pgem_edge_capacity(config->max_edges, from, to, message);
    }
    const int tangent = PGEM_TANGENT_SIZE(config->dimension);
    int status = pgem_edge_check_ends(store, from, to, &from_index, &to_index, message);
    if (status == PGEM_OK) {
        status = pgem_check_pose(message, config->dimension, measurement, checked, "measurement");
    }
    if (status == PGEM_OK) {
        status = pgem_check_information(message, tangent, information);
    }
    if (status != PGEM_OK) {
        return status == PGEM_ERR_UNKNOWN_ID || status == PGEM_ERR_SELF_LOOP
                   ? status
                   : pgem_edge_fail_ids(message, status, from, to);
    }
    const uint32_t k = store->edge_count;
    const size_t pose_size = pgem_pose_doubles(tangent);
    const size_t info_size = (size_t)tangent * (size_t)tangent;
    store->edge_from[k] = (uint32_t)from_index;
    store->edge_to[k] = (uint32_t)to_index;
    memcpy(store->edge_measurement + (size_t)k * pose_size, checked, pose_size * sizeof(double));
    memcpy(store->edge_information + (size_t)k * info_size, information,
           info_size * sizeof(double));
    store->edge_kind[k] = (uint8_t)kind;
    store->edge_active[k] = PGEM_EDGE_ACTIVE;
    store->edge_weight[k] = 1.0;
    store->edge_count++;
    store->topology++;
    message[0] = '\0';
    if (edge_index != NULL) {
        *edge_index = k;
    }
    return PGEM_OK;
}

int pgem_store_edge_at(const pgem_store_t *store, uint32_t index, pgem_edge_view_t *view,
                       int tangent)
{
    if (view == NULL || index >= store->edge_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const size_t pose_size = pgem_pose_doubles(tangent);
    const size_t info_size = (size_t)tangent * (size_t)tangent;
    memset(view, 0, sizeof *view);
    view->from = store->pose_id[store->edge_from[index]];
    view->to = store->pose_id[store->edge_to[index]];
    view->kind = (pgem_edge_kind_t)store->edge_kind[index];
    memcpy(view->measurement, store->edge_measurement + (size_t)index * pose_size,
           pose_size * sizeof(double));
    memcpy(view->information, store->edge_information + (size_t)index * info_size,
           info_size * sizeof(double));
    view->weight = store->edge_weight[index];
    view->active = store->edge_active[index] != PGEM_EDGE_PRUNED; /* dormant: not pruned */
    return PGEM_OK;
}

/* An edge named by its poses' ids in messages. */
void pgem_store_edge_name(const pgem_store_t *store, uint32_t k, char *message)
{
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, store->pose_id[store->edge_from[k]]);
    pgem_edge_note(message, "-");
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, store->pose_id[store->edge_to[k]]);
}
