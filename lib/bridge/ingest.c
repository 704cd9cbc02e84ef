/* Reception state machine: decode, validate, deduplicate, hold edges for missing poses, emit. */
#include "ingest.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pgem_command_t.h"
#include "pgem_edge2_t.h"
#include "pgem_edge3_t.h"
#include "pgem_pose2_t.h"
#include "pgem_pose3_t.h"

#define DEFAULT_MAX_PENDING 4096u
#define DEFAULT_MAX_SOURCES 64u

static const char *const reject_names[PGEM_REJECT_COUNT] = {
    "decode", "dimension", "not_finite", "information", "rotation", "self_loop", "kind",
    "source", "conflict", "capacity", "pending_full", "command", "core"};

const char *pgem_reject_name(pgem_reject_t reason)
{
    return (unsigned)reason < PGEM_REJECT_COUNT ? reject_names[reason] : "unknown";
}

/* Open-addressing tables keyed by a 64-bit pair; `used` marks live slots. */
typedef struct slot {
    uint64_t key_a;
    uint64_t key_b;
    uint64_t content;
    uint8_t used;
} slot_t;

typedef struct table {
    slot_t *slots;
    size_t mask;
} table_t;

struct pgem_ingest {
    pgem_ingest_config_t config;
    pgem_emit_fn emit;
    void *user;
    table_t poses;            /* key (id, 0) */
    table_t edges;            /* key (source, sequence) */
    pgem_item_t *pending;     /* edges waiting for poses, in arrival order */
    uint32_t pending_count;
    uint32_t admitted_poses;  /* capacity reserved since the last reset */
    uint32_t admitted_edges;  /* includes pending edges */
    char (*sources)[PGEM_SOURCE_MAX];
    int64_t *source_last;     /* per source: highest sequence admitted since the last reset,
                                 -1 none (named in conflict messages) */
    uint32_t source_count;
    pgem_ingest_counts_t counts;
};

static int table_init(table_t *table, uint32_t capacity)
{
    size_t size = 16;
    while (size < 2 * (size_t)capacity) {
        size *= 2;
    }
    table->slots = calloc(size, sizeof *table->slots);
    table->mask = size - 1;
    return table->slots != NULL;
}

static void table_clear(table_t *table)
{
    memset(table->slots, 0, (table->mask + 1) * sizeof *table->slots);
}

static uint64_t mix(uint64_t a, uint64_t b)
{
    uint64_t h = a * 0x9E3779B97F4A7C15ull ^ (b + 0xBF58476D1CE4E5B9ull + (a << 6) + (a >> 2));
    h ^= h >> 31;
    h *= 0x94D049BB133111EBull;
    return h ^ (h >> 29);
}

/* The slot holding the key, or the empty slot where it would go. Never full: capacity is
 * reserved before insertion and the table has twice the slots. */
static slot_t *table_find(const table_t *table, uint64_t a, uint64_t b)
{
    size_t index = (size_t)mix(a, b) & table->mask;
    for (;;) {
        slot_t *slot = &table->slots[index];
        if (!slot->used || (slot->key_a == a && slot->key_b == b)) {
            return slot;
        }
        index = (index + 1) & table->mask;
    }
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
    ingest->sources = calloc(ingest->config.max_sources, sizeof *ingest->sources);
    ingest->source_last = calloc(ingest->config.max_sources, sizeof *ingest->source_last);
    if (!table_init(&ingest->poses, config->max_poses) ||
        !table_init(&ingest->edges, config->max_edges) || ingest->pending == NULL ||
        ingest->sources == NULL || ingest->source_last == NULL) {
        pgem_ingest_destroy(ingest);
        return NULL;
    }
    return ingest;
}

void pgem_ingest_destroy(pgem_ingest_t *ingest)
{
    if (ingest != NULL) {
        free(ingest->poses.slots);
        free(ingest->edges.slots);
        free(ingest->pending);
        free(ingest->sources);
        free(ingest->source_last);
        free(ingest);
    }
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
    return index < ingest->source_count ? ingest->sources[index] : "";
}

