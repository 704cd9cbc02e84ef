/* The bridge's reception side, as a deterministic state machine with no LCM runtime, threads,
 * clocks or I/O: raw message bytes in, verdicts and graph items out.
 *
 * Every message is decoded and checked before anything changes (finite numbers within the
 * core's magnitude limits, information positive definite, unit quaternion, not a self-loop,
 * known kind, the bridge's dimension, a source name of printable UTF-8). Poses are keyed by id
 * and edges by (source, sequence): an exact repeat is a replay and is ignored; the same key
 * with other content is a conflict and is rejected. An edge whose poses have not arrived waits
 * in a bounded pending list and is released, in arrival order, when they have; one that waits
 * longer than the pending timeout expires (counted, named, its key and capacity freed), and a
 * full list makes room by expiring the oldest edge of the source that holds the most, so no
 * sender can keep the list for itself. A source that never had an edge in the graph leaves
 * the source table when its last waiting edge expires. Capacity is reserved when a message is
 * admitted, so an admitted item always fits the core. A message that would change the state
 * is first offered to the admit hook (the bridge's journal): a refusal there changes nothing.
 * An edge sent as ODOMETRY leaves as one only when it is a step of the chain (pose ids one
 * apart, not yet joined by odometry in the graph); otherwise as a loop closure, counted and
 * named (pgem_ingest_last_odometry_note): the wire's kind is a claim, the robust layer's is
 * the bridge's decision (docs/BRIDGE.md, "What a front-end may claim").
 * Admitted items leave through the emit callback in the order the solver must add them;
 * feeding the same accepted messages in the same order with the same times (the journal)
 * rebuilds exactly the same sequence of items. All memory is allocated once, in
 * pgem_ingest_create. */
#ifndef PGEM_BRIDGE_INGEST_H
#define PGEM_BRIDGE_INGEST_H

#include <stddef.h>
#include <stdint.h>

#include "pgem/graph.h"

/* Why a message was rejected. The names (pgem_reject_name) appear in status_t. */
typedef enum pgem_reject {
    PGEM_REJECT_DECODE = 0,    /* not the channel's message type, or truncated/garbled */
    PGEM_REJECT_DIMENSION,     /* a 2D message to a 3D bridge, or the reverse */
    PGEM_REJECT_NOT_FINITE,    /* NaN or Inf in a pose, measurement or information */
    PGEM_REJECT_INFORMATION,   /* information matrix not positive definite */
    PGEM_REJECT_ROTATION,      /* quaternion norm off 1 by more than 1% */
    PGEM_REJECT_SELF_LOOP,     /* from == to */
    PGEM_REJECT_KIND,          /* kind neither ODOMETRY nor LOOP */
    PGEM_REJECT_SOURCE,        /* source name empty, too long or not printable UTF-8, or too
                                  many sources */
    PGEM_REJECT_CONFLICT,      /* pose id or (source, sequence) seen with other content */
    PGEM_REJECT_CAPACITY,      /* pose or edge capacity of the bridge reached */
    PGEM_REJECT_PENDING_FULL,  /* the edge waits for a pose and the pending list is full */
    PGEM_REJECT_COMMAND,       /* unknown command; SNAPSHOT off, or not a plain file name */
    PGEM_REJECT_CORE,          /* the core refused an admitted item (a bug if ever seen) */
    PGEM_REJECT_RANGE,         /* a translation or information entry beyond the core's limits
                                  (PGEM_TRANSLATION_LIMIT, PGEM_INFORMATION_LIMIT) */
    PGEM_REJECT_JOURNAL,       /* the admit hook refused it (the journal could not write it) */
    PGEM_REJECT_REMOVED,       /* names a pose compaction removed from the map (a pose id is
                                  never used again) */
    PGEM_REJECT_EXPIRED,       /* an accepted edge that waited past the pending timeout for
                                  its poses, or made room in a full pending list: it left the
                                  accepted count for this one */
    PGEM_REJECT_FULL,          /* with compaction: the block is full and compaction can free
                                  nothing (every pose held, among the newest, or joined by
                                  other than two odometry edges) */
    PGEM_REJECT_FORGOTTEN,     /* names a pose compaction removed so long ago that its anchor
                                  is forgotten (beyond 4 x max_poses removed poses) */
    PGEM_REJECT_COUNT
} pgem_reject_t;

const char *pgem_reject_name(pgem_reject_t reason);

/* What a message is expected to be (the channel it came on). ANY dispatches by the LCM type
 * fingerprint, for replaying a journal. */
typedef enum pgem_role {
    PGEM_ROLE_POSE = 0,
    PGEM_ROLE_EDGE = 1,
    PGEM_ROLE_COMMAND = 2,
    PGEM_ROLE_ANY = 3
} pgem_role_t;

