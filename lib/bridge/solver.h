/* The bridge's solver thread: it owns the core instance, drains the queue (handoff.h) into
 * it, decides when to update or solve, publishes what it solved (graph_t, compaction_t,
 * covariance_t) and writes snapshots. Its own state is below; only this thread touches it
 * (and the start and the end, before it exists and after it ended). The live EM pass's
 * thread shares only `pass`'s fields that pass.h marks as guarded by the bridge's lock. */
#ifndef PGEM_BRIDGE_SOLVER_H
#define PGEM_BRIDGE_SOLVER_H

#include <stddef.h>
#include <stdint.h>

#include "handoff.h"
#include "ingest.h"
#include "pass.h"
#include "pgem_graph_t.h"
#include "pgem/pgem.h"

/* How the bridge holds a part's anchor (gauge_fixed). */
#define BRIDGE_HOLD_FIXED 1u /* pgem_fix_pose: the main part's */
#define BRIDGE_HOLD_GAUGE 2u /* pgem_hold_gauge: any other part's */

/* The parts of the graph joined by odometry (components.c), kept up to date from what
 * arrived since the last look. */
typedef struct bridge_parts {
    uint32_t *parent;           /* per core pose: union-find parent over the odometry */
    uint32_t *anchor;           /* per root: index of the part's smallest pose id, UINT32_MAX
                                   if the front-end fixed a pose in it */
    uint8_t *has_edge;          /* per root: 1 if an edge touches the part */
    uint32_t poses;             /* poses already in the parts */
    uint32_t edges;             /* edges already in the parts */
    uint32_t with_edges;        /* parts that have an edge */
    uint32_t main_anchor;       /* the held pose of the part with the smallest pose id: fixed
                                   (the other parts hold their gauge), UINT32_MAX if none */
} bridge_parts_t;

/* Compaction (--compact, compaction.c): pgem_compact's maps and what the ingest is told. */
typedef struct bridge_compaction {
    uint32_t *pose_map;         /* pgem_compact's maps of old to new indices */
    uint32_t *edge_map;
    pgem_id_t *ids;             /* the removed poses' ids, for the ingest */
    pgem_id_t *anchors;         /* each one's anchor: the kept pose before it */
    double *relative;           /* the anchor in the removed pose's frame */
    double *before;             /* every pose's estimate before the compaction */
    pgem_ingest_released_t *edges; /* the removed edges' keys, for the ingest */
    uint64_t count;             /* compactions so far */
    int full;                   /* the last one left the graph above its high mark */
} bridge_compaction_t;

/* The settle's way back (incremental bridges, solve.c): the core's estimate and loop states
 * (pgem_update_save) and the bridge's per-pose flags from before it, so a settle that gives
 * way to arriving items is undone and the incremental updates go on. */
typedef struct bridge_settle {
    unsigned char *save;
    size_t save_size;
    uint8_t *anchored;
    uint8_t *gauge;
    uint32_t solved_poses;
    int yields;                 /* the settle under way gives way to arriving items */
    int gave_way;               /* and it did */
} bridge_settle_t;

/* The live EM pass (incremental bridges): whole-graph EM on a copy while the updates go on
 * (pass.c, its own thread), adopted when done (pass_adopt.c). */
typedef struct bridge_live_em {
    bridge_pass_t pass;
    int on;                     /* the bridge runs passes */
    uint64_t generation;        /* +1 when the estimate is replaced other than by an update or
                                   a pass (reset, a whole-graph solve): an older copy is dropped */
    uint32_t loops;             /* loop closures the last pass's copy held */
    double next;                /* no pass starts before this (the last one's end plus its
                                   time: passes take at most half the time) */
    double took;                /* the last pass's time, copy to result (s) */
} bridge_live_em_t;

/* Publication (publish.c, covariance.c): buffers sized for the capacities. */
typedef struct bridge_out {
    int64_t *ids;
    double *values;
    double **rows;
    pgem_loop_t *loops;
    char **sources;
    char *names;                /* the source names, copied under the lock (PGEM_SOURCE_MAX
                                   bytes each) */
    int64_t *last;
    int64_t *anchors;           /* a compaction's anchors, for pgem.compaction_t */
    unsigned char *buffer;      /* every message is encoded here */
    size_t buffer_size;
    int64_t graph_utime;        /* the last graph_t's utime, for pgem.covariance_t */
} bridge_out_t;

