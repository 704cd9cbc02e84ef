/* The admission state machine: each decoded message (wire.c) checked, deduplicated, its
 * capacity reserved, edges held for missing poses (and aged out), changes offered to the admit
 * hook, items emitted. The poses compaction removed: removed.c. */
#include "admission.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pgem/geometry.h"
#include "utf8.h"
#include "wire.h"

#define DEFAULT_MAX_PENDING 4096u
#define DEFAULT_MAX_SOURCES 64u
static const char *const reject_names[PGEM_REJECT_COUNT] = {
    "decode", "dimension", "not_finite", "information", "rotation", "self_loop", "kind",
    "source", "conflict", "capacity", "pending_full", "command", "core", "range", "journal",
    "removed", "expired", "full", "forgotten"};

const char *pgem_reject_name(pgem_reject_t reason)
{
    return (unsigned)reason < PGEM_REJECT_COUNT ? reject_names[reason] : "unknown";
}

/* FNV-1a over the bytes of the fields that make an item's content. */
static uint64_t fnv(uint64_t hash, const void *data, size_t size)
{
    const unsigned char *bytes = data;
    for (size_t i = 0; i < size; ++i) {
        hash = (hash ^ bytes[i]) * 0x100000001B3ull;
    }
    return hash;
}

static uint64_t item_content(const pgem_item_t *item, int dimension)
{
    uint64_t hash = 0xCBF29CE484222325ull;
    hash = fnv(hash, &item->type, sizeof item->type);
    hash = fnv(hash, &item->kind, sizeof item->kind);
    hash = fnv(hash, &item->from, sizeof item->from);
    hash = fnv(hash, &item->to, sizeof item->to);
    hash = fnv(hash, item->value, sizeof(double) * PGEM_POSE_SIZE(dimension));
    if (item->type == PGEM_ITEM_EDGE) {
        int n = PGEM_TANGENT_SIZE(dimension);
        hash = fnv(hash, item->information, sizeof(double) * (size_t)(n * (n + 1) / 2));
    }
    return hash;
}

void pgem_ingest_config_resolve(pgem_ingest_config_t *config)
{
    if (config->max_pending == 0) {
        config->max_pending = DEFAULT_MAX_PENDING;
    }
    if (config->max_sources == 0) {
        config->max_sources = DEFAULT_MAX_SOURCES;
    }
    if (config->max_sources > UINT16_MAX) {
        config->max_sources = UINT16_MAX;
    }
    if (config->pending_timeout <= 0) {
        config->pending_timeout = PGEM_PENDING_TIMEOUT_DEFAULT;
    }
}

/* Every pending slot free, no edge waiting. */
static void pending_clear(pgem_ingest_t *ingest)
{
    for (uint32_t k = 0; k < ingest->config.max_pending; ++k) {
        ingest->free_slots[k] = ingest->config.max_pending - 1 - k;
    }
    ingest->free_count = ingest->config.max_pending;
    ingest->oldest = NONE;
    ingest->newest = NONE;
    ingest->pending_count = 0;
    for (uint32_t s = 0; s < ingest->source_count; ++s) {
        ingest->sources[s].waiting = 0;
        ingest->sources[s].oldest = NONE;
        ingest->sources[s].newest = NONE;
    }
}

