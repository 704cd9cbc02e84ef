/* Shared state of a running bridge (bridge.c: reception, scheduling; graph.c: the solver's
 * graph, solves and publication; status.c: status messages). */
#ifndef PGEM_BRIDGE_INTERNAL_H
#define PGEM_BRIDGE_INTERNAL_H

#include <lcm/lcm.h>
#include <pthread.h>
#include <signal.h>

#include "bridge.h"
#include "ingest.h"
#include "journal.h"
#include "pass.h"
#include "pgem/pgem.h"
#include "pgem_compaction_t.h"
#include "pgem_graph_t.h"

/* How the bridge holds a part's anchor (gauge_fixed). */
#define BRIDGE_HOLD_FIXED 1u /* pgem_fix_pose: the main part's */
#define BRIDGE_HOLD_GAUGE 2u /* pgem_hold_gauge: any other part's */

/* SNAPSHOT's bounds (issue 31), pgem_bridge_options_t's defaults: an operator saving the map
 * by hand, or a periodic saver, makes a few a minute; 64 MiB a minute lets a 20000-pose map
 * (some 10 MB in 2D, 20 MB in 3D) be saved several times a minute, while a flood of SNAPSHOTs
 * writes at most 64 MiB a minute, not a disk's worth. */
#define BRIDGE_SNAPSHOT_LIMIT 6u
#define BRIDGE_SNAPSHOT_BUDGET 64.0   /* MiB */
#define BRIDGE_SNAPSHOT_PERIOD 60.0   /* s: the window both bounds count */

typedef struct bridge_snapshot {
    double accepted;  /* bridge_now() when the SNAPSHOT was accepted */
    uint64_t bytes;   /* what its write wrote (both files) */
} bridge_snapshot_t;

