/* pgem-online-driver: a graph file fed to the library as a robot's stream, one update call per
 * pose (or every N poses), each timed; the stream's order and the update strategies. */
#ifndef PGEM_ONLINE_H
#define PGEM_ONLINE_H

#include <stddef.h>
#include <stdint.h>

#include "cli.h"

/* The order a front-end sends the file in: the poses in file order, each followed by every
 * edge whose later pose it is, in file order. */
typedef struct online_stream {
    const pgem_io_graph_t *file;  /* the graph read (poses, edges, FIX ids) */
    size_t *edges;                /* file->edge_count edge indices in stream order */
    size_t *first_edge;           /* file->pose_count + 1 entries: pose p's edges are
                                     edges[first_edge[p] .. first_edge[p + 1]) */
    unsigned char *fixed;         /* file->pose_count flags: named by a FIX line */
} online_stream_t;

/* Builds the stream of a file graph; 0, or -1 out of memory (nothing printed). */
int online_stream_build(const pgem_io_graph_t *file, online_stream_t *stream);
void online_stream_free(online_stream_t *stream);

/* How the driver places a new pose before its first update. */
typedef enum online_guess {
    ONLINE_GUESS_ANCHORED = 0,    /* as the LCM bridge: a new pose joined by odometry to a pose
                                     already solved (or placed so) is placed by the measurement
                                     from it; before the first solve, the stream's guess */
    ONLINE_GUESS_FILE = 1         /* the stream's guess (VERTEX line or composed) as it is */
} online_guess_t;

/* The library instance and the bookkeeping the bridge keeps beside it. */
typedef struct online_state {
    pgem_t *core;                 /* instance in `block`, sized for the whole stream */
    void *block;                  /* its memory, allocated once before the stream */
    size_t block_bytes;           /* pgem_memory_size of the configuration */
    int dimension;                /* 2 or 3 */
    online_guess_t guess;         /* --guess */
    double *raw;                  /* max_poses x pose size: the stream's guesses, kept for a
                                     restart after a failed update */
    unsigned char *placed;        /* max_poses flags: placed by odometry since the last solve */
    uint32_t solved_poses;        /* poses (by index) in the last successful update */
    int restart_pending;          /* an update failed: the next starts from the raw guesses */
    uint32_t restarts;            /* updates that started from the raw guesses */
    pgem_update_summary_t step;   /* --mode incremental: the last pgem_update's summary */
    pgem_config_t config;         /* the instance's configuration, kept for the pass's */
    pgem_t *pass;                 /* --live-em: the whole-graph pass's instance (NULL: none) */
    void *pass_block;             /* its memory, re-initialised for every pass */
    size_t pass_bytes;            /* pgem_memory_size of its configuration */
    int pass_pending;             /* a pass was solved and waits to be adopted */
    int pending;                  /* --mode incremental: pgem_update_options_t.pending */
} online_state_t;

/* Creates the instance for capacities (max_poses, max_edges, fill_budget; 0 = the core's
 * default fill, as the bridge); prints what failed. 0 or -1. */
int online_state_init(online_state_t *state, const pgem_config_t *config, online_guess_t guess);
void online_state_free(online_state_t *state);

/* --live-em: the second instance, same dimension and capacities, no online_fill; prints what
 * failed. 0 or -1. */
int online_pass_init(online_state_t *state);

/* A pass: the pass instance re-initialised, the graph copied into it, every pose set to the
 * stream's guess (what batch EM on the graph received so far starts from), every loop back in
 * and EM with its defaults; *seconds is the copy and the solve. Returns the library's status
 * (the pass waits for online_pass_adopt only when it succeeded). */
int online_pass_run(online_state_t *state, pgem_robust_summary_t *summary, double *seconds);

/* pgem_update_adopt of the waiting pass into the graph; *seconds is its wall time. Returns the
 * library's status; the pass no longer waits either way. */
int online_pass_adopt(online_state_t *state, pgem_adopt_summary_t *summary, double *seconds);

/* Adds pose p of the stream with its guess; adds one edge of the file and, with
 * ONLINE_GUESS_ANCHORED, places its new pose. Print the core's refusal; 0 or -1. */
int online_add_pose(online_state_t *state, const online_stream_t *stream, size_t pose);
int online_add_edge(online_state_t *state, const pgem_io_edge_t *edge);

/* One update of the estimate after new poses and edges; *seconds is the wall time of the
 * library call alone. Returns the library's status; *summary is filled either way. */
typedef int (*online_update_fn)(online_state_t *state, pgem_robust_summary_t *summary,
                                double *seconds);

/* An update strategy the command line can choose (--mode). */
typedef struct online_mode {
    const char *name;             /* "full", "incremental" */
    online_update_fn update;      /* NULL: not in this build (why says what is missing) */
    const char *why;              /* shown when update is NULL */
    online_update_fn settle;      /* after the stream (NULL: none): the solve that takes the
                                     estimate to the optimum; timed apart */
} online_mode_t;

/* The modes, ending with a {NULL, NULL, NULL} entry. */
extern const online_mode_t online_modes[];

#endif /* PGEM_ONLINE_H */