pgem_ingest_t *pgem_ingest_create(const pgem_ingest_config_t *config, pgem_emit_fn emit,
                                  void *user)
{
    if (config == NULL || emit == NULL || (config->dimension != 2 && config->dimension != 3) ||
        config->max_poses == 0 || config->max_edges == 0) {
        return NULL;
    }
    pgem_ingest_t *ingest = calloc(1, sizeof *ingest);
    if (ingest == NULL) {
        return NULL;
    }
    ingest->config = *config;
    pgem_ingest_config_resolve(&ingest->config);
    ingest->emit = emit;
    ingest->user = user;
    ingest->pending = calloc(ingest->config.max_pending, sizeof *ingest->pending);
    ingest->free_slots = calloc(ingest->config.max_pending, sizeof *ingest->free_slots);
    ingest->sources = calloc(ingest->config.max_sources, sizeof *ingest->sources);
    if (!key_table_init(&ingest->poses, config->max_poses) ||
        !key_table_init(&ingest->edges, config->max_edges) ||
        !key_table_init(&ingest->steps, config->max_poses) ||
        !key_table_init(&ingest->removed, REMOVED_PER_POSE * config->max_poses) ||
        (ingest->removed_ring = calloc((size_t)REMOVED_PER_POSE * config->max_poses,
                                       sizeof *ingest->removed_ring)) == NULL ||
        (ingest->anchor_ring = calloc((size_t)REMOVED_PER_POSE * config->max_poses,
                                      sizeof *ingest->anchor_ring)) == NULL ||
        (ingest->relative_ring = calloc((size_t)REMOVED_PER_POSE * config->max_poses * PGEM_POSE_SIZE_MAX,
                                        sizeof *ingest->relative_ring)) == NULL ||
        ingest->pending == NULL ||
        ingest->free_slots == NULL || ingest->sources == NULL) {
        pgem_ingest_destroy(ingest);
        return NULL;
    }
    pending_clear(ingest);
    return ingest;
}

void pgem_ingest_destroy(pgem_ingest_t *ingest)
{
    if (ingest != NULL) {
        free(ingest->poses.slots);
        free(ingest->edges.slots);
        free(ingest->steps.slots);
        free(ingest->removed.slots);
        free(ingest->removed_ring);
        free(ingest->anchor_ring);
        free(ingest->relative_ring);
        free(ingest->pending);
        free(ingest->free_slots);
        free(ingest->sources);
        free(ingest);
    }
}

void pgem_ingest_set_admit(pgem_ingest_t *ingest, pgem_admit_fn admit, void *user)
{
    ingest->admit = admit;
    ingest->admit_user = user;
}

void pgem_ingest_set_snapshot_check(pgem_ingest_t *ingest, pgem_snapshot_check_fn check,
                                    void *user)
{
    ingest->snapshot_check = check;
    ingest->snapshot_user = user;
}

void pgem_ingest_counts(const pgem_ingest_t *ingest, pgem_ingest_counts_t *counts)
{
    *counts = ingest->counts;
    counts->pending = ingest->pending_count;
}

uint32_t pgem_ingest_source_count(const pgem_ingest_t *ingest)
{
    return ingest->source_count;
}

const char *pgem_ingest_source_name(const pgem_ingest_t *ingest, uint32_t index)
{
    return index < ingest->source_count ? ingest->sources[index].name : "";
}

const char *pgem_ingest_last_expiry(const pgem_ingest_t *ingest)
{
    return ingest->last_expiry;
}

const char *pgem_ingest_last_odometry_note(const pgem_ingest_t *ingest)
{
    return ingest->last_odometry;
}

static void reject(pgem_ingest_t *ingest, pgem_ingest_result_t *result, pgem_reject_t reason)
{
    result->verdict = PGEM_VERDICT_REJECTED;
    result->reason = reason;
    ingest->counts.rejected[reason]++;
}

/* The admit hook's verdict on the message being handled: 1 to go ahead, or 0 with the
 * rejection (reason journal) filled. Called after every check, before any change. */
static int admitted(pgem_ingest_t *ingest, const char *what, pgem_ingest_result_t *result)
{
    char why[256] = "";
    if (ingest->admit == NULL ||
        ingest->admit(ingest->admit_user, ingest->data, ingest->size, why, sizeof why) == 0) {
        return 1;
    }
    snprintf(result->message, sizeof result->message,
             "%s: not accepted, it could not be journaled (%s); nothing changed, resend it", what,
             why[0] != '\0' ? why : "the journal refused it");
    reject(ingest, result, PGEM_REJECT_JOURNAL);
    return 0;
}

/* ---- checks shared by poses and edges ---------------------------------------------------- */

/* The index of a source name: a known source's, or for a new one the slot it will take if its
 * edge is admitted (a rejected message must not use up the source table). -1 (result filled)
 * when the name is refused or the table is full. */
