/* The estimate and the loops' states kept in a caller's buffer and put back: a batch solve
 * stopped midway (a settle that gives way to new data) is undone exactly, and the incremental
 * factor, which the batch solve does not touch, is current again. */
#include <string.h>

#include "online/factor.h"

/* What the buffer starts with; the arrays follow it, byte-packed. */
typedef struct pgem_saved_header {
    uint32_t dimension;
    uint32_t pose_count;
    uint32_t edge_count;
    uint32_t fixed_count;
    uint32_t edited_low;
    int32_t online_ready;
} pgem_saved_header_t;

/* The saved arrays in buffer order after the header, for `poses` poses and `edges` edges: per
 * pose its value and held flag, per edge its weight, state, last distance and check. Returns
 * the bytes of header and arrays. */
#define PGEM_SAVED_FIELDS 6
static size_t pgem_saved_lengths(int pose_size, size_t poses, size_t edges,
                                 size_t lengths[PGEM_SAVED_FIELDS])
{
    const size_t bytes[PGEM_SAVED_FIELDS] = {poses * (size_t)pose_size * sizeof(double),
                                             poses, edges * sizeof(double), edges,
                                             edges * sizeof(double), edges};
    size_t total = sizeof(pgem_saved_header_t);
    for (int f = 0; f < PGEM_SAVED_FIELDS; f++) {
        lengths[f] = bytes[f];
        total += bytes[f];
    }
    return total;
}

static size_t pgem_saved_bytes(int pose_size, size_t poses, size_t edges)
{
    size_t lengths[PGEM_SAVED_FIELDS];
    return pgem_saved_lengths(pose_size, poses, edges, lengths);
}

/* Copies the arrays of the graph as it is between the instance and the buffer. */
static void pgem_saved_copy(const pgem_online_entry_t *entry, unsigned char *to_buffer,
                            const unsigned char *from_buffer)
{
    const pgem_store_t *store = entry->factor.store;
    const pgem_robust_state_t *robust = entry->robust.state;
    unsigned char *const fields[PGEM_SAVED_FIELDS] = {
        (unsigned char *)store->pose, store->pose_fixed, (unsigned char *)store->edge_weight,
        store->edge_active, (unsigned char *)robust->edge_distance, robust->edge_checked};
    size_t lengths[PGEM_SAVED_FIELDS];
    (void)pgem_saved_lengths(entry->factor.pose_size, store->pose_count, store->edge_count,
                             lengths);
    size_t at = sizeof(pgem_saved_header_t);
    for (int f = 0; f < PGEM_SAVED_FIELDS; f++) {
        if (to_buffer != NULL) {
            memcpy(to_buffer + at, fields[f], lengths[f]);
        } else {
            memcpy(fields[f], from_buffer + at, lengths[f]);
        }
        at += lengths[f];
    }
}

static void pgem_saved_text(char *message, const char *text)
{
    pgem_text_append(message, PGEM_MESSAGE_SIZE, text);
}

static void pgem_saved_u64(char *message, uint64_t value)
{
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, value);
}

/* "the save's " + what + " of pose i (id X)" or "... of edge k (F-T)" as the message start. */
static void pgem_saved_name(const pgem_store_t *store, char *message, const char *what, int edge,
                            uint32_t index)
{
    message[0] = '\0';
    pgem_saved_text(message, "the save's ");
    pgem_saved_text(message, what);
    pgem_saved_text(message, edge ? "edge " : "pose ");
    pgem_saved_u64(message, index);
    pgem_saved_text(message, " (");
    if (edge) {
        pgem_store_edge_name(store, index, message);
    } else {
        pgem_saved_text(message, "id ");
        pgem_saved_u64(message, store->pose_id[index]);
    }
    pgem_saved_text(message, ")");
}

static int pgem_saved_refuse(char *message, int code)
{
    pgem_saved_text(message, ": not a save of this graph, nothing restored");
    return code;
}