/* The team message (team.c): per pose its robot and its part over the odometry and the
 * accepted loop closures, per source its count, first pose and what goes out. */
typedef struct bridge_team {
    uint32_t *parent;           /* per pose: union-find over odometry and accepted loops */
    uint32_t *robot;            /* per pose: its robot's source index (team.c), or none */
    uint32_t *label;            /* per root: its part's number in the message, or none */
    uint8_t *bits;              /* per pose: an edge touches it, it is held; per root: its
                                   part has an edge, holds a held pose */
    uint32_t *first;            /* per source: its first pose's index */
    int32_t *count;             /* per source: its poses */
    char **names;               /* per robot (out): its source name (the graph's copy) */
    int32_t *poses;             /* per robot (out): its poses, first pose, part, anchored */
    int64_t *first_ids;
    int32_t *part;
    int8_t *anchored;
    double **frames;            /* per robot (out): rows into frame_values */
    double *frame_values;
    uint32_t parts;             /* the last graph's parts that have an edge, joined by
                                   odometry and accepted loop closures */
} bridge_team_t;

typedef struct bridge_solver {
    /* The graph: the core instance and the bridge's per-edge and per-pose arrays. */
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
    double *raw;                /* per core pose: the front-end's estimate, as received */
    /* What the solves left. */
    uint32_t solved_poses;      /* poses that took part in the last successful solve */
    uint32_t loop_count;        /* loop closures in the core */
    uint32_t pruned_count;      /* of them pruned after the last solve or update (its
                                   summary's count) */
    pgem_robust_outcome_t outcome; /* and that summary's outcome for the loops */
    int restart_pending;        /* the last solve saw a split graph or failed: the next one
                                   on a whole graph starts afresh from the raw estimates */
    int live_failed;            /* a compacted graph's restart from the live estimate failed:
                                   the next restart starts from the front-end's estimates */
    int64_t solve_id;

    bridge_parts_t parts;
    bridge_compaction_t compaction;
    bridge_settle_t settle;
    bridge_live_em_t live_em;
    bridge_out_t out;
    bridge_team_t team;
    /* The newest pose's covariances published (covariance.c), [0] from the incremental
     * factor, [1] from a factor at the estimate, and the seconds they took; failures. */
    struct {
        uint64_t count[2];
        double seconds[2];
        uint64_t failures;
    } covariance;
} bridge_solver_t;

/* solver.c: the state, allocated at start from the capacities (0, or -1 with message), and
 * freed at the end; the thread's loop (drain, apply, decide, solve, snapshot, pass). */
int bridge_solver_init(bridge_t *bridge, char *message, size_t message_size);
void bridge_solver_free(bridge_t *bridge);
void *bridge_solver_main(void *user);
/* Copies the graph's counts into the hand-off for the status (takes the lock). */
void bridge_solver_counts(bridge_t *bridge);

/* apply.c: adds one item to the graph; returns 1 if it was a new loop closure. */
int bridge_apply(bridge_t *bridge, const pgem_item_t *item);

/* solve.c. */
/* Solves and publishes; trigger names why ("loops", "command", "recovery"). */
void bridge_solve(bridge_t *bridge, const char *trigger);
/* One incremental update, not published: while a batch of items is applied, one per pose
 * that got edges, so each pose's loop closures are gated under a map that already holds the
 * loop closures before them (one update for a long batch would test them all against the
 * estimate from before it, and reject the ones that agree with an earlier correction).
 * Nothing when the next solve must restart. */
void bridge_solve_step(bridge_t *bridge);
/* The settle solve: every pose back to the front-end's estimate, every loop closure back in,
 * EM on the whole graph (trigger "settle"); run once the stream has been quiet for idle_solve
 * after incremental solves, so a paused robot's map is the one the offline tools compute.
 * With incremental updates it gives way to items that arrive while it runs: it stops after
 * the Gauss-Newton iteration under way, the graph is put back as the last update left it
 * (nothing is published), and it returns 0, still owed; else 1. */