static int source_index(pgem_ingest_t *ingest, const char *name, pgem_ingest_result_t *result)
{
    if (!pgem_wire_source_ok(name, result->message, sizeof result->message)) {
        return -1;
    }
    int free_slot = -1;
    for (uint32_t i = 0; i < ingest->source_count; ++i) {
        if (strcmp(ingest->sources[i].name, name) == 0) {
            return (int)i;
        }
        if (free_slot < 0 && ingest->sources[i].name[0] == '\0') {
            free_slot = (int)i;
        }
    }
    if (free_slot >= 0) {
        return free_slot;
    }
    if (ingest->source_count == ingest->config.max_sources) {
        snprintf(result->message, sizeof result->message,
                 "source '%s' is new and the bridge already has %u sources (--max-sources)",
                 name, (unsigned)ingest->config.max_sources);
        return -1;
    }
    return (int)ingest->source_count;
}

/* Admits an edge's source: a new name takes the slot source_index gave it. */
static void source_admit(pgem_ingest_t *ingest, uint32_t index, const char *name,
                         int64_t sequence)
{
    source_t *source = &ingest->sources[index];
    if (source->name[0] == '\0' && name != NULL) { /* source_index refused NULL */
        memset(source, 0, sizeof *source);
        memcpy(source->name, name, strlen(name) + 1);
        source->last = -1;
        source->oldest = NONE;
        source->newest = NONE;
        if (index == ingest->source_count) {
            ingest->source_count++;
        }
    }
    if (sequence > source->last) {
        source->last = sequence;
    }
}

/* A source that never had an edge in the graph and has none waiting leaves the table. */
static void source_release(pgem_ingest_t *ingest, uint32_t index)
{
    source_t *source = &ingest->sources[index];
    if (source->waiting > 0 || source->emitted) {
        return;
    }
    memset(source, 0, sizeof *source);
    source->last = -1;
    source->oldest = NONE;
    source->newest = NONE;
    while (ingest->source_count > 0 && ingest->sources[ingest->source_count - 1].name[0] == '\0') {
        ingest->source_count--;
    }
}

/* A pose estimate or a measurement (wire.c's check): 1, or 0 with the rejection filled. */
static int values_ok(pgem_ingest_t *ingest, const double *values, const char *what,
                     const char *noun, pgem_ingest_result_t *result)
{
    const pgem_reject_t reason = pgem_wire_check_values(
        ingest->config.dimension, values, what, noun, result->message, sizeof result->message);
    if (reason != PGEM_REJECT_COUNT) {
        reject(ingest, result, reason);
        return 0;
    }
    return 1;
}

/* The slot a new key (a, b) with this content will take. A replay (same key, same content), a
 * conflict (same key, other content) or a full capacity (admitted == limit) ends here: NULL,
 * with the result filled. */
static slot_t *claim(pgem_ingest_t *ingest, table_t *table, uint64_t a, uint64_t b,
                     uint64_t content, uint32_t admitted_count, uint32_t limit, const char *what,
                     const char *conflict, const char *items, pgem_ingest_result_t *result)
{
    slot_t *slot = key_table_find(table, a, b);
    if (slot->used) {
        if (slot->content == content) {
            result->verdict = PGEM_VERDICT_REPLAY;
            ingest->counts.replays++;
            return NULL;
        }
        snprintf(result->message, sizeof result->message, "%s: %s", what, conflict);
        reject(ingest, result, PGEM_REJECT_CONFLICT);
        return NULL;
    }
    const uint32_t full = table == &ingest->poses ? ingest->full_poses : ingest->full_edges;
    if (full != 0u && admitted_count >= full) {
        snprintf(result->message, sizeof result->message,
                 "%s: the block's %u %s are full and compaction can free nothing (%s)", what,
                 (unsigned)full, items, ingest->full_why);
        reject(ingest, result, PGEM_REJECT_FULL);
        return NULL;
    }
    if (admitted_count >= limit) {
        snprintf(result->message, sizeof result->message,
                 "%s: the bridge holds its maximum of %u %s (--max-%s%s)", what, (unsigned)limit,
                 items, items, ingest->config.compact
                                   ? ", and half as many again waiting for a solver thread "
                                     "that is behind"
                                   : "");
        reject(ingest, result, PGEM_REJECT_CAPACITY);
        return NULL;
    }
    return slot;
}