void pgem_upper_to_full(const double *upper, int n, double *full)
{
    int k = 0;
    for (int i = 0; i < n; ++i) {
        for (int j = i; j < n; ++j) {
            full[i * n + j] = upper[k];
            full[j * n + i] = upper[k];
            ++k;
        }
    }
}

static void reject(pgem_ingest_t *ingest, pgem_ingest_result_t *result, pgem_reject_t reason)
{
    result->verdict = PGEM_VERDICT_REJECTED;
    result->reason = reason;
    ingest->counts.rejected[reason]++;
}

/* ---- checks shared by poses and edges ---------------------------------------------------- */

/* The index of the first value that is NaN or Inf, or -1. */
static int first_not_finite(const double *values, int count)
{
    for (int i = 0; i < count; ++i) {
        if (!isfinite(values[i])) {
            return i;
        }
    }
    return -1;
}

static const char *const value_names_2d[] = {"x", "y", "theta"};
static const char *const value_names_3d[] = {"x", "y", "z", "qx", "qy", "qz", "qw"};

static int quaternion_ok(const double *pose7)
{
    const double *q = pose7 + 3;
    double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    return fabs(norm - 1.0) <= PGEM_QUAT_NORM_TOLERANCE;
}

/* The index of a source name: a known source's, or for a new one the index it will take if
 * its edge is admitted (a rejected message must not use up the source table). -1 (result
 * filled) when the name is refused or the table is full. */
static int source_index(pgem_ingest_t *ingest, const char *name, pgem_ingest_result_t *result)
{
    size_t length = name != NULL ? strlen(name) : 0;
    if (length == 0 || length >= PGEM_SOURCE_MAX) {
        snprintf(result->message, sizeof result->message,
                 "source name must have 1 to %d bytes, got %zu", PGEM_SOURCE_MAX - 1, length);
        return -1;
    }
    for (uint32_t i = 0; i < ingest->source_count; ++i) {
        if (strcmp(ingest->sources[i], name) == 0) {
            return (int)i;
        }
    }
    if (ingest->source_count == ingest->config.max_sources) {
        snprintf(result->message, sizeof result->message,
                 "source '%s' is new and the bridge already has %u sources (--max-sources)",
                 name, (unsigned)ingest->config.max_sources);
        return -1;
    }
    return (int)ingest->source_count;
}

/* Admits an edge's source: a new name takes the index source_index gave it. */
static void source_admit(pgem_ingest_t *ingest, uint32_t index, const char *name,
                         int64_t sequence)
{
    if (index == ingest->source_count && name != NULL) { /* source_index refused NULL */
        memcpy(ingest->sources[index], name, strlen(name) + 1);
        ingest->source_last[index] = -1;
        ingest->source_count++;
    }
    if (sequence > ingest->source_last[index]) {
        ingest->source_last[index] = sequence;
    }
}

/* A pose estimate or a measurement: finite, and in 3D a unit quaternion. Returns 1, or 0 with
 * the message and the rejection filled. */
static int values_ok(pgem_ingest_t *ingest, const double *values, const char *what,
                     const char *noun, pgem_ingest_result_t *result)
{
    int dimension = ingest->config.dimension;
    int bad = first_not_finite(values, PGEM_POSE_SIZE(dimension));
    if (bad >= 0) {
        snprintf(result->message, sizeof result->message, "%s: NaN or Inf in the %s (field %s)",
                 what, noun, dimension == 3 ? value_names_3d[bad] : value_names_2d[bad]);
        reject(ingest, result, PGEM_REJECT_NOT_FINITE);
        return 0;
    }
    if (dimension == 3 && !quaternion_ok(values)) {
        snprintf(result->message, sizeof result->message,
                 "%s: quaternion norm off 1 by more than %g", what, PGEM_QUAT_NORM_TOLERANCE);
        reject(ingest, result, PGEM_REJECT_ROTATION);
        return 0;
    }
    return 1;
}