typedef struct bridge {
    pgem_bridge_options_t options;
    lcm_t *lcm;
    pthread_mutex_t lock;   /* guards everything marked (L) */
    pthread_cond_t wake;    /* (L) the solver waits on it */
    volatile sig_atomic_t stopping;

    /* Reception side (reception thread; the ingest is (L) because the solver reads sources
     * and counters). */
    pgem_ingest_t *ingest;
    pgem_journal_t *journal;
    int64_t recovered;
    const char *channel;       /* the message being handled: its channel and receive time, */
    int64_t utime;             /* for the journal record the admit hook writes */
    int64_t replay_refused[PGEM_REJECT_COUNT]; /* journal records refused on replay, by reason */
    char replay_first[384];    /* the first of them, in words */
    int64_t expiries_logged;
    int64_t odometry_notes_logged; /* edges sent as ODOMETRY that entered as loops */
    int snapshot_dir;          /* open folder for SNAPSHOT, -1 none */
    /* (L) The ingest's counters as of the last message handled to the end (journaled and
     * visible to the solver). The status reports these, never the live ones: the solver
     * publishes a status after each solve, and a count taken while the reception thread is
     * between admitting an edge and journaling it would acknowledge an edge a SIGKILL then
     * loses. */
    pgem_ingest_counts_t counts;
    int64_t journal_records;   /* (L) the journal's records at the same moment */

    /* Queue of admitted items (L): [head, visible) may be taken by the solver; [visible,
     * tail) are being journaled. Indices grow forever; slot = index % capacity. */
    pgem_item_t *queue;
    uint64_t queue_capacity;
    uint64_t head;
    uint64_t visible;
    uint64_t tail;
    int64_t queue_overflows;

    /* Requests for the solver (L). */
    int64_t optimize_commands; /* OPTIMIZE received since the last command solve began */
    int optimize_requested;
    int snapshot_requested;
    char snapshot_path[PGEM_PATH_MAX];
    /* (L) The SNAPSHOTs accepted in the last minute, oldest first (a ring of snapshot_limit
     * entries from snapshot_first): when, and what the write they asked for wrote (0 until
     * written, and for one a later request replaced). */
    bridge_snapshot_t *snapshots;
    uint64_t snapshot_last_size; /* bytes of the last snapshot written (both files) */
    uint32_t snapshot_first;
    uint32_t snapshot_count;
    uint32_t snapshot_latest;  /* the entry of the request the solver will write */
    int recovery_pending;

    /* What the solver last did, for the status (L). */
    int32_t graph_poses;
    int32_t graph_edges;
    int32_t graph_loops;
    int32_t graph_pruned;
    int64_t solves;
    int solving;
    int compaction_full;        /* the last compaction left the graph above its high mark */
    int64_t core_rejections;
    int64_t full_rejections;    /* admitted items the full block could not take (--compact) */
    char last_message[384];
    int64_t rejections_logged;

    /* Solver thread only. */
    pgem_config_t core_config;
    void *core_block;
    size_t core_block_size;
    pgem_t *core;
    uint16_t *edge_source;      /* per core edge: source index */
    int64_t *edge_sequence;     /* per core edge: the front-end's sequence number */
    int64_t *source_last;       /* per source: highest sequence in the graph, -1 none */
    uint8_t *anchored;          /* per core pose: initial estimate re-anchored */
    uint8_t *user_fixed;        /* per core pose: fixed by the front-end */
    uint8_t *gauge_fixed;       /* per core pose: held by the bridge for its component
                                   (BRIDGE_HOLD_FIXED, BRIDGE_HOLD_GAUGE) or 0 */
    uint32_t *component;        /* per core pose: union-find parent over the odometry */
    uint32_t *component_anchor; /* per root: index of the part's smallest pose id, UINT32_MAX
                                   if the front-end fixed a pose in it */
    double *raw;                /* per core pose: the front-end's estimate, as received */
    uint8_t *part_edges;        /* per root: 1 if an edge touches the part */
    uint32_t parts_poses;       /* poses already in the parts (components.c) */
    uint32_t *compact_pose_map; /* pgem_compact's maps of old to new indices */
    uint32_t *compact_edge_map;
    pgem_id_t *compact_ids;     /* the removed poses' ids, for the ingest */
    pgem_id_t *compact_anchors; /* each one's anchor: the kept pose before it */
    double *compact_relative;   /* the anchor in the removed pose's frame */
    double *compact_before;     /* every pose's estimate before the compaction */
    pgem_ingest_released_t *compact_edges; /* the removed edges' keys, for the ingest */
    uint64_t compactions;
    uint32_t main_anchor;       /* the held pose of the part with the smallest pose id: fixed
                                   (the other parts hold their gauge), UINT32_MAX if none */
    uint32_t parts_edges;       /* edges already in the parts */
    uint32_t parts_with_edges;  /* parts that have an edge */
    int restart_pending;        /* the last solve saw a split graph or failed: the next one
                                   on a whole graph starts afresh from the raw estimates */
    int live_failed;            /* a compacted graph's restart from the live estimate failed:
                                   the next restart starts from the front-end's estimates */
    uint32_t solved_poses;      /* poses that took part in the last successful solve */
    uint32_t loop_count;        /* loop closures in the core */
    uint32_t pruned_count;      /* of them pruned after the last solve or update */
    uint32_t counted_edges;     /* edges whose state pruned_count has seen */
    int64_t solve_id;
    /* The settle's way back (incremental bridges): the core's estimate and loop states
     * (pgem_update_save) and the bridge's per-pose flags from before it, so a settle that
     * gives way to arriving items is undone and the incremental updates go on. */
    unsigned char *settle_save;
    size_t settle_save_size;
    uint8_t *settle_anchored;
    uint8_t *settle_gauge;
    uint32_t settle_solved_poses;
    int settle_yields;          /* the settle under way gives way to arriving items */
    int settle_gave_way;        /* and it did */
    /* The live EM pass (incremental bridges, pass.c): whole-graph EM on a copy while the
     * updates go on, adopted when done. */
    bridge_pass_t pass;
    int pass_on;                /* the bridge runs passes */
    uint64_t generation;        /* +1 when the estimate is replaced other than by an update or
                                   a pass (reset, a whole-graph solve): an older copy is dropped */
    uint32_t pass_loops;        /* loop closures the last pass's copy held */
    double pass_next;           /* no pass starts before this (the last one's end plus its
                                   time: passes take at most half the time) */
    double pass_took;           /* the last pass's time, copy to result (s) */
    /* Publication buffers for graph_t, sized for the capacities. */
    int64_t *out_ids;
    double *out_values;
    double **out_rows;
    pgem_loop_t *out_loops;
    char **out_sources;
    int64_t *out_last;
    int64_t *out_last_anchor;   /* a compaction's anchors, for pgem.compaction_t */
    unsigned char *out_buffer;
    size_t out_buffer_size;
    int64_t graph_utime;        /* the last graph_t's utime, for pgem.covariance_t */
    /* The newest pose's covariances published (covariance.c), [0] from the incremental
     * factor, [1] from a factor at the estimate, and the seconds they took; failures. */
    uint64_t covariance_count[2];
    double covariance_seconds[2];
    uint64_t covariance_failures;
} bridge_t;

/* Monotonic seconds and wall-clock microseconds. */
double bridge_now(void);
int64_t bridge_utime(void);