/* 1 (the message refused, naming the pose) if a pose message's id is one compaction removed. */
static int refuse_removed(pgem_ingest_t *ingest, pgem_id_t id, const char *what,
                          pgem_ingest_result_t *result)
{
    if (!ingest_removed(ingest, id)) {
        return 0;
    }
    snprintf(result->message, sizeof result->message,
             "%s: pose %llu was removed from the map to keep it in its block (compaction: its "
             "neighbours and loop closures were kept); a removed pose's id is not taken again",
             what, (unsigned long long)id);
    reject(ingest, result, PGEM_REJECT_REMOVED);
    return 1;
}

void pgem_ingest_set_full(pgem_ingest_t *ingest, uint32_t poses, uint32_t edges, const char *why)
{
    ingest->full_poses = poses;
    ingest->full_edges = edges;
    snprintf(ingest->full_why, sizeof ingest->full_why, "%s", why != NULL ? why : "");
}

/* ---- the pending list ------------------------------------------------------------------- */

/* Appends an edge to the waiting lists (a free slot exists: the caller checked). */
static void pending_add(pgem_ingest_t *ingest, const pgem_item_t *item, int64_t since)
{
    uint32_t k = ingest->free_slots[--ingest->free_count];
    waiting_t *entry = &ingest->pending[k];
    source_t *source = &ingest->sources[item->source];
    entry->item = *item;
    entry->since = since;
    entry->prev = ingest->newest;
    entry->next = NONE;
    entry->source_prev = source->newest;
    entry->source_next = NONE;
    if (ingest->newest != NONE) {
        ingest->pending[ingest->newest].next = k;
    } else {
        ingest->oldest = k;
    }
    ingest->newest = k;
    if (source->newest != NONE) {
        ingest->pending[source->newest].source_next = k;
    } else {
        source->oldest = k;
    }
    source->newest = k;
    source->waiting++;
    ingest->pending_count++;
}

/* Takes an edge out of the waiting lists and frees its slot. */
static void pending_remove(pgem_ingest_t *ingest, uint32_t k)
{
    waiting_t *entry = &ingest->pending[k];
    source_t *source = &ingest->sources[entry->item.source];
    if (entry->prev != NONE) {
        ingest->pending[entry->prev].next = entry->next;
    } else {
        ingest->oldest = entry->next;
    }
    if (entry->next != NONE) {
        ingest->pending[entry->next].prev = entry->prev;
    } else {
        ingest->newest = entry->prev;
    }
    if (entry->source_prev != NONE) {
        ingest->pending[entry->source_prev].source_next = entry->source_next;
    } else {
        source->oldest = entry->source_next;
    }
    if (entry->source_next != NONE) {
        ingest->pending[entry->source_next].source_prev = entry->source_prev;
    } else {
        source->newest = entry->source_prev;
    }
    source->waiting--;
    ingest->pending_count--;
    ingest->free_slots[ingest->free_count++] = k;
}

/* "edge F -> T (source 'S', sequence Q)" for messages; the name is escaped, so this also
 * serves a name that was refused. */
static void edge_what(char *what, size_t size, const pgem_item_t *item, const char *source)
{
    char shown[128];
    snprintf(what, size, "edge %llu -> %llu (source '%s', sequence %lld)",
             (unsigned long long)item->from, (unsigned long long)item->to,
             pgem_utf8_escape(shown, sizeof shown, source != NULL ? source : ""),
             (long long)item->sequence);
}

/* An accepted edge leaves without reaching the graph: its key and capacity are freed (a later
 * resend is a new edge), it moves from the accepted count to `expired`, and a source that
 * never had an edge in the graph goes when its last waiting edge does. */
