/* The bridge's reception thread (the thread that calls pgem_bridge_run): LCM's handlers feed
 * each message to the ingest (ingest.h), journal what it admits (journal.h) and queue the
 * items for the solver thread (handoff.h); it also publishes the periodic status and watches
 * the files the bridge holds. Its own state is below; only this thread (and the start, before
 * the solver thread exists) touches it. */
#ifndef PGEM_BRIDGE_RECEPTION_H
#define PGEM_BRIDGE_RECEPTION_H

#include <stddef.h>
#include <stdint.h>

#include <lcm/lcm.h>

#include "handoff.h"
#include "ingest.h"
#include "journal.h"

typedef struct bridge_reception {
    pgem_journal_t *journal;
    const char *channel;       /* the message being handled: its channel and receive time, */
    int64_t utime;             /* for the journal record the admit hook writes */
    int64_t replay_refused[PGEM_REJECT_COUNT]; /* journal records refused on replay, by reason */
    char replay_first[384];    /* the first of them, in words */
    int64_t rejections_logged;
    int64_t expiries_logged;
    int64_t odometry_notes_logged; /* edges sent as ODOMETRY that entered as loops */
} bridge_reception_t;

/* reception.c. At start: the ingest and the queue for the capacities (0, or -1 with message);
 * then, with a journal, its replay through the ingest (refused when its records do not fit
 * the bridge) and the admit hook that journals every later change. */
int bridge_reception_init(bridge_t *bridge, char *message, size_t message_size);
int bridge_reception_open_journal(bridge_t *bridge, char *message, size_t message_size);
/* LCM's handler for the pose, edge and command channels. */
void bridge_reception_message(const lcm_recv_buf_t *buffer, const char *channel, void *user);
/* Expires what has waited too long by now, for a bridge that receives nothing (the ingest
 * does it at every message otherwise). */
void bridge_reception_expire(bridge_t *bridge);
void bridge_reception_free(bridge_t *bridge);

/* held.c: the files the bridge holds. */
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
/* The ingest's SNAPSHOT hook (lock held): refuses a NAME whose NAME or NAME.weights in the
 * snapshot folder is the journal or the file the bridge's standard output or error goes to,
 * or one past SNAPSHOT's bounds; else counts it. */
int bridge_snapshot_check(void *user, const char *name, char *message, size_t message_size);
/* (Solver thread, lock held) After a snapshot was written: the bytes it took, for the
 * budget. */
void bridge_snapshot_written(bridge_t *bridge, uint64_t bytes);

#endif /* PGEM_BRIDGE_RECEPTION_H */