/* One unit of work for the solver, in order. */
typedef enum pgem_item_type {
    PGEM_ITEM_POSE = 0,
    PGEM_ITEM_EDGE = 1,
    PGEM_ITEM_RESET = 2     /* forget the graph */
} pgem_item_type_t;

#define PGEM_SOURCE_MAX 64  /* bytes of a source name, NUL included */
#define PGEM_INFO_UPPER_MAX 21

typedef struct pgem_item {
    uint8_t type;            /* pgem_item_type_t */
    uint8_t kind;            /* edges: pgem_edge_kind_t; poses: fixed flag */
    uint16_t source;         /* index into the source table */
    int64_t sequence;        /* edges: the front-end's sequence number */
    pgem_id_t from;          /* poses: the id */
    pgem_id_t to;
    double value[PGEM_POSE_SIZE_MAX];          /* pose estimate or measurement */
    double information[PGEM_INFO_UPPER_MAX];   /* upper triangle, row by row */
} pgem_item_t;

/* What happened to one message. */
typedef enum pgem_verdict {
    PGEM_VERDICT_ACCEPTED = 0,  /* admitted: items emitted (or, an edge, pending) */
    PGEM_VERDICT_REPLAY = 1,    /* an exact repeat of an admitted message: ignored */
    PGEM_VERDICT_REJECTED = 2,  /* see reason and message */
    PGEM_VERDICT_COMMAND = 3,   /* a command for the bridge (command, path); RESET is already
                                   applied here and emitted */
    PGEM_VERDICT_IGNORED = 4    /* ROLE_ANY only: a message of another type (a graph or status
                                   in a recorded log, say), passed over and not counted */
} pgem_verdict_t;

#define PGEM_PATH_MAX 1024
#define PGEM_SNAPSHOT_NAME_MAX 200 /* bytes of a SNAPSHOT file name (room for .weights) */

typedef struct pgem_ingest_result {
    pgem_verdict_t verdict;
    pgem_reject_t reason;      /* when rejected */
    int pending;               /* accepted edge that waits for a pose */
    int command;               /* when a command: pgem_command_t's constant */
    char path[PGEM_PATH_MAX];  /* SNAPSHOT file name (checked: see pgem_snapshot_name_ok) */
    char message[384];         /* rejected: what was wrong, naming ids, source and sequence */
} pgem_ingest_result_t;

typedef void (*pgem_emit_fn)(void *user, const pgem_item_t *item);

/* Offered every message that would change the state (an accepted pose or edge, a RESET), with
 * its bytes, before anything changes: 0 lets it in; anything else refuses it with reason
 * `journal` and the message the hook wrote, and nothing changes (its key stays free, so a
 * resend can be accepted). */
typedef int (*pgem_admit_fn)(void *user, const void *data, size_t size, char *message,
                             size_t message_size);

#define PGEM_PENDING_TIMEOUT_DEFAULT INT64_C(60000000) /* us an edge may wait: one minute */

typedef struct pgem_ingest_config {
    int dimension;           /* 2 or 3 */
    uint32_t max_poses;      /* as the core's config */
    uint32_t max_edges;
    uint32_t max_pending;    /* edges allowed to wait for poses; 0 means 4096 */
    uint32_t max_sources;    /* front-ends; 0 means 64 */
    int64_t pending_timeout; /* microseconds an edge may wait for its poses; 0 means
                                PGEM_PENDING_TIMEOUT_DEFAULT */
    int snapshots;           /* SNAPSHOT commands allowed (the bridge has a snapshot folder) */
    int compact;             /* the graph is compacted: max_poses and max_edges include what
                                waits for the solver beyond the block (messages say so) */
} pgem_ingest_config_t;

/* Counters (status_t's fields). */
typedef struct pgem_ingest_counts {
    int64_t received;          /* pose and edge messages */
    int64_t accepted_poses;
    int64_t accepted_edges;    /* admitted, less those that expired since (so received is
                                  always accepted + replays + rejected) */
    int64_t replays;
    int64_t commands;
    int64_t rejected[PGEM_REJECT_COUNT];
    uint32_t pending;          /* edges waiting now */
    int64_t odometry_as_loops; /* edges sent as ODOMETRY that are not a step of the chain
                                  (pgem_ingest_last_odometry_note): they entered as loop
                                  closures (counted among accepted_edges too) */
} pgem_ingest_counts_t;

typedef struct pgem_ingest pgem_ingest_t;

/* Fills the defaults of max_pending, max_sources and pending_timeout (0 means 4096, 64 and one
 * minute) and caps max_sources at 65535 (an item carries a 16-bit source index). */
void pgem_ingest_config_resolve(pgem_ingest_config_t *config);

/* NULL when out of memory or the config is invalid. */
pgem_ingest_t *pgem_ingest_create(const pgem_ingest_config_t *config, pgem_emit_fn emit,
                                  void *user);
void pgem_ingest_destroy(pgem_ingest_t *ingest);

