/* A running bridge: what every thread may read (fixed at start), the hand-off the reception
 * and solver threads share under its lock (handoff.h), and each thread's own state
 * (reception.h, solver.h). docs/design/bridge-threads.md maps every field to its thread. */
#ifndef PGEM_BRIDGE_INTERNAL_H
#define PGEM_BRIDGE_INTERNAL_H

#include <lcm/lcm.h>

#include "bridge.h"
#include "handoff.h"
#include "reception.h"
#include "solver.h"

struct bridge {
    /* Fixed at start, before the solver thread exists: every thread reads them. */
    pgem_bridge_options_t options;
    lcm_t *lcm;                /* (LCM's own lock orders publishing against reception) */
    int snapshot_dir;          /* open folder for SNAPSHOT, -1 none */

    bridge_handoff_t handoff;  /* under handoff.lock */
    bridge_reception_t reception; /* the reception thread's */
    bridge_solver_t solver;    /* the solver thread's */
};

/* status.c (either thread). */
/* Monotonic seconds and wall-clock microseconds. */
double bridge_now(void);
int64_t bridge_utime(void);

/* Formats a line and hands it to the log callback. */
void bridge_log(bridge_t *bridge, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* Publishes status_t from the hand-off (takes the lock). */
void bridge_publish_status(bridge_t *bridge);
/* Sets the status's message (the lock must NOT be held) and logs it. */
void bridge_note(bridge_t *bridge, const char *format, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
/* Whether the bridge is stopping (takes the lock). */
int bridge_stopping(bridge_t *bridge);

#endif /* PGEM_BRIDGE_INTERNAL_H */
