/* The estimate and the loops' states kept in a caller's buffer and put back: a batch solve
 * stopped midway (a settle that gives way to new data) is undone exactly, and the incremental
 * factor, which the batch solve does not touch, is current again. */
#include <string.h>

#include "online/factor.h"
#include "pgem/update.h"
#include "robust/robust.h"

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
static size_t pgem_saved_layout(const pgem_t *graph, size_t poses, size_t edges,
                                unsigned char *fields[PGEM_SAVED_FIELDS],
                                size_t lengths[PGEM_SAVED_FIELDS])
{
    unsigned char *const arrays[PGEM_SAVED_FIELDS] = {
        (unsigned char *)graph->store.pose, graph->store.pose_fixed,
        (unsigned char *)graph->store.edge_weight, graph->store.edge_active,
        (unsigned char *)graph->robust.edge_distance, graph->robust.edge_checked};
    const size_t bytes[PGEM_SAVED_FIELDS] = {poses * (size_t)graph->pose_size * sizeof(double),
                                             poses, edges * sizeof(double), edges,
                                             edges * sizeof(double), edges};
    size_t total = sizeof(pgem_saved_header_t);
    for (int f = 0; f < PGEM_SAVED_FIELDS; f++) {
        fields[f] = arrays[f];
        lengths[f] = bytes[f];
        total += bytes[f];
    }
    return total;
}

static size_t pgem_saved_bytes(const pgem_t *graph, size_t poses, size_t edges)
{
    unsigned char *fields[PGEM_SAVED_FIELDS];
    size_t lengths[PGEM_SAVED_FIELDS];
    return pgem_saved_layout(graph, poses, edges, fields, lengths);
}

/* Copies the arrays of the graph as it is between the instance and the buffer. */
static void pgem_saved_copy(const pgem_t *graph, unsigned char *to_buffer, const unsigned char *from_buffer)
{
    unsigned char *fields[PGEM_SAVED_FIELDS];
    size_t lengths[PGEM_SAVED_FIELDS];
    (void)pgem_saved_layout(graph, graph->store.pose_count, graph->store.edge_count, fields, lengths);
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

/* "the save's " + what + " of pose i (id X)" or "... of edge k (F-T)" as the message start. */
static void pgem_saved_name(pgem_t *graph, const char *what, int edge, uint32_t index)
{
    pgem_message_clear(graph);
    pgem_message_text(graph, "the save's ");
    pgem_message_text(graph, what);
    pgem_message_text(graph, edge ? "edge " : "pose ");
    pgem_message_u64(graph, index);
    pgem_message_text(graph, " (");
    if (edge) {
        pgem_message_edge(graph, index);
    } else {
        pgem_message_text(graph, "id ");
        pgem_message_u64(graph, graph->store.pose_id[index]);
    }
    pgem_message_text(graph, ")");
}

static int pgem_saved_refuse(pgem_t *graph, int code)
{
    pgem_message_text(graph, ": not a save of this graph, nothing restored");
    return code;
}

/* Everything a restore would put back, checked before anything is: each pose as
 * pgem_set_pose checks it, held flags known (free, fixed, a gauge or a part's gauge held by a
 * robust solve) and as many fixed as the header says, weights in
 * [0, 1], states known, the header's edited index and factor flag possible. (The robust
 * layer's last distances and checks are its own notes, rewritten before they are read.)
 * PGEM_OK, or the error with the message naming the pose or edge and the field. */
static int pgem_saved_check(pgem_t *graph, const unsigned char *buffer,
                            const pgem_saved_header_t *header)
{
    unsigned char *fields[PGEM_SAVED_FIELDS];
    size_t lengths[PGEM_SAVED_FIELDS];
    (void)pgem_saved_layout(graph, header->pose_count, header->edge_count, fields, lengths);
    const unsigned char *pose = buffer + sizeof(pgem_saved_header_t);
    const unsigned char *held = pose + lengths[0];
    const unsigned char *weight = held + lengths[1];
    const unsigned char *state = weight + lengths[2];
    const size_t size = (size_t)graph->pose_size;
    uint32_t held_count = 0;
    for (uint32_t i = 0; i < header->pose_count; i++) {
        double value[PGEM_POSE_SIZE_MAX];
        memcpy(value, pose + (size_t)i * size * sizeof(double), size * sizeof(double));
        int field = -1;
        const int status = pgem_pose_check(value, graph->config.dimension, &field);
        if (status != PGEM_OK) {
            static const char *const names[2][7] = {{"x", "y", "theta", "", "", "", ""},
                                                    {"x", "y", "z", "qx", "qy", "qz", "qw"}};
            pgem_saved_name(graph, "", 0, i);
            pgem_message_text(graph, ": ");
            if (status == PGEM_ERR_ROTATION) {
                pgem_message_text(graph, "the quaternion is not of unit norm");
            } else {
                pgem_message_text(graph, "field ");
                pgem_message_text(graph, names[size == 7u][field >= 0 ? field : 0]);
                pgem_message_text(graph, status == PGEM_ERR_NOT_FINITE
                                             ? " is not finite"
                                             : " is beyond the translation limit (1e8 m)");
            }
            return pgem_saved_refuse(graph, status);
        }
        if (held[i] > PGEM_POSE_PART_NEW) {
            pgem_saved_name(graph, "held flag of ", 0, i);
            pgem_message_text(graph, " is ");
            pgem_message_u64(graph, held[i]);
            pgem_message_text(graph, ", not a hold (0 to 4)");
            return pgem_saved_refuse(graph, PGEM_ERR_INVALID_ARGUMENT);
        }
        held_count += held[i] == PGEM_POSE_FIXED;
    }
    if (held_count != header->fixed_count) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "the save counts ");
        pgem_message_u64(graph, header->fixed_count);
        pgem_message_text(graph, " held poses and flags ");
        pgem_message_u64(graph, held_count);
        return pgem_saved_refuse(graph, PGEM_ERR_INVALID_ARGUMENT);
    }
    for (uint32_t k = 0; k < header->edge_count; k++) {
        double w;
        memcpy(&w, weight + (size_t)k * sizeof(double), sizeof w);
        if (!(w >= 0.0 && w <= 1.0)) {
            pgem_saved_name(graph, "weight of ", 1, k);
            pgem_message_text(graph, " is ");
            pgem_message_text(graph, w != w ? "NaN" : w > 1.0 ? "above 1" : "below 0");
            return pgem_saved_refuse(graph, PGEM_ERR_INVALID_ARGUMENT);
        }
        if (state[k] > (unsigned char)PGEM_EDGE_DORMANT) {
            pgem_saved_name(graph, "state of ", 1, k);
            pgem_message_text(graph, " is ");
            pgem_message_u64(graph, state[k]);
            pgem_message_text(graph, " (pruned 0, active 1, dormant 2)");
            return pgem_saved_refuse(graph, PGEM_ERR_INVALID_ARGUMENT);
        }
    }
    if (header->edited_low != UINT32_MAX && header->edited_low >= header->pose_count) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "the save's edited pose index ");
        pgem_message_u64(graph, header->edited_low);
        pgem_message_text(graph, " is past its ");
        pgem_message_u64(graph, header->pose_count);
        pgem_message_text(graph, " poses");
        return pgem_saved_refuse(graph, PGEM_ERR_INVALID_ARGUMENT);
    }
    if (header->online_ready != 0 && header->online_ready != 1) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "the save's factor-current flag is ");
        pgem_message_i64(graph, header->online_ready);
        pgem_message_text(graph, ", not 0 or 1");
        return pgem_saved_refuse(graph, PGEM_ERR_INVALID_ARGUMENT);
    }
    return PGEM_OK;
}