/* Everything a restore would put back, checked before anything is: each pose as
 * pgem_set_pose checks it, held flags known (free, fixed, a gauge or a part's gauge held by a
 * robust solve) and as many fixed as the header says, weights in
 * [0, 1], states known, the header's edited index and factor flag possible. (The robust
 * layer's last distances and checks are its own notes, rewritten before they are read.)
 * PGEM_OK, or the error with the message naming the pose or edge and the field. */
static int pgem_saved_check(const pgem_online_parts_t *parts, const unsigned char *buffer,
                            const pgem_saved_header_t *header)
{
    const pgem_store_t *store = parts->store;
    char *message = parts->message;
    size_t lengths[PGEM_SAVED_FIELDS];
    (void)pgem_saved_lengths(parts->pose_size, header->pose_count, header->edge_count, lengths);
    const unsigned char *pose = buffer + sizeof(pgem_saved_header_t);
    const unsigned char *held = pose + lengths[0];
    const unsigned char *weight = held + lengths[1];
    const unsigned char *state = weight + lengths[2];
    const size_t size = (size_t)parts->pose_size;
    uint32_t held_count = 0;
    for (uint32_t i = 0; i < header->pose_count; i++) {
        double value[PGEM_POSE_SIZE_MAX];
        memcpy(value, pose + (size_t)i * size * sizeof(double), size * sizeof(double));
        int field = -1;
        const int status = pgem_pose_check(value, parts->config->dimension, &field);
        if (status != PGEM_OK) {
            static const char *const names[2][7] = {{"x", "y", "theta", "", "", "", ""},
                                                    {"x", "y", "z", "qx", "qy", "qz", "qw"}};
            pgem_saved_name(store, message, "", 0, i);
            pgem_saved_text(message, ": ");
            if (status == PGEM_ERR_ROTATION) {
                pgem_saved_text(message, "the quaternion is not of unit norm");
            } else {
                pgem_saved_text(message, "field ");
                pgem_saved_text(message, names[size == 7u][field >= 0 ? field : 0]);
                pgem_saved_text(message, status == PGEM_ERR_NOT_FINITE
                                             ? " is not finite"
                                             : " is beyond the translation limit (1e8 m)");
            }
            return pgem_saved_refuse(message, status);
        }
        if (held[i] > PGEM_POSE_PART_NEW) {
            pgem_saved_name(store, message, "held flag of ", 0, i);
            pgem_saved_text(message, " is ");
            pgem_saved_u64(message, held[i]);
            pgem_saved_text(message, ", not a hold (0 to 4)");
            return pgem_saved_refuse(message, PGEM_ERR_INVALID_ARGUMENT);
        }
        held_count += held[i] == PGEM_POSE_FIXED;
    }
    if (held_count != header->fixed_count) {
        message[0] = '\0';
        pgem_saved_text(message, "the save counts ");
        pgem_saved_u64(message, header->fixed_count);
        pgem_saved_text(message, " held poses and flags ");
        pgem_saved_u64(message, held_count);
        return pgem_saved_refuse(message, PGEM_ERR_INVALID_ARGUMENT);
    }
    for (uint32_t k = 0; k < header->edge_count; k++) {
        double w;
        memcpy(&w, weight + (size_t)k * sizeof(double), sizeof w);
        if (!(w >= 0.0 && w <= 1.0)) {
            pgem_saved_name(store, message, "weight of ", 1, k);
            pgem_saved_text(message, " is ");
            pgem_saved_text(message, w != w ? "NaN" : w > 1.0 ? "above 1" : "below 0");
            return pgem_saved_refuse(message, PGEM_ERR_INVALID_ARGUMENT);
        }
        if (state[k] > (unsigned char)PGEM_EDGE_DORMANT) {
            pgem_saved_name(store, message, "state of ", 1, k);
            pgem_saved_text(message, " is ");
            pgem_saved_u64(message, state[k]);
            pgem_saved_text(message, " (pruned 0, active 1, dormant 2)");
            return pgem_saved_refuse(message, PGEM_ERR_INVALID_ARGUMENT);
        }
    }
    if (header->edited_low != UINT32_MAX && header->edited_low >= header->pose_count) {
        message[0] = '\0';
        pgem_saved_text(message, "the save's edited pose index ");
        pgem_saved_u64(message, header->edited_low);
        pgem_saved_text(message, " is past its ");
        pgem_saved_u64(message, header->pose_count);
        pgem_saved_text(message, " poses");
        return pgem_saved_refuse(message, PGEM_ERR_INVALID_ARGUMENT);
    }
    if (header->online_ready != 0 && header->online_ready != 1) {
        message[0] = '\0';
        pgem_saved_text(message, "the save's factor-current flag is ");
        pgem_text_i64(message, PGEM_MESSAGE_SIZE, header->online_ready);
        pgem_saved_text(message, ", not 0 or 1");
        return pgem_saved_refuse(message, PGEM_ERR_INVALID_ARGUMENT);
    }
    return PGEM_OK;
}

