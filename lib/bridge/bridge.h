/* The LCM bridge: receives poses and edges from front-ends, keeps them in a core instance,
 * runs EM when new loop closures arrive (debounced, rate-limited) or on command, and publishes
 * the optimized graph and its status.
 *
 * Two threads. The reception thread only decodes, validates, journals and queues (through the
 * ingest state machine), so it never waits for a solve. The solver thread owns the core: it
 * drains the queue into the graph and solves. Memory is allocated at start from the
 * capacities; a solve allocates nothing but what the core documents (CSparse's symbolic
 * analysis when the topology changed). */
#ifndef PGEM_BRIDGE_BRIDGE_H
#define PGEM_BRIDGE_BRIDGE_H

#include <stddef.h>
#include <stdint.h>

#include <lcm/lcm.h>

#include "channels.h"
#include "pgem/robust.h"

typedef void (*pgem_bridge_log_fn)(void *user, const char *line);

typedef struct pgem_bridge_options {
    lcm_t *lcm;                /* an LCM instance to use (the caller's; not destroyed); NULL:
                                  the bridge opens `url` itself */
    const char *url;           /* LCM URL; NULL means LCM_DEFAULT_URL (or LCM's default) */
    pgem_channels_t channels;  /* see channels.h */
    int dimension;             /* 2 or 3 */
    uint32_t max_poses;        /* capacities (0: 20000 poses, 4 edges per pose) */
    uint32_t max_edges;
    uint32_t fill_budget;      /* 0: the core's default */
    uint32_t max_pending;      /* edges that may wait for their poses (0: 4096) */
    uint32_t max_sources;      /* front-ends (0: 64) */
    double pending_timeout;    /* s an edge may wait for its poses before it expires
                                  (default 60) */
    double debounce;           /* s to wait after a new loop closure for more (default 0.01) */
    double max_rate;           /* solves per second at most (default 20) */
    double max_delay;          /* s a loop closure may wait for its solve while more keep
                                  arriving (default 0.1) */
    double status_period;      /* s between status messages (default 0.5) */
    double idle_solve;         /* s without new items after which edges not yet in a solve
                                  (odometry alone, say) get one, and after that (or after
                                  incremental loop solves) the settle solve (default 0.5) */
    const char *journal;       /* journal path; NULL for none */
    int journal_sync;          /* fdatasync every record */
    const char *snapshot_dir;  /* the folder SNAPSHOT commands write into; NULL: SNAPSHOT is
                                  refused (a message names a file in it, never a path) */
    uint32_t snapshot_limit;   /* SNAPSHOTs accepted in any minute at most (default 6) */
    double snapshot_budget;    /* MiB snapshots may write in any minute (default 64): one
                                  that would pass it is refused */
    pgem_robust_options_t robust;  /* zeroed: EM with its defaults, as everywhere; kernel
                                      PGEM_KERNEL_NONE (--robust none): every loop at weight 1 */
    int full;                  /* 0 (default): every pose that got edges gets an incremental
                                  update (pgem_update, new loop closures through its gate),
                                  published after each batch of items; the settle solve (EM
                                  on everything, after idle_solve) follows once the stream is
                                  quiet. 1: every solve re-solves the whole graph with EM
                                  (debounced, rate-limited), as before issue 20 */
    int no_live_em;            /* incremental bridges run whole-graph EM passes while the
                                  stream goes on (on a copy of the graph in a block of its
                                  own, on a thread of its own; each adopted into the live map
                                  when done, at most half the time busy): 1 turns them off,
                                  leaving the per-update gate alone until the settle */
    int compact;               /* 1: a graph that reaches 90 % of max_poses (or of max_edges)
                                  has poses removed down to 70 % (pgem_compact), so the map
                                  keeps growing; 0 (default): poses at capacity are refused */
    uint32_t compact_tail;     /* the newest poses compaction never removes (0: 64) */
    int no_covariance;         /* 0 (default): after each graph, the newest pose's marginal
                                  covariance is published (pgem.covariance_t on
                                  channels.covariance); 1: not */
    pgem_bridge_log_fn log;    /* progress lines (NULL: silent) */
    void *log_user;
} pgem_bridge_options_t;

/* Fills the defaults above into a zeroed options struct (channels from the default prefix for
 * the dimension; dimension 2 if unset). */
void pgem_bridge_defaults(pgem_bridge_options_t *options);

/* Runs until stop() returns non-zero (polled at least every 100 ms), then finishes
 * cleanly: the solve in progress is interrupted, a last status is published, the journal is
 * closed. Returns 0, or -1 with message when the bridge could not start (LCM URL, journal,
 * snapshot folder, memory). A journal that is not an LCM log, or whose records do not fit the
 * bridge's dimension and capacities, is refused, unchanged. */
int pgem_bridge_run(const pgem_bridge_options_t *options, int (*stop)(void), char *message,
                    size_t message_size);

#endif /* PGEM_BRIDGE_BRIDGE_H */
