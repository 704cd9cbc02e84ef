/* The estimate and the loops' states kept in a caller's buffer and put back: a batch solve
 * stopped midway (a settle that gives way to new data) is undone exactly, and the incremental
 * factor, which the batch solve does not touch, is current again. */
#include <string.h>

#include "instance.h"
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
    header.online_ready = graph->online.ready;
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
    pgem_saved_copy(graph, NULL, buffer);
    graph->store.fixed_count = header.fixed_count;
    graph->store.edited_low = header.edited_low;
    graph->store.topology++; /* held flags may be back to others: the next analysis is anew */
    graph->online.ready = header.online_ready;
    pgem_linear_invalidate(graph);
    pgem_message_clear(graph);
    return PGEM_OK;
}