size_t pgem_online_save_size(int pose_size, const pgem_config_t *config)
{
    return pgem_saved_bytes(pose_size, config->max_poses, config->max_edges);
}

int pgem_online_save(const pgem_online_entry_t *entry, void *buffer, size_t size)
{
    const pgem_online_parts_t *parts = &entry->factor;
    const pgem_store_t *store = parts->store;
    if (size < pgem_saved_bytes(parts->pose_size, store->pose_count, store->edge_count)) {
        return pgem_text_fail(parts->message, PGEM_ERR_INVALID_ARGUMENT,
                              "the save buffer is smaller than pgem_update_save_size says");
    }
    pgem_saved_header_t header;
    memset(&header, 0, sizeof header);
    header.dimension = (uint32_t)parts->config->dimension;
    header.pose_count = store->pose_count;
    header.edge_count = store->edge_count;
    header.fixed_count = store->fixed_count;
    header.edited_low = store->edited_low;
    pgem_online_sync(parts);
    header.online_ready = parts->online->ready;
    memcpy(buffer, &header, sizeof header);
    pgem_saved_copy(entry, buffer, NULL);
    return PGEM_OK;
}

int pgem_online_restore(const pgem_online_entry_t *entry, const void *buffer, size_t size)
{
    const pgem_online_parts_t *parts = &entry->factor;
    pgem_store_t *store = parts->store;
    char *message = parts->message;
    pgem_saved_header_t header;
    if (size < sizeof header) {
        return pgem_text_fail(message, PGEM_ERR_INVALID_ARGUMENT, "the save buffer is too small");
    }
    memcpy(&header, buffer, sizeof header);
    if (header.dimension != (uint32_t)parts->config->dimension ||
        header.pose_count != store->pose_count || header.edge_count != store->edge_count ||
        size < pgem_saved_bytes(parts->pose_size, header.pose_count, header.edge_count)) {
        message[0] = '\0';
        pgem_saved_text(message, "the save holds ");
        pgem_saved_u64(message, header.pose_count);
        pgem_saved_text(message, " poses and ");
        pgem_saved_u64(message, header.edge_count);
        pgem_saved_text(message, " edges, the graph ");
        pgem_saved_u64(message, store->pose_count);
        pgem_saved_text(message, " and ");
        pgem_saved_u64(message, store->edge_count);
        pgem_saved_text(message, " (or another dimension): nothing restored");
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const int checked = pgem_saved_check(parts, buffer, &header);
    if (checked != PGEM_OK) {
        return checked;
    }
    pgem_saved_copy(entry, NULL, buffer);
    store->fixed_count = header.fixed_count;
    store->edited_low = header.edited_low;
    store->topology++; /* held flags may be back to others: the next analysis is anew */
    parts->online->ready = header.online_ready;
    parts->online->solves_seen = store->solves;
    pgem_linear_invalidate(parts->linear);
    message[0] = '\0';
    return PGEM_OK;
}