static void pending_expire(pgem_ingest_t *ingest, uint32_t k, const char *why)
{
    waiting_t *entry = &ingest->pending[k];
    uint32_t source = entry->item.source;
    char what[200];
    edge_what(what, sizeof what, &entry->item, ingest->sources[source].name);
    snprintf(ingest->last_expiry, sizeof ingest->last_expiry, "%s expired: %s", what, why);
    key_table_remove(&ingest->edges, key_table_find(&ingest->edges, source, (uint64_t)entry->item.sequence));
    pending_remove(ingest, k);
    ingest->admitted_edges--;
    ingest->counts.accepted_edges--;
    ingest->counts.rejected[PGEM_REJECT_EXPIRED]++;
    source_release(ingest, source);
}

/* Microseconds from since to now, 0 when the clock went back (no overflow for any times). */
static uint64_t age(int64_t since, int64_t now)
{
    return now > since ? (uint64_t)now - (uint64_t)since : 0u;
}

uint32_t pgem_ingest_expire(pgem_ingest_t *ingest, int64_t utime)
{
    uint32_t expired = 0;
    while (ingest->oldest != NONE && age(ingest->pending[ingest->oldest].since, utime) >
                                         (uint64_t)ingest->config.pending_timeout) {
        const pgem_item_t *item = &ingest->pending[ingest->oldest].item;
        char why[160];
        snprintf(why, sizeof why, "it waited %.1f s for pose %llu (--pending-timeout %.0f s)",
                 (double)age(ingest->pending[ingest->oldest].since, utime) * 1e-6,
                 (unsigned long long)(ingest_pose_known(ingest, item->from) ? item->to : item->from),
                 (double)ingest->config.pending_timeout * 1e-6);
        pending_expire(ingest, ingest->oldest, why);
        expired++;
    }
    return expired;
}

/* When the list is full, the edge that makes room for one of `source` (its slot may be new):
 * the oldest waiting edge of the source holding the most, if that source holds more than
 * `source` does. NONE when no source does: the newcomer is refused. So a sender that floods
 * the list only ever displaces its own edges. */
static uint32_t pending_victim(const pgem_ingest_t *ingest, uint32_t source)
{
    uint32_t most = 0;
    uint32_t holder = NONE;
    for (uint32_t s = 0; s < ingest->source_count; ++s) {
        if (ingest->sources[s].waiting > most) {
            most = ingest->sources[s].waiting;
            holder = s;
        }
    }
    uint32_t own = source < ingest->source_count ? ingest->sources[source].waiting : 0;
    return holder != NONE && most > own ? ingest->sources[holder].oldest : NONE;
}

/* Ids that differ by exactly one, without unsigned wrap-around (2^64 - 1 and 0 do not): the
 * pgem I/O reader's rule for odometry, so a graph file streamed by pgem-lcm-send keeps the
 * kinds the offline tools give it. */
static int ids_consecutive(pgem_id_t a, pgem_id_t b)
{
    return (a > b ? a - b : b - a) == 1u;
}

/* An edge goes into the graph (its poses are known). The wire's kind is the front-end's claim;
 * the robust layer trusts ODOMETRY (weight 1, never pruned), so the claim is checked against
 * the chain it would extend: an ODOMETRY edge is odometry only when it is a step, its poses'
 * ids one apart, and no odometry edge in the graph joins those two poses yet (the first to
 * enter the graph holds the step, whatever its source; a source's own second edge between
 * them is a second opinion too). Otherwise it enters as a loop closure, weighed and prunable
 * like any, counted and named. The decision depends only on the order in which edges enter
 * the graph, which the journal's replay reproduces. The item keeps the kind it was sent with
 * in its key's content, so a resend of the same message is still a replay. */
static void emit_edge(pgem_ingest_t *ingest, pgem_item_t *item)
{
    ingest->sources[item->source].emitted = 1;
    if (item->kind == PGEM_EDGE_ODOMETRY) {
        char why[160] = "";
        unsigned long long from = (unsigned long long)item->from;
        unsigned long long to = (unsigned long long)item->to;
        if (!ids_consecutive(item->from, item->to)) {
            snprintf(why, sizeof why, "poses %llu and %llu are not consecutive ids", from, to);
        } else {
            pgem_id_t low = item->from < item->to ? item->from : item->to;
            slot_t *slot = key_table_find(&ingest->steps, low, 0);
            if (slot->used) {
                snprintf(why, sizeof why,
                         "poses %llu and %llu are already joined by odometry of source '%s'",
                         from, to, ingest->sources[slot->content].name);
            } else {
                key_table_take(slot, low, 0, item->source); /* at most max_poses - 1 steps */
            }
        }
        if (why[0] != '\0') {
            char what[200];
            edge_what(what, sizeof what, item, ingest->sources[item->source].name);
            snprintf(ingest->last_odometry, sizeof ingest->last_odometry,
                     "%s was sent as ODOMETRY but %s: it enters as a loop closure", what, why);
            item->kind = PGEM_EDGE_LOOP;
            ingest->counts.odometry_as_loops++;
        }
    }
    ingest->emit(ingest->user, item);
}

