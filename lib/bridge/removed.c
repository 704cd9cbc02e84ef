/* The poses compaction removed, as the admission state machine remembers them (admission.h):
 * each with its anchor (a kept pose) and where that lies in its frame, in a ring of
 * REMOVED_PER_POSE x max_poses; the ones the ring forgot as id ranges. A later edge to a
 * removed pose enters on its anchor; one to a forgotten pose is refused. */
#include <stdio.h>
#include <string.h>

#include "admission.h"
#include "pgem/geometry.h"

int ingest_removed(const pgem_ingest_t *ingest, pgem_id_t id)
{
    return key_table_find(&ingest->removed, id, 0)->used;
}

void ingest_removed_clear(pgem_ingest_t *ingest)
{
    key_table_clear(&ingest->removed);
    ingest->removed_head = 0;
    ingest->removed_count = 0;
    ingest->forgotten_count = 0;
}

/* An edge end on a removed pose moves to its anchor (following anchors removed since): the
 * measurement composed with where the anchor lies in the removed pose's frame, on the side
 * of that end. Returns 1 if it moved. */
static int reanchor_end(pgem_ingest_t *ingest, pgem_item_t *item, int to_end)
{
    const int three = ingest->config.dimension == 3;
    int moved = 0;
    for (int hops = 0; hops < 64; ++hops) {
        pgem_id_t *end = to_end ? &item->to : &item->from;
        const slot_t *slot = key_table_find(&ingest->removed, *end, 0);
        if (!slot->used) {
            break;
        }
        const double *relative = ingest->relative_ring + slot->content * PGEM_POSE_SIZE_MAX;
        double step[PGEM_POSE_SIZE_MAX], out[PGEM_POSE_SIZE_MAX];
        if (to_end) { /* z' = z T */
            (three ? pgem_se3_compose : pgem_se2_compose)(item->value, relative, out);
        } else { /* z' = T^-1 z */
            (three ? pgem_se3_inverse : pgem_se2_inverse)(relative, step);
            (three ? pgem_se3_compose : pgem_se2_compose)(step, item->value, out);
        }
        memcpy(item->value, out, sizeof(double) * (size_t)PGEM_POSE_SIZE(ingest->config.dimension));
        *end = ingest->anchor_ring[slot->content];
        moved = 1;
    }
    return moved;
}

/* Whether id lies within gap of [low, high] (no overflow at either end of the id space). */
static int id_near(pgem_id_t id, pgem_id_t low, pgem_id_t high, pgem_id_t gap)
{
    return (id >= low || low - id <= gap) && (id <= high || id - high <= gap);
}

/* A removed id the ring no longer remembers joins the forgotten ranges. */
static void forget(pgem_ingest_t *ingest, pgem_id_t id)
{
    const pgem_id_t gap = ingest->config.max_poses;
    for (uint32_t r = 0; r < ingest->forgotten_count; ++r) {
        if (id_near(id, ingest->forgotten_low[r], ingest->forgotten_high[r], gap)) {
            ingest->forgotten_low[r] = id < ingest->forgotten_low[r] ? id : ingest->forgotten_low[r];
            ingest->forgotten_high[r] =
                id > ingest->forgotten_high[r] ? id : ingest->forgotten_high[r];
            return;
        }
    }
    if (ingest->forgotten_count == FORGOTTEN_RANGES) { /* the two closest ranges become one */
        uint32_t a = 0, b = 1;
        pgem_id_t best = UINT64_MAX;
        for (uint32_t i = 0; i < FORGOTTEN_RANGES; ++i) {
            for (uint32_t j = i + 1; j < FORGOTTEN_RANGES; ++j) {
                const pgem_id_t li = ingest->forgotten_low[i], hi = ingest->forgotten_high[i];
                const pgem_id_t lj = ingest->forgotten_low[j], hj = ingest->forgotten_high[j];
                const pgem_id_t distance = lj > hi ? lj - hi : li > hj ? li - hj : 0u;
                if (distance < best) {
                    best = distance;
                    a = i;
                    b = j;
                }
            }
        }
        if (ingest->forgotten_low[b] < ingest->forgotten_low[a]) {
            ingest->forgotten_low[a] = ingest->forgotten_low[b];
        }
        if (ingest->forgotten_high[b] > ingest->forgotten_high[a]) {
            ingest->forgotten_high[a] = ingest->forgotten_high[b];
        }
        ingest->forgotten_count--;
        ingest->forgotten_low[b] = ingest->forgotten_low[ingest->forgotten_count];
        ingest->forgotten_high[b] = ingest->forgotten_high[ingest->forgotten_count];
    }
    ingest->forgotten_low[ingest->forgotten_count] = id;
    ingest->forgotten_high[ingest->forgotten_count++] = id;
}

