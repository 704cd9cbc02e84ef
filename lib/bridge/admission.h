/* The admission state machine's state (ingest.h's pgem_ingest_t), shared by its files:
 * admission.c (the verdicts: capacity, sources, the pending list, commands), removed.c (the
 * poses compaction removed and their anchors) and key_table.c (the tables it keys by). */
#ifndef PGEM_BRIDGE_ADMISSION_H
#define PGEM_BRIDGE_ADMISSION_H

#include <stddef.h>
#include <stdint.h>

#include "ingest.h"

#define NONE UINT32_MAX /* end of a waiting list */
/* Removed poses remembered with their anchors, per pose of capacity: a long mission's later
 * edges to poses removed long ago still find their anchor (80 bytes each, 1.5 MiB per 1000
 * poses of capacity in 3D). */
#define REMOVED_PER_POSE 4u
/* Removed ids the ring has forgotten, kept as id ranges: an edge naming an unknown id inside one
 * is refused as forgotten rather than left to wait for a pose that will never come. Ids closer
 * than the pose capacity join one range (the kept poses between them are known); past 64
 * ranges the two closest merge. */
#define FORGOTTEN_RANGES 64u


/* Open-addressing tables keyed by a 64-bit pair (key_table.c); `used` marks live slots. */
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

/* An edge waiting for its poses: in the list of every waiting edge and in its source's, both
 * in arrival order (doubly linked through slot indices, NONE at the ends). */
typedef struct waiting {
    pgem_item_t item;
    int64_t since;          /* when it arrived (the message's utime) */
    uint32_t prev;
    uint32_t next;
    uint32_t source_prev;
    uint32_t source_next;
} waiting_t;

/* One front-end. A slot is free when its name is empty. */
typedef struct source {
    char name[PGEM_SOURCE_MAX];
    int64_t last;            /* highest sequence admitted since the last reset, -1 none
                                (named in conflict messages) */
    uint32_t waiting;        /* its edges in the pending list */
    uint32_t oldest;         /* the first of them, NONE */
    uint32_t newest;         /* the last of them, NONE */
    uint8_t emitted;         /* an edge of it went into the graph: its slot stays */
} source_t;

struct pgem_ingest {
    pgem_ingest_config_t config;
    pgem_emit_fn emit;
    void *user;
    pgem_admit_fn admit;
    void *admit_user;
    pgem_snapshot_check_fn snapshot_check;
    void *snapshot_user;
    table_t poses;            /* key (id, 0) */
    table_t edges;            /* key (source, sequence) */
    table_t removed;          /* ids compaction removed: key (id, 0) */
    pgem_id_t *removed_ring;  /* the same ids in the order removed (max_poses), to forget the
                                 oldest when full */
    pgem_id_t *anchor_ring;   /* each one's anchor (a pose kept when it went) */
    double *relative_ring;    /* the anchor in the removed pose's frame (pose_size each) */
    int64_t reanchored;
    uint32_t removed_head;    /* the oldest */
    uint32_t removed_count;
    pgem_id_t forgotten_low[FORGOTTEN_RANGES]; /* ranges of ids the ring forgot */
    pgem_id_t forgotten_high[FORGOTTEN_RANGES];
    uint32_t forgotten_count;
    table_t steps;            /* odometry in the graph: key (the smaller of two consecutive
                                 pose ids, 0), content the source index that made the step */
    waiting_t *pending;       /* max_pending slots */
    uint32_t *free_slots;     /* stack of unused pending slots */
    uint32_t free_count;
    uint32_t oldest;          /* first waiting edge in arrival order, NONE */
    uint32_t newest;          /* last, NONE */
    uint32_t pending_count;
    uint32_t full_poses;      /* nonzero: compaction can free nothing, poses beyond this many
                                 are refused as full (pgem_ingest_set_full) */
    uint32_t full_edges;
    char full_why[160];
    uint32_t admitted_poses;  /* capacity reserved since the last reset */
    uint32_t admitted_edges;  /* includes pending edges */
    source_t *sources;
    uint32_t source_count;    /* slots in use or freed below the highest in use */
    const void *data;         /* the message being handled, for the admit hook */
    size_t size;
    pgem_ingest_counts_t counts;
    char last_expiry[384];
    char last_odometry[384];  /* pgem_ingest_last_odometry_note */
};

/* key_table.c: a table with room for `capacity` keys (twice the slots): 1, or 0 out of
 * memory; every slot free; the slot holding the key, or the empty slot where it would go (never
 * full: capacity is reserved before insertion); a used slot removed; a slot taken. */
int key_table_init(table_t *table, uint32_t capacity);
void key_table_clear(table_t *table);
slot_t *key_table_find(const table_t *table, uint64_t a, uint64_t b);
void key_table_remove(table_t *table, slot_t *slot);
void key_table_take(slot_t *slot, uint64_t a, uint64_t b, uint64_t content);

/* A pose the ingest admitted (and compaction did not remove). */
static inline int ingest_pose_known(const pgem_ingest_t *ingest, pgem_id_t id)
{
    return key_table_find(&ingest->poses, id, 0)->used;
}

/* removed.c: 1 if compaction removed pose id (and the ingest still remembers it). */
int ingest_removed(const pgem_ingest_t *ingest, pgem_id_t id);
/* Both ends of an edge onto their anchors; 1 if either moved. */
int ingest_reanchor(pgem_ingest_t *ingest, pgem_item_t *item);
/* A re-anchored edge that goes in: counted, and a loop closure (a step of the chain no more:
 * the robust layer weighs it). */
void ingest_reanchored_goes_in(pgem_ingest_t *ingest, pgem_item_t *item);
/* An id in a forgotten range that is no pose the ingest knows: removed long ago. */
int ingest_forgotten(const pgem_ingest_t *ingest, pgem_id_t id);
/* Every removed pose forgotten (a reset). */
void ingest_removed_clear(pgem_ingest_t *ingest);

#endif /* PGEM_BRIDGE_ADMISSION_H */