/* Edges in the pending list whose poses are all known now leave it, in arrival order. */
static void release_pending(pgem_ingest_t *ingest)
{
    uint32_t k = ingest->oldest;
    while (k != NONE) {
        uint32_t next = ingest->pending[k].next;
        pgem_item_t *item = &ingest->pending[k].item;
        if (ingest_pose_known(ingest, item->from) && ingest_pose_known(ingest, item->to)) {
            emit_edge(ingest, item);
            pending_remove(ingest, k);
        }
        k = next;
    }
}

/* ---- poses ------------------------------------------------------------------------------- */

static void admit_pose(pgem_ingest_t *ingest, const pgem_item_t *item, const char *what,
                       pgem_ingest_result_t *result)
{
    if (!values_ok(ingest, item->value, what, "estimate", result) ||
        refuse_removed(ingest, item->from, what, result)) {
        return;
    }
    uint64_t content = item_content(item, ingest->config.dimension);
    slot_t *slot = claim(ingest, &ingest->poses, item->from, 0, content, ingest->admitted_poses,
                         ingest->config.max_poses, what,
                         "the pose already exists with another estimate", "poses", result);
    if (slot == NULL || !admitted(ingest, what, result)) {
        return;
    }
    key_table_take(slot, item->from, 0, content);
    ingest->admitted_poses++;
    ingest->counts.accepted_poses++;
    ingest->emit(ingest->user, item);
    release_pending(ingest);
}

/* ---- edges ------------------------------------------------------------------------------- */

/* Other content under a used (source, sequence) is most often a front-end that restarted and
 * numbers from 0 again. Every such edge is refused, so the message says how to resume. */
static void explain_conflict(const pgem_ingest_t *ingest, uint32_t source, const char *what,
                             pgem_ingest_result_t *result)
{
    int64_t last = ingest->sources[source].last;
    if (last == INT64_MAX) { /* nothing is left above it */
        snprintf(result->message, sizeof result->message,
                 "%s: other content under a sequence number this source used (its highest is "
                 "%lld, the largest there is: a restarted front-end must use a new source name)",
                 what, (long long)last);
        return;
    }
    snprintf(result->message, sizeof result->message,
             "%s: other content under a sequence number this source used (its highest is %lld):"
             " a restarted front-end must number on from %lld or use a new source name", what,
             (long long)last, (long long)last + 1);
}

/* The checks of an edge's own values (wire.c's): 1, or 0 with the rejection filled. wire_kind
 * is the int8 of the message (an item holds it as unsigned). */
static int edge_values_ok(pgem_ingest_t *ingest, const pgem_item_t *item, int wire_kind,
                          const char *what, pgem_ingest_result_t *result)
{
    const pgem_reject_t reason =
        pgem_wire_check_edge(ingest->config.dimension, item, wire_kind, what, result->message,
                             sizeof result->message);
    if (reason != PGEM_REJECT_COUNT) {
        reject(ingest, result, reason);
        return 0;
    }
    return 1;
}