int ingest_forgotten(const pgem_ingest_t *ingest, pgem_id_t id)
{
    if (ingest_pose_known(ingest, id)) {
        return 0;
    }
    for (uint32_t r = 0; r < ingest->forgotten_count; ++r) {
        if (id >= ingest->forgotten_low[r] && id <= ingest->forgotten_high[r]) {
            return 1;
        }
    }
    return 0;
}

void pgem_ingest_release(pgem_ingest_t *ingest, const pgem_id_t *ids, const pgem_id_t *anchors,
                         const double *relative, uint32_t id_count,
                         const pgem_ingest_released_t *edges, uint32_t edge_count)
{
    const uint32_t capacity = REMOVED_PER_POSE * ingest->config.max_poses;
    const size_t size = (size_t)PGEM_POSE_SIZE(ingest->config.dimension);
    for (uint32_t i = 0; i < id_count; ++i) {
        slot_t *slot = key_table_find(&ingest->poses, ids[i], 0);
        if (slot->used) {
            key_table_remove(&ingest->poses, slot);
            ingest->admitted_poses -= ingest->admitted_poses > 0u;
        }
        for (int low = 0; low < 2; ++low) { /* its steps: (id - 1, id) and (id, id + 1) */
            slot_t *step = key_table_find(&ingest->steps, ids[i] - (pgem_id_t)(1 - low), 0);
            if (step->used) {
                key_table_remove(&ingest->steps, step);
            }
        }
        if (ingest->removed_count == capacity) { /* forget the oldest */
            forget(ingest, ingest->removed_ring[ingest->removed_head]);
            key_table_remove(&ingest->removed,
                         key_table_find(&ingest->removed, ingest->removed_ring[ingest->removed_head], 0));
            ingest->removed_head = (ingest->removed_head + 1u) % capacity;
            ingest->removed_count--;
        }
        slot_t *removed = key_table_find(&ingest->removed, ids[i], 0);
        if (!removed->used) {
            const uint32_t at = (ingest->removed_head + ingest->removed_count) % capacity;
            key_table_take(removed, ids[i], 0, at);
            ingest->removed_ring[at] = ids[i];
            ingest->anchor_ring[at] = anchors[i];
            memcpy(ingest->relative_ring + (size_t)at * PGEM_POSE_SIZE_MAX, relative + i * size,
                   size * sizeof(double));
            ingest->removed_count++;
        }
    }
    for (uint32_t k = 0; k < edge_count; ++k) {
        slot_t *slot = key_table_find(&ingest->edges, edges[k].source, (uint64_t)edges[k].sequence);
        if (slot->used) {
            key_table_remove(&ingest->edges, slot);
            ingest->admitted_edges -= ingest->admitted_edges > 0u;
        }
    }
}

int ingest_reanchor(pgem_ingest_t *ingest, pgem_item_t *item)
{
    const int moved_from = reanchor_end(ingest, item, 0);
    return reanchor_end(ingest, item, 1) | moved_from;
}

void ingest_reanchored_goes_in(pgem_ingest_t *ingest, pgem_item_t *item)
{
    ingest->reanchored++;
    item->kind = PGEM_EDGE_LOOP;
}

int pgem_ingest_reanchor(pgem_ingest_t *ingest, pgem_item_t *item)
{
    if (!ingest_reanchor(ingest, item) || item->from == item->to) {
        return 0;
    }
    ingest_reanchored_goes_in(ingest, item);
    return 1;
}

int64_t pgem_ingest_reanchored(const pgem_ingest_t *ingest)
{
    return ingest->reanchored;
}