int bridge_solve_settle(bridge_t *bridge);
/* One incremental update; the summary gets what a robust solve's would say of the loops
 * (bridge_solve_loops). */
int bridge_solve_update(bridge_t *bridge, pgem_robust_summary_t *summary);
/* What a robust solve's summary would say of the loops: the loop closures, and the pruned
 * count and outcome of the last update or solve (the core's); chi2 not computed (NaN). */
void bridge_solve_loops(const bridge_t *bridge, pgem_robust_summary_t *summary);
/* A successful solve's degenerate outcome in words, empty when loop closures were accepted. */
void bridge_solve_describe(const pgem_robust_summary_t *summary, char *text, size_t size);
/* After a solve or an update: the poses it solved (none re-anchored since) and the outcome
 * in words, or why it failed. */
void bridge_solve_done(bridge_t *bridge, int status, const pgem_robust_summary_t *summary,
                       char *why, size_t why_size);

/* pass_adopt.c: the live EM pass, after each batch: adopts a finished pass (an update at its
 * estimate and verdicts, published as "em-pass") and starts the next one when loop closures
 * arrived since the last copy. Nothing when passes are off. */
void bridge_pass_schedule(bridge_t *bridge);
/* (Lock held) When the next pass is owed (loop closures arrived since the last copy and the
 * pass is idle): its earliest start; +inf when none is. */
double bridge_pass_due(const bridge_t *bridge);
/* The estimate was replaced other than by an update or a pass: a pass of an older copy is
 * dropped when it ends. */
void bridge_pass_drop(bridge_t *bridge);

/* compaction.c: poses removed (pgem_compact) when the graph nears its capacities; 1 if it
 * did. bridge_compact_further: to 70 % of the poses it has (an incremental factor that outgrew
 * its fill budget). */
int bridge_compact(bridge_t *bridge);
int bridge_compact_further(bridge_t *bridge);

/* publish.c: every message the solver thread publishes is encoded into the out buffer.
 * bridge_out_ready: 1 when it has room for `size` bytes (grown if need be), else 0, noted,
 * naming `what`; bridge_out_publish: the buffer's message (`encoded`: what its encoder
 * returned) published on channel, a failed encoding or a refusal noted. A new message is an
 * encoder between the two. */
int bridge_out_ready(bridge_t *bridge, int size, const char *what);
void bridge_out_publish(bridge_t *bridge, const char *channel, const char *what, int size,
                        int encoded);
/* graph_t: the graph as it is, with the solve's summary (NULL after a reset). */
void bridge_publish_graph(bridge_t *bridge, const char *trigger,
                          const pgem_robust_summary_t *summary, int usable, const char *why,
                          int64_t solve_time_us);
/* team_t: each robot's poses, part and frame in the graph just published (team.c), with the
 * graph's utime and its sources' count (the names are the graph's, in out.sources). */
void bridge_publish_team(bridge_t *bridge, int64_t utime, uint32_t sources);
/* compaction_t: the poses one compaction removed, their anchors and where they lay. */
void bridge_publish_compaction(bridge_t *bridge, const pgem_compact_summary_t *summary,
                               uint32_t removed, int full);

/* snapshot.c: the graph and its weights written to NAME and NAME.weights in the snapshot
 * folder, whole or not at all; noted either way. */
void bridge_snapshot_write(bridge_t *bridge, const char *name);

/* components.c: the parts joined by odometry that have edges, each held at its smallest pose
 * id (or by a pose the front-end fixed); returns how many there are. Visits only what arrived
 * since the last call; reset with the graph. hold_lone also holds the poses no edge touches
 * yet, for a whole-graph solve (O(poses)). */
uint32_t bridge_components_hold(bridge_t *bridge);
void bridge_components_hold_lone(bridge_t *bridge);
void bridge_components_reset(bridge_t *bridge);

/* covariance.c: after a graph was published, the newest pose's covariance
 * (pgem.covariance_t): whole after a whole-graph solve (a factor at the estimate), else from
 * the incremental factor of the update. Nothing with no_covariance, or when it cannot be had
 * (logged). */
void bridge_covariance_publish(bridge_t *bridge, int whole);

#endif /* PGEM_BRIDGE_SOLVER_H */