/* The admit hook (NULL: everything that passes the checks is admitted). */
void pgem_ingest_set_admit(pgem_ingest_t *ingest, pgem_admit_fn admit, void *user);

/* Offered the file name of every SNAPSHOT that passes the ingest's own checks: 0 lets it
 * through; anything else rejects it (reason `command`) with the message the hook wrote (the
 * bridge refuses a name that is its journal). */
typedef int (*pgem_snapshot_check_fn)(void *user, const char *name, char *message,
                                      size_t message_size);

/* The SNAPSHOT hook (NULL: every plain name passes). */
void pgem_ingest_set_snapshot_check(pgem_ingest_t *ingest, pgem_snapshot_check_fn check,
                                    void *user);

/* Handles one message that arrived at `utime` (microseconds; LCM's receive time, or a journal
 * record's): first expires the edges that have waited longer than the pending timeout by then.
 * Never fails as a call: every outcome is in *result. */
void pgem_ingest_message(pgem_ingest_t *ingest, pgem_role_t role, const void *data, size_t size,
                         int64_t utime, pgem_ingest_result_t *result);

/* Expires what has waited too long by `utime` without a message (a quiet bridge still lets
 * them go). Returns how many expired. */
/* An edge the graph no longer holds (compaction removed or replaced it). */
typedef struct pgem_ingest_released {
    uint16_t source;
    int64_t sequence;
} pgem_ingest_released_t;

/* After a compaction of the graph: the removed poses' ids and the removed edges' keys leave
 * the tables, their capacity freed. Each removed id is remembered with its anchor: a pose
 * that was kept (anchors[i]) and where it lies in the removed pose's frame (relative, pose_size
 * values each). A later edge naming a removed pose enters on its anchor, the measurement
 * composed with that relative pose (through anchors removed since, too); a pose message with
 * a removed id is refused as `removed`. At most 4 x max_poses ids are remembered, the oldest
 * forgotten first: an edge naming a forgotten one (an unknown id within the ranges of ids
 * forgotten) is refused as `forgotten`, naming the pose. */
void pgem_ingest_release(pgem_ingest_t *ingest, const pgem_id_t *ids, const pgem_id_t *anchors,
                         const double *relative, uint32_t id_count,
                         const pgem_ingest_released_t *edges, uint32_t edge_count);
/* An admitted edge whose pose compaction removed after the ingest let it through (it was in
 * the queue): its ends moved onto their anchors as pgem_ingest_release describes. Returns 1
 * if an end moved. */
int pgem_ingest_reanchor(pgem_ingest_t *ingest, pgem_item_t *item);
/* After a compaction that left the graph above its high-water mark: poses beyond `poses` and
 * edges beyond `edges` admitted are refused as `full`, the message ending with `why`; 0, 0
 * (after a compaction that freed room) admits up to the configured capacities again. */
void pgem_ingest_set_full(pgem_ingest_t *ingest, uint32_t poses, uint32_t edges, const char *why);
/* Edges that entered on a removed pose's anchor since the start (a status counter). */
int64_t pgem_ingest_reanchored(const pgem_ingest_t *ingest);

uint32_t pgem_ingest_expire(pgem_ingest_t *ingest, int64_t utime);

/* The latest expiry in words, naming the edge and why ("" before the first). */
const char *pgem_ingest_last_expiry(const pgem_ingest_t *ingest);

void pgem_ingest_counts(const pgem_ingest_t *ingest, pgem_ingest_counts_t *counts);

/* The latest edge sent as ODOMETRY that entered the graph as a loop closure, in words, naming
 * the edge's poses, source and sequence and why ("" before the first). See emit_edge in
 * ingest.c and docs/BRIDGE.md, "What a front-end may claim". */
const char *pgem_ingest_last_odometry_note(const pgem_ingest_t *ingest);

/* The source table (names in order of first appearance); index from pgem_item_t.source. A slot
 * freed by expiry names "" until a new source takes it. */
uint32_t pgem_ingest_source_count(const pgem_ingest_t *ingest);
const char *pgem_ingest_source_name(const pgem_ingest_t *ingest, uint32_t index);

/* The role of bytes laid out exactly as one of the input types (pose2_t, pose3_t, edge2_t,
 * edge3_t, command_t: fingerprint, one well-formed string, nothing more or less): POSE, EDGE or
 * COMMAND; ANY when they are none of them. Checks the layout only, not the values. */
pgem_role_t pgem_ingest_wire_role(const void *data, size_t size);

/* A SNAPSHOT file name the bridge accepts: 1 to PGEM_SNAPSHOT_NAME_MAX bytes of [A-Za-z0-9._-],
 * not starting with '.': no folder, no way out of the snapshot folder, no hidden file. */
int pgem_snapshot_name_ok(const char *name);

/* Expands an upper triangle (row by row) into a full row-major n x n matrix. */
void pgem_upper_to_full(const double *upper, int n, double *full);

#endif /* PGEM_BRIDGE_INGEST_H */