/* Formats a line and hands it to the log callback. */
void bridge_log(bridge_t *bridge, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* graph.c (solver thread). */
int bridge_graph_init(bridge_t *bridge, char *message, size_t message_size);
void bridge_graph_free(bridge_t *bridge);
/* Copies the graph's counts for the status (takes L). */
void bridge_graph_counts(bridge_t *bridge);
/* Adds one item to the graph; returns 1 if it was a new loop closure. */
int bridge_graph_apply(bridge_t *bridge, const pgem_item_t *item);
/* Solves and publishes; trigger names why ("loops", "command", "recovery"). */
void bridge_graph_solve(bridge_t *bridge, const char *trigger);
/* One incremental update, not published: while a batch of items is applied, one per pose
 * that got edges, so each pose's loop closures are gated under a map that already holds the
 * loop closures before them (one update for a long batch would test them all against the
 * estimate from before it, and reject the ones that agree with an earlier correction).
 * Nothing when the next solve must restart or hold several parts. */
void bridge_graph_step(bridge_t *bridge);
/* The live EM pass, after each batch: adopts a finished pass (an update at its estimate and
 * verdicts, published as "em-pass") and starts the next one when loop closures arrived since
 * the last copy. Nothing when passes are off. */
void bridge_graph_pass(bridge_t *bridge);
/* (L held) When the next pass is owed (loop closures arrived since the last copy and the
 * pass is idle): its earliest start; +inf when none is. */
double bridge_graph_pass_due(const bridge_t *bridge);
/* The settle solve: every pose back to the front-end's estimate, every loop closure back in,
 * EM on the whole graph (trigger "settle"); run once the stream has been quiet for idle_solve
 * after incremental solves, so a paused robot's map is the one the offline tools compute.
 * With incremental updates it gives way to items that arrive while it runs: it stops after
 * the Gauss-Newton iteration under way, the graph is put back as the last update left it
 * (nothing is published), and it returns 0, still owed; else 1. */
int bridge_graph_settle(bridge_t *bridge);
/* Publishes the graph as it is, without solving (after a reset). */
void bridge_graph_publish(bridge_t *bridge, const char *trigger,
                          const pgem_robust_summary_t *summary, int usable, const char *why,
                          int64_t solve_time_us);
void bridge_graph_snapshot(bridge_t *bridge, const char *path);
/* graph.c (solver thread): every message the solver thread publishes is encoded into the out
 * buffer. bridge_out_ready: 1 when it has room for `size` bytes (grown if need be), else 0,
 * noted, naming `what`; bridge_out_publish: the buffer's message (`encoded`: what its encoder
 * returned) published on channel, a failed encoding or a refusal noted. */
int bridge_out_ready(bridge_t *bridge, int size, const char *what);
void bridge_out_publish(bridge_t *bridge, const char *channel, const char *what, int size,
                        int encoded);

/* components.c (solver thread): the parts joined by odometry that have edges, each held at its
 * smallest pose id (or by a pose the front-end fixed); returns how many there are. Visits only
 * what arrived since the last call; reset with the graph. hold_lone also holds the poses no
 * edge touches yet, for a whole-graph solve (O(poses)). */
uint32_t bridge_components_hold(bridge_t *bridge);
void bridge_components_hold_lone(bridge_t *bridge);
void bridge_components_reset(bridge_t *bridge);
/* graph.c: poses removed (pgem_compact) when the graph nears its capacities; 1 if it did */
int bridge_graph_compact(bridge_t *bridge);
/* graph.c: the estimate was replaced other than by an update or a pass: a pass of an older
 * copy is dropped when it ends */
void bridge_graph_drop_pass(bridge_t *bridge);

/* covariance.c (solver thread): after a graph was published, the newest pose's covariance
 * (pgem.covariance_t): whole after a whole-graph solve (a factor at the estimate), else from
 * the incremental factor of the update. Nothing with no_covariance, or when it cannot be had
 * (logged). */
void bridge_covariance_publish(bridge_t *bridge, int whole);

/* status.c (either thread). */
void bridge_publish_status(bridge_t *bridge);
/* Sets the status's message (L must NOT be held) and logs it. */
void bridge_note(bridge_t *bridge, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* held.c (start and reception thread): the files the bridge holds. */
/* Logs each damaged stretch the journal's replay skipped and notes the summary (and a torn
 * last record cut). */
void bridge_journal_damage(bridge_t *bridge, const pgem_journal_info_t *info);
/* The journal's recognise hook: a record without a checksum holds a message the bridge takes
 * (an input type's exact layout; the type of its channel for the bridge's own channels). */
int bridge_journal_recognise(void *user, const char *channel, const void *data, size_t size);
/* Every status period: is the journal still at its path? Noted once when it is not (every
 * message that would change the graph is refused meanwhile) and once when it is back; *away
 * carries the state between calls. */
void bridge_journal_watch(bridge_t *bridge, int *away);
/* The ingest's SNAPSHOT hook: refuses a NAME whose NAME or NAME.weights in the snapshot
 * folder is the journal or the file the bridge's standard output or error goes to. */
int bridge_snapshot_check(void *user, const char *name, char *message, size_t message_size);
/* (L held) After a snapshot was written: the bytes it took, for the budget. */
void bridge_snapshot_written(bridge_t *bridge, uint64_t bytes);

#endif /* PGEM_BRIDGE_INTERNAL_H */