/* The slot a new key (a, b) with this content will take. A replay (same key, same content), a
 * conflict (same key, other content) or a full capacity (admitted == limit) ends here: NULL,
 * with the result filled. */
static slot_t *claim(pgem_ingest_t *ingest, table_t *table, uint64_t a, uint64_t b,
                     uint64_t content, uint32_t admitted, uint32_t limit, const char *what,
                     const char *conflict, const char *items, pgem_ingest_result_t *result)
{
    slot_t *slot = table_find(table, a, b);
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
    if (admitted >= limit) {
        snprintf(result->message, sizeof result->message,
                 "%s: the bridge holds its maximum of %u %s (--max-%s)", what, (unsigned)limit,
                 items, items);
        reject(ingest, result, PGEM_REJECT_CAPACITY);
        return NULL;
    }
    return slot;
}

static void take(slot_t *slot, uint64_t a, uint64_t b, uint64_t content)
{
    slot->used = 1;
    slot->key_a = a;
    slot->key_b = b;
    slot->content = content;
}

static int pose_known(const pgem_ingest_t *ingest, pgem_id_t id)
{
    return table_find(&ingest->poses, id, 0)->used;
}

/* ---- poses ------------------------------------------------------------------------------- */

/* Edges in the pending list whose poses are all known now leave it, in arrival order. */
static void release_pending(pgem_ingest_t *ingest)
{
    uint32_t kept = 0;
    for (uint32_t i = 0; i < ingest->pending_count; ++i) {
        pgem_item_t *item = &ingest->pending[i];
        if (pose_known(ingest, item->from) && pose_known(ingest, item->to)) {
            ingest->emit(ingest->user, item);
        } else {
            ingest->pending[kept++] = *item;
        }
    }
    ingest->pending_count = kept;
}

static void admit_pose(pgem_ingest_t *ingest, const pgem_item_t *item, const char *what,
                       pgem_ingest_result_t *result)
{
    if (!values_ok(ingest, item->value, what, "estimate", result)) {
        return;
    }
    uint64_t content = item_content(item, ingest->config.dimension);
    slot_t *slot = claim(ingest, &ingest->poses, item->from, 0, content, ingest->admitted_poses,
                         ingest->config.max_poses, what,
                         "the pose already exists with another estimate", "poses", result);
    if (slot == NULL) {
        return;
    }
    take(slot, item->from, 0, content);
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
    long long last = (long long)ingest->source_last[source];
    snprintf(result->message, sizeof result->message,
             "%s: other content under a sequence number this source used (its highest is %lld):"
             " a restarted front-end must number on from %lld or use a new source name", what,
             last, last + 1);
}

