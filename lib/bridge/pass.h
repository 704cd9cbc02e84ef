/* The live EM pass of an incremental bridge: whole-graph EM on a copy of the graph, in a block
 * of its own sized at start, on a thread of its own, while the solver thread goes on with
 * incremental updates; the solver thread adopts its result (pgem_update_adopt). */
#ifndef PGEM_BRIDGE_PASS_H
#define PGEM_BRIDGE_PASS_H

#include <pthread.h>
#include <signal.h>
#include <stdint.h>

#include "pgem/pgem.h"

typedef enum bridge_pass_state {
    BRIDGE_PASS_IDLE = 0,    /* the copy is the solver thread's to fill */
    BRIDGE_PASS_RUNNING = 1, /* the pass thread solves the copy */
    BRIDGE_PASS_DONE = 2     /* solved: the solver thread adopts it (or drops it) */
} bridge_pass_state_t;

typedef struct bridge_pass {
    pgem_config_t config;
    void *block;
    size_t block_size;
    pgem_t *core;                  /* the copy */
    uint8_t *has_edge;             /* per pose of the copy: an edge touches it (else held) */
    pgem_robust_options_t robust;  /* EM as the settle runs it */
    pthread_t thread;
    int thread_started;
    /* Guarded by the bridge's lock (the `lock` given to bridge_pass_start / _stop). */
    pthread_mutex_t *lock;
    pthread_cond_t *done_wake;     /* the solver's condition: signalled when a pass is done */
    pthread_cond_t wake;           /* the pass thread waits on it */
    int state;                     /* bridge_pass_state_t */
    int quit;
    volatile sig_atomic_t cancel;          /* read by the solve's round callback: stop now */
    /* Set by the solver thread before RUNNING, read by it after DONE. */
    uint64_t generation;           /* the bridge's graph generation at the copy */
    double started;                /* when the copy was taken */
    double took;                   /* copy to done, s */
    double solve_took;             /* the solve alone, s */
    int status;                    /* the solve's */
    pgem_robust_summary_t summary;
    uint32_t loops_at_copy;        /* loop closures the copy holds */
    uint64_t passes;               /* ended and adopted so far */
} bridge_pass_t;

/* Sizes the copy's block for the live instance's capacities (no incremental factor) and
 * starts the pass thread. 0, or -1 with message. */
int bridge_pass_init(bridge_pass_t *pass, const pgem_config_t *live, const pgem_robust_options_t *robust,
                     pthread_mutex_t *lock, pthread_cond_t *done_wake, char *message,
                     size_t message_size);
/* Stops the thread (a pass under way is cancelled) and frees the block. */
void bridge_pass_free(bridge_pass_t *pass);
/* Solver thread, lock held or not: the state (takes the lock). */
int bridge_pass_state(bridge_pass_t *pass);
/* Solver thread, IDLE: copies `live` (the front-end's estimates `raw`, or the live estimate
 * when raw is NULL, pose_size doubles per
 * pose, as the starting point, what batch EM starts from) and hands it to the pass thread.
 * 0, or -1 if the copy failed (the message is the core's). */
int bridge_pass_start(bridge_pass_t *pass, const pgem_t *live, const double *raw,
                      uint64_t generation, double now);
/* Solver thread, DONE: back to IDLE (after adopting or dropping it). */
void bridge_pass_release(bridge_pass_t *pass);

#endif /* PGEM_BRIDGE_PASS_H */