static void admit_edge(pgem_ingest_t *ingest, pgem_item_t *item, const char *source,
                       int wire_kind, int64_t utime, pgem_ingest_result_t *result)
{
    char what[200];
    edge_what(what, sizeof what, item, source);
    int index = source_index(ingest, source, result);
    if (index < 0) {
        char why[sizeof result->message];
        memcpy(why, result->message, sizeof why);
        snprintf(result->message, sizeof result->message, "%s: %.180s", what, why);
        reject(ingest, result, PGEM_REJECT_SOURCE);
        return;
    }
    item->source = (uint16_t)index;
    if (!edge_values_ok(ingest, item, wire_kind, what, result)) {
        return;
    }
    item->kind = (uint8_t)wire_kind;
    uint64_t content = item_content(item, ingest->config.dimension);
    slot_t *slot = claim(ingest, &ingest->edges, item->source, (uint64_t)item->sequence, content,
                         ingest->admitted_edges, ingest->config.max_edges, what,
                         "this source already sent this sequence number with other content",
                         "edges", result);
    if (slot == NULL) {
        if (result->verdict == PGEM_VERDICT_REJECTED && result->reason == PGEM_REJECT_CONFLICT) {
            explain_conflict(ingest, item->source, what, result);
        }
        return;
    }
    /* an end on a pose compaction removed goes to its anchor (the key and its content stay
     * the message's: a resend is still a replay) */
    const int moved = ingest_reanchor(ingest, item);
    if (moved && item->from == item->to) {
        snprintf(result->message, sizeof result->message,
                 "%s: its poses were removed from the map and both lie on pose %llu now", what,
                 (unsigned long long)item->from);
        reject(ingest, result, PGEM_REJECT_REMOVED);
        return;
    }
    const int from_lost = ingest_forgotten(ingest, item->from);
    if (from_lost || ingest_forgotten(ingest, item->to)) {
        snprintf(result->message, sizeof result->message,
                 "%s: pose %llu was removed from the map long ago and the bridge no longer "
                 "remembers its anchor (it remembers the last %u removed poses)", what,
                 (unsigned long long)(from_lost ? item->from : item->to),
                 (unsigned)(REMOVED_PER_POSE * ingest->config.max_poses));
        reject(ingest, result, PGEM_REJECT_FORGOTTEN);
        return;
    }
    int ready = ingest_pose_known(ingest, item->from) && ingest_pose_known(ingest, item->to);
    uint32_t victim = NONE;
    if (!ready && ingest->pending_count >= ingest->config.max_pending) {
        victim = pending_victim(ingest, item->source);
        if (victim == NONE) {
            snprintf(result->message, sizeof result->message,
                     "%s: waits for a pose and %u edges already wait, no source holding more of "
                     "them than this one (--max-pending)", what,
                     (unsigned)ingest->config.max_pending);
            reject(ingest, result, PGEM_REJECT_PENDING_FULL);
            return;
        }
    }
    if (!admitted(ingest, what, result)) {
        return;
    }
    if (victim != NONE) {
        char why[200];
        uint32_t holder = ingest->pending[victim].item.source;
        snprintf(why, sizeof why, "the pending list was full (--max-pending %u) and its source "
                 "held the most waiting edges (%u): room for a source with fewer",
                 (unsigned)ingest->config.max_pending,
                 (unsigned)ingest->sources[holder].waiting);
        pending_expire(ingest, victim, why);
        /* the expiry may have freed a source slot and moved keys: look both up again */
        item->source = (uint16_t)source_index(ingest, source, result);
        slot = key_table_find(&ingest->edges, item->source, (uint64_t)item->sequence);
    }
    key_table_take(slot, item->source, (uint64_t)item->sequence, content);
    source_admit(ingest, item->source, source, item->sequence);
    ingest->admitted_edges++;
    ingest->counts.accepted_edges++;
    if (moved) {
        ingest_reanchored_goes_in(ingest, item);
    }
    if (ready) {
        emit_edge(ingest, item);
    } else {
        pending_add(ingest, item, utime);
        result->pending = 1;
    }
}

static void reset(pgem_ingest_t *ingest)
{
    key_table_clear(&ingest->poses);
    key_table_clear(&ingest->edges);
    key_table_clear(&ingest->steps);
    ingest_removed_clear(ingest);
    pending_clear(ingest);
    ingest->admitted_poses = 0;
    ingest->admitted_edges = 0;
    ingest->full_poses = 0;
    ingest->full_edges = 0;
    for (uint32_t i = ingest->source_count; i-- > 0;) {
        ingest->sources[i].last = -1;
        source_release(ingest, i); /* one that only ever had waiting edges */
    }
    pgem_item_t item;
    memset(&item, 0, sizeof item);
    item.type = PGEM_ITEM_RESET;
    ingest->emit(ingest->user, &item);
}