static void admit_edge(pgem_ingest_t *ingest, pgem_item_t *item, const char *source,
                       pgem_ingest_result_t *result)
{
    int dimension = ingest->config.dimension;
    int n = PGEM_TANGENT_SIZE(dimension);
    char what[200];
    snprintf(what, sizeof what, "edge %llu -> %llu (source '%.63s', sequence %lld)",
             (unsigned long long)item->from, (unsigned long long)item->to,
             source != NULL ? source : "", (long long)item->sequence);
    int index = source_index(ingest, source, result);
    if (index < 0) {
        reject(ingest, result, PGEM_REJECT_SOURCE);
        return;
    }
    item->source = (uint16_t)index;
    if (item->from == item->to) {
        snprintf(result->message, sizeof result->message, "%s: a self-loop", what);
        reject(ingest, result, PGEM_REJECT_SELF_LOOP);
        return;
    }
    if (item->kind != PGEM_EDGE_ODOMETRY && item->kind != PGEM_EDGE_LOOP) {
        snprintf(result->message, sizeof result->message,
                 "%s: kind %d is neither ODOMETRY (0) nor LOOP (1)", what, (int)item->kind);
        reject(ingest, result, PGEM_REJECT_KIND);
        return;
    }
    if (!values_ok(ingest, item->value, what, "measurement", result)) {
        return;
    }
    double full[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    pgem_upper_to_full(item->information, n, full);
    int entry = 0;
    int check = pgem_information_check(full, n, &entry);
    if (check != PGEM_OK) {
        int not_finite = check == PGEM_ERR_NOT_FINITE;
        snprintf(result->message, sizeof result->message, "%s: information %s (entry %d,%d)",
                 what, not_finite ? "has NaN or Inf" : "is not positive definite", entry / n,
                 entry % n);
        reject(ingest, result, not_finite ? PGEM_REJECT_NOT_FINITE : PGEM_REJECT_INFORMATION);
        return;
    }
    uint64_t content = item_content(item, dimension);
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
    int ready = pose_known(ingest, item->from) && pose_known(ingest, item->to);
    if (!ready && ingest->pending_count >= ingest->config.max_pending) {
        snprintf(result->message, sizeof result->message,
                 "%s: waits for a pose and %u edges already wait (--max-pending)", what,
                 (unsigned)ingest->config.max_pending);
        reject(ingest, result, PGEM_REJECT_PENDING_FULL);
        return;
    }
    take(slot, item->source, (uint64_t)item->sequence, content);
    source_admit(ingest, item->source, source, item->sequence);
    ingest->admitted_edges++;
    ingest->counts.accepted_edges++;
    if (ready) {
        ingest->emit(ingest->user, item);
    } else {
        ingest->pending[ingest->pending_count++] = *item;
        result->pending = 1;
    }
}

/* ---- decoding ---------------------------------------------------------------------------- */

static int64_t fingerprint(const void *data, size_t size)
{
    if (size < 8) {
        return 0;
    }
    const unsigned char *b = data;
    uint64_t value = 0;
    for (int i = 0; i < 8; ++i) {
        value = value << 8 | b[i];
    }
    return (int64_t)value;
}

/* lcm-gen's decoders trust a string's length field (they malloc it and never check the
 * terminating NUL), so every message is first checked against its exact layout: the type's
 * fingerprint, one string at string_offset (length 1 .. 64 KiB including a NUL that is its
 * only zero byte) and `tail` bytes after it, nothing more or less. */
static int wire_ok(const void *data, size_t size, int64_t type, size_t string_offset,
                   size_t tail)
{
    const unsigned char *bytes = data;
    if (fingerprint(data, size) != type || size < string_offset + 4) {
        return 0;
    }
    const unsigned char *p = bytes + string_offset;
    uint32_t length = (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
    if (length == 0 || length > 65536 || size != string_offset + 4 + length + tail) {
        return 0;
    }
    const unsigned char *text = p + 4;
    return text[length - 1] == 0 && memchr(text, 0, length - 1) == NULL;
}

/* Byte sizes of the fields after the string in each input type (see types/ *.lcm). */
#define POSE2_TAIL (8 + 3 * 8 + 1)
#define POSE3_TAIL (8 + 7 * 8 + 1)
#define EDGE2_TAIL (3 * 8 + 3 * 8 + 6 * 8 + 1)
#define EDGE3_TAIL (3 * 8 + 7 * 8 + 21 * 8 + 1)
#define STRING_AFTER_UTIME 16  /* fingerprint, utime */
#define COMMAND_STRING 17      /* fingerprint, utime, command */

#define DECODE(type, data, size, offset, tail, msg)                                  \
    (wire_ok(data, size, __##type##_get_hash(), offset, tail) &&                      \
     type##_decode(data, 0, (int)(size), msg) == (int)(size))

static void reset(pgem_ingest_t *ingest)
{
    table_clear(&ingest->poses);
    table_clear(&ingest->edges);
    ingest->pending_count = 0;
    ingest->admitted_poses = 0;
    ingest->admitted_edges = 0;
    for (uint32_t i = 0; i < ingest->source_count; ++i) {
        ingest->source_last[i] = -1;
    }
    pgem_item_t item;
    memset(&item, 0, sizeof item);
    item.type = PGEM_ITEM_RESET;
    ingest->emit(ingest->user, &item);
}

static void handle_command(pgem_ingest_t *ingest, const void *data, size_t size,
                           pgem_ingest_result_t *result)
{
    pgem_command_t command;
    if (!DECODE(pgem_command_t, data, size, COMMAND_STRING, 0, &command)) {
        snprintf(result->message, sizeof result->message,
                 "a %zu-byte message on the command channel is not a pgem.command_t", size);
        reject(ingest, result, PGEM_REJECT_DECODE);
        return;
    }
    ingest->counts.commands++;
    result->command = (int)command.command; /* a signed 8-bit code on the wire */
    size_t length = command.path != NULL ? strlen(command.path) : 0;
    if (command.command == PGEM_COMMAND_T_SNAPSHOT && (length == 0 || length >= PGEM_PATH_MAX)) {
        snprintf(result->message, sizeof result->message,
                 "SNAPSHOT needs a path of 1 to %d bytes, got %zu", PGEM_PATH_MAX - 1, length);
        reject(ingest, result, PGEM_REJECT_COMMAND);
    } else if (command.command == PGEM_COMMAND_T_OPTIMIZE ||
               command.command == PGEM_COMMAND_T_SNAPSHOT ||
               command.command == PGEM_COMMAND_T_RESET) {
        result->verdict = PGEM_VERDICT_COMMAND;
        if (length > 0 && length < PGEM_PATH_MAX) {
            memcpy(result->path, command.path, length + 1);
        }
        if (command.command == PGEM_COMMAND_T_RESET) {
            reset(ingest);
        }
    } else {
        snprintf(result->message, sizeof result->message,
                 "unknown command %d (OPTIMIZE 1, RESET 2, SNAPSHOT 3)", (int)command.command);
        reject(ingest, result, PGEM_REJECT_COMMAND);
    }
    pgem_command_t_decode_cleanup(&command);
}

/* A message on the pose or edge channel that did not decode: of the other dimension, or not
 * the channel's type at all. */
static void reject_undecoded(pgem_ingest_t *ingest, const void *data, size_t size,
                             int64_t other_dimension, const char *noun,
                             pgem_ingest_result_t *result)
{
    int dimension = ingest->config.dimension;
    if (fingerprint(data, size) == other_dimension) {
        snprintf(result->message, sizeof result->message, "a %dD %s reached a %dD bridge",
                 5 - dimension, noun, dimension);
        reject(ingest, result, PGEM_REJECT_DIMENSION);
    } else {
        snprintf(result->message, sizeof result->message,
                 "a %zu-byte message on the %s channel is not a pgem.%s%d_t", size, noun, noun,
                 dimension);
        reject(ingest, result, PGEM_REJECT_DECODE);
    }
}

/* The fields an edge2_t and an edge3_t share, into an item. */
#define EDGE_INTO_ITEM(edge, item)                                              \
    do {                                                                        \
        (item).from = (pgem_id_t)(edge).from;                                   \
        (item).to = (pgem_id_t)(edge).to;                                       \
        (item).sequence = (edge).sequence;                                      \
        (item).kind = (uint8_t)(edge).kind;                                     \
        memcpy((item).value, (edge).measurement, sizeof (edge).measurement);    \
        memcpy((item).information, (edge).information, sizeof (edge).information); \
    } while (0)

static void pose_what(char *what, size_t size, pgem_id_t id, int dimension)
{
    snprintf(what, size, "%dD pose %llu", dimension, (unsigned long long)id);
}

static void handle_pose(pgem_ingest_t *ingest, const void *data, size_t size,
                        pgem_ingest_result_t *result)
{
    pgem_item_t item;
    memset(&item, 0, sizeof item);
    item.type = PGEM_ITEM_POSE;
    char what[64];
    if (ingest->config.dimension == 2) {
        pgem_pose2_t pose;
        if (DECODE(pgem_pose2_t, data, size, STRING_AFTER_UTIME, POSE2_TAIL, &pose)) {
            item.from = (pgem_id_t)pose.id;
            item.kind = pose.fixed ? 1 : 0;
            memcpy(item.value, pose.pose, sizeof pose.pose);
            pgem_pose2_t_decode_cleanup(&pose);
            pose_what(what, sizeof what, item.from, 2);
            admit_pose(ingest, &item, what, result);
            return;
        }
    } else {
        pgem_pose3_t pose;
        if (DECODE(pgem_pose3_t, data, size, STRING_AFTER_UTIME, POSE3_TAIL, &pose)) {
            item.from = (pgem_id_t)pose.id;
            item.kind = pose.fixed ? 1 : 0;
            memcpy(item.value, pose.pose, sizeof pose.pose);
            pgem_pose3_t_decode_cleanup(&pose);
            pose_what(what, sizeof what, item.from, 3);
            admit_pose(ingest, &item, what, result);
            return;
        }
    }
    reject_undecoded(ingest, data, size,
                     ingest->config.dimension == 2 ? __pgem_pose3_t_get_hash()
                                                   : __pgem_pose2_t_get_hash(),
                     "pose", result);
}

static void handle_edge(pgem_ingest_t *ingest, const void *data, size_t size,
                        pgem_ingest_result_t *result)
{
    pgem_item_t item;
    memset(&item, 0, sizeof item);
    item.type = PGEM_ITEM_EDGE;
    if (ingest->config.dimension == 2) {
        pgem_edge2_t edge;
        if (DECODE(pgem_edge2_t, data, size, STRING_AFTER_UTIME, EDGE2_TAIL, &edge)) {
            EDGE_INTO_ITEM(edge, item);
            admit_edge(ingest, &item, edge.source, result);
            pgem_edge2_t_decode_cleanup(&edge);
            return;
        }
    } else {
        pgem_edge3_t edge;
        if (DECODE(pgem_edge3_t, data, size, STRING_AFTER_UTIME, EDGE3_TAIL, &edge)) {
            EDGE_INTO_ITEM(edge, item);
            admit_edge(ingest, &item, edge.source, result);
            pgem_edge3_t_decode_cleanup(&edge);
            return;
        }
    }
    reject_undecoded(ingest, data, size,
                     ingest->config.dimension == 2 ? __pgem_edge3_t_get_hash()
                                                   : __pgem_edge2_t_get_hash(),
                     "edge", result);
}

static pgem_role_t role_of(const void *data, size_t size)
{
    int64_t type = fingerprint(data, size);
    if (type == __pgem_pose2_t_get_hash() || type == __pgem_pose3_t_get_hash()) {
        return PGEM_ROLE_POSE;
    }
    if (type == __pgem_edge2_t_get_hash() || type == __pgem_edge3_t_get_hash()) {
        return PGEM_ROLE_EDGE;
    }
    if (type == __pgem_command_t_get_hash()) {
        return PGEM_ROLE_COMMAND;
    }
    return PGEM_ROLE_ANY;
}

void pgem_ingest_message(pgem_ingest_t *ingest, pgem_role_t role, const void *data, size_t size,
                         pgem_ingest_result_t *result)
{
    memset(result, 0, sizeof *result);
    if (role == PGEM_ROLE_ANY) {
        role = role_of(data, size);
        if (role == PGEM_ROLE_ANY) {
            result->verdict = PGEM_VERDICT_IGNORED;
            return;
        }
    }
    if (role == PGEM_ROLE_COMMAND) {
        handle_command(ingest, data, size, result);
        return;
    }
    ingest->counts.received++;
    if (role == PGEM_ROLE_POSE) {
        handle_pose(ingest, data, size, result);
    } else {
        handle_edge(ingest, data, size, result);
    }
}
