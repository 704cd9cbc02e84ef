/* What the bridge's reception and solver threads share: everything here is read and written
 * with `lock` held, and nothing else of the bridge is touched by both (reception.h and
 * solver.h hold each thread's own state; docs/design/bridge-threads.md has the map). */
#ifndef PGEM_BRIDGE_HANDOFF_H
#define PGEM_BRIDGE_HANDOFF_H

#include <pthread.h>
#include <stdint.h>

#include "ingest.h"

typedef struct bridge bridge_t; /* bridge_internal.h */

/* SNAPSHOT's bounds (issue 31), pgem_bridge_options_t's defaults: an operator saving the map
 * by hand, or a periodic saver, makes a few a minute; 64 MiB a minute lets a 20000-pose map
 * (some 10 MB in 2D, 20 MB in 3D) be saved several times a minute, while a flood of SNAPSHOTs
 * writes at most 64 MiB a minute, not a disk's worth. */
#define BRIDGE_SNAPSHOT_LIMIT 6u
#define BRIDGE_SNAPSHOT_BUDGET 64.0   /* MiB */
#define BRIDGE_SNAPSHOT_PERIOD 60.0   /* s: the window both bounds count */

/* Items the solver thread takes from the queue at once; the queue has room for the
 * capacities and one batch more. */
#define BRIDGE_BATCH 256

typedef struct bridge_snapshot {
    double accepted;  /* bridge_now() when the SNAPSHOT was accepted */
    uint64_t bytes;   /* what its write wrote (both files) */
} bridge_snapshot_t;

typedef struct bridge_handoff {
    pthread_mutex_t lock;      /* guards every field below */
    pthread_cond_t wake;       /* the solver thread waits on it (and the live pass's end) */
    int stopping;              /* the bridge stops: the solver thread ends, a solve stops */

    /* The reception state machine: the reception thread feeds it messages; the solver thread
     * copies its source names and hands it what a compaction removed. */
    pgem_ingest_t *ingest;
    /* The reception thread is journaling a message the ingest is admitting (the ingest's
     * admit hook): the lock is released for the write, and the ingest, consistent meanwhile
     * (nothing has changed yet), may be read but must not be changed until it is 0 again
     * (the reception thread signals `wake` when the message is done). */
    int admitting;
    /* The ingest's counters as of the last message handled to the end (journaled and visible
     * to the solver). The status reports these, never the live ones: the solver publishes a
     * status after each solve, and a count taken while the reception thread is between
     * admitting an edge and journaling it would acknowledge an edge a SIGKILL then loses. */
    pgem_ingest_counts_t counts;
    int64_t journal_records;   /* the journal's records at the same moment */
    int64_t recovered;         /* records the journal's replay gave at start */

    /* Queue of admitted items: [head, visible) may be taken by the solver; [visible, tail)
     * are being journaled. Indices grow forever; slot = index % capacity. */
    struct {
        pgem_item_t *items;
        uint64_t capacity;
        uint64_t head;
        uint64_t visible;
        uint64_t tail;
        int64_t overflows;
    } queue;

    /* Requests for the solver thread. */
    struct {
        int64_t optimize_commands; /* OPTIMIZE received since the last command solve began */
        int optimize;
        int recovery;              /* the journal's replay owes one whole-graph solve */
        int snapshot;
        char snapshot_path[PGEM_PATH_MAX];
    } requests;

    /* The SNAPSHOTs accepted in the last minute, oldest first (a ring of snapshot_limit
     * entries from `first`): when, and what the write they asked for wrote (0 until written,
     * and for one a later request replaced). The reception thread admits them (held.c), the
     * solver thread writes them. */
    struct {
        bridge_snapshot_t *ring;
        uint64_t last_size;        /* bytes of the last snapshot written (both files) */
        uint32_t first;
        uint32_t count;
        uint32_t latest;           /* the entry of the request the solver will write */
    } snapshots;

    /* What the solver thread last did, for the status. */
    struct {
        int32_t poses;
        int32_t edges;
        int32_t loops;
        int32_t pruned;
        int64_t solves;
        int solving;
        int64_t core_rejections;
        int64_t full_rejections; /* admitted items the full block could not take (--compact) */
    } graph;

    /* The status's message: the latest note of either thread. */
    char last_message[384];
} bridge_handoff_t;

#endif /* PGEM_BRIDGE_HANDOFF_H */