/* SNAPSHOT's file name: allowed at all, and a plain name. 1, or 0 with the rejection filled. */
static int snapshot_ok(pgem_ingest_t *ingest, const char *name, pgem_ingest_result_t *result)
{
    char shown[128];
    if (!ingest->config.snapshots) {
        snprintf(result->message, sizeof result->message,
                 "SNAPSHOT is off: start the bridge with --snapshot-dir DIR to have it write "
                 "snapshots there");
    } else if (!pgem_snapshot_name_ok(name)) {
        snprintf(result->message, sizeof result->message,
                 "SNAPSHOT takes a file name of 1 to %d bytes of A-Z a-z 0-9 . _ - (not "
                 "starting with '.'), written in the bridge's --snapshot-dir; got '%s'",
                 PGEM_SNAPSHOT_NAME_MAX, pgem_utf8_escape(shown, sizeof shown, name));
    } else if (ingest->snapshot_check == NULL ||
               ingest->snapshot_check(ingest->snapshot_user, name, result->message,
                                      sizeof result->message) == 0) {
        return 1;
    }
    reject(ingest, result, PGEM_REJECT_COMMAND);
    return 0;
}

/* ---- the message ------------------------------------------------------------------------- */

static void handle_command(pgem_ingest_t *ingest, const pgem_wire_message_t *command,
                           pgem_ingest_result_t *result)
{
    ingest->counts.commands++;
    result->command = command->command;
    const char *path = command->path;
    if (command->command == PGEM_COMMAND_T_SNAPSHOT) {
        if (snapshot_ok(ingest, path, result)) {
            result->verdict = PGEM_VERDICT_COMMAND;
            memcpy(result->path, path, strlen(path) + 1);
        }
    } else if (command->command == PGEM_COMMAND_T_RESET) {
        if (admitted(ingest, "RESET", result)) {
            result->verdict = PGEM_VERDICT_COMMAND;
            reset(ingest);
        }
    } else if (command->command == PGEM_COMMAND_T_OPTIMIZE) {
        result->verdict = PGEM_VERDICT_COMMAND;
    } else {
        snprintf(result->message, sizeof result->message,
                 "unknown command %d (OPTIMIZE 1, RESET 2, SNAPSHOT 3)", command->command);
        reject(ingest, result, PGEM_REJECT_COMMAND);
    }
}

void pgem_ingest_message(pgem_ingest_t *ingest, pgem_role_t role, const void *data, size_t size,
                         int64_t utime, pgem_ingest_result_t *result)
{
    memset(result, 0, sizeof *result);
    pgem_ingest_expire(ingest, utime);
    if (role == PGEM_ROLE_ANY) {
        role = pgem_wire_role(data, size);
        if (role == PGEM_ROLE_ANY) {
            result->verdict = PGEM_VERDICT_IGNORED;
            return;
        }
    }
    if (role != PGEM_ROLE_COMMAND) {
        ingest->counts.received++;
    }
    const int dimension = ingest->config.dimension;
    pgem_wire_message_t message;
    pgem_reject_t reason = PGEM_REJECT_DECODE;
    if (!pgem_wire_decode(dimension, role, data, size, &message, &reason, result->message,
                          sizeof result->message)) {
        reject(ingest, result, reason);
        return;
    }
    ingest->data = data;
    ingest->size = size;
    if (role == PGEM_ROLE_COMMAND) {
        handle_command(ingest, &message, result);
    } else if (role == PGEM_ROLE_POSE) {
        char what[64];
        snprintf(what, sizeof what, "%dD pose %llu", dimension,
                 (unsigned long long)message.item.from);
        admit_pose(ingest, &message.item, what, result);
    } else {
        admit_edge(ingest, &message.item, message.source, message.wire_kind, utime, result);
    }
    pgem_wire_release(&message);
    ingest->data = NULL;
    ingest->size = 0;
}