size_t pgem_update_save_size(const pgem_t *graph)
{
    return graph != NULL ? pgem_saved_bytes(graph, graph->config.max_poses, graph->config.max_edges)
                         : 0u;
}

int pgem_update_save(pgem_t *graph, void *buffer, size_t size)
{
    if (graph == NULL || buffer == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (size < pgem_saved_bytes(graph, graph->store.pose_count, graph->store.edge_count)) {
        return pgem_fail(graph, PGEM_ERR_INVALID_ARGUMENT,
                         "the save buffer is smaller than pgem_update_save_size says");
    }
    pgem_saved_header_t header;
    memset(&header, 0, sizeof header);
    header.dimension = (uint32_t)graph->config.dimension;
    header.pose_count = graph->store.pose_count;
    header.edge_count = graph->store.edge_count;
    header.fixed_count = graph->store.fixed_count;
    header.edited_low = graph->store.edited_low;
    pgem_online_sync(graph);
    header.online_ready = graph->online->ready;
    memcpy(buffer, &header, sizeof header);
    pgem_saved_copy(graph, buffer, NULL);
    return PGEM_OK;
}

int pgem_update_restore(pgem_t *graph, const void *buffer, size_t size)
{
    if (graph == NULL || buffer == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    pgem_saved_header_t header;
    if (size < sizeof header) {
        return pgem_fail(graph, PGEM_ERR_INVALID_ARGUMENT, "the save buffer is too small");
    }
    memcpy(&header, buffer, sizeof header);
    if (header.dimension != (uint32_t)graph->config.dimension ||
        header.pose_count != graph->store.pose_count || header.edge_count != graph->store.edge_count ||
        size < pgem_saved_bytes(graph, header.pose_count, header.edge_count)) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "the save holds ");
        pgem_message_u64(graph, header.pose_count);
        pgem_message_text(graph, " poses and ");
        pgem_message_u64(graph, header.edge_count);
        pgem_message_text(graph, " edges, the graph ");
        pgem_message_u64(graph, graph->store.pose_count);
        pgem_message_text(graph, " and ");
        pgem_message_u64(graph, graph->store.edge_count);
        pgem_message_text(graph, " (or another dimension): nothing restored");
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const int checked = pgem_saved_check(graph, buffer, &header);
    if (checked != PGEM_OK) {
        return checked;
    }
    pgem_saved_copy(graph, NULL, buffer);
    graph->store.fixed_count = header.fixed_count;
    graph->store.edited_low = header.edited_low;
    graph->store.topology++; /* held flags may be back to others: the next analysis is anew */
    graph->online->ready = header.online_ready;
    graph->online->solves_seen = graph->store.solves;
    pgem_linear_invalidate(graph->linear);
    pgem_message_clear(graph);
    return PGEM_OK;
}
