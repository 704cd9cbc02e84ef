/* The reception thread: LCM's handler feeds each message to the ingest under the lock, the
 * admit hook journals what would change the graph, the items it emits join the queue, and the
 * counters the status reports are copied once the message is handled to the end. Also the
 * journal's replay at start. */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bridge_internal.h"
#include "pgem_command_t.h"

#define REJECTIONS_LOGGED 20      /* then one line per 1000 */

/* ---- the queue (lock held) ---------------------------------------------------------------- */

static void emit(void *user, const pgem_item_t *item)
{
    bridge_t *bridge = user;
    bridge_handoff_t *const h = &bridge->handoff;
    if (h->queue.tail - h->queue.head >= h->queue.capacity) {
        h->queue.overflows++; /* cannot happen: capacity is reserved on admission */
        return;
    }
    h->queue.items[h->queue.tail % h->queue.capacity] = *item;
    h->queue.tail++;
}

/* ---- start and end ------------------------------------------------------------------------ */

int bridge_reception_init(bridge_t *bridge, char *message, size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    /* With --compact the graph never holds more than 90 % of the capacities (the solver thread
     * compacts as it adds), so what waits in the queue may go past them: the reception thread
     * admits up to half as much again, room for a solver thread that falls behind a burst
     * (a loaded or slow machine) without refusing poses for capacity. */
    const uint32_t admit_poses = o->compact ? o->max_poses + o->max_poses / 2u : o->max_poses;
    const uint32_t admit_edges = o->compact ? o->max_edges + o->max_edges / 2u : o->max_edges;
    pgem_ingest_config_t ingest_config = {o->dimension, admit_poses, admit_edges,
                                          o->max_pending, o->max_sources,
                                          (int64_t)(o->pending_timeout * 1e6),
                                          o->snapshot_dir != NULL, o->compact};
    bridge_handoff_t *h = &bridge->handoff;
    h->ingest = pgem_ingest_create(&ingest_config, emit, bridge);
    h->queue.capacity = (uint64_t)admit_poses + admit_edges + BRIDGE_BATCH;
    h->queue.items = calloc((size_t)h->queue.capacity, sizeof *h->queue.items);
    if (h->ingest == NULL || h->queue.items == NULL) {
        snprintf(message, message_size, "out of memory for %u poses and %u edges",
                 (unsigned)o->max_poses, (unsigned)o->max_edges);
        return -1;
    }
    return 0;
}

void bridge_reception_free(bridge_t *bridge)
{
    pgem_journal_close(bridge->reception.journal);
    pgem_ingest_destroy(bridge->handoff.ingest);
    free(bridge->handoff.queue.items);
}

/* ---- messages ------------------------------------------------------------------------------ */

static pgem_role_t role_of_channel(const bridge_t *bridge, const char *channel)
{
    const pgem_channels_t *c = &bridge->options.channels;
    if (strcmp(channel, c->pose) == 0) {
        return PGEM_ROLE_POSE;
    }
    if (strcmp(channel, c->edge) == 0) {
        return PGEM_ROLE_EDGE;
    }
    return PGEM_ROLE_COMMAND;
}

static void log_rejection(bridge_t *bridge, const pgem_ingest_result_t *result)
{
    bridge->reception.rejections_logged++;
    if (bridge->reception.rejections_logged <= REJECTIONS_LOGGED) {
        bridge_log(bridge, "rejected (%s): %s", pgem_reject_name(result->reason),
                   result->message);
    } else if (bridge->reception.rejections_logged % 1000 == 0) {
        bridge_log(bridge, "%lld messages rejected so far (latest, %s: %s)",
                   (long long)bridge->reception.rejections_logged, pgem_reject_name(result->reason),
                   result->message);
    }
}

/* The ingest's admit hook: a message that would change the graph is journaled before anything
 * changes, so what the status acknowledges is always in the journal, and a message the journal
 * cannot take (a full disk, an I/O error) is refused and changes nothing: the front-end's
 * resend is accepted once the journal has room. Called from pgem_ingest_message with the lock
 * held; the write runs without it, `admitting` set: the solver thread may read the ingest
 * meanwhile (source names, a removed pose's anchor), but what it would change (a compaction's
 * removed poses) waits for the message to be done. */
static int journal_admit(void *user, const void *data, size_t size, char *message,
                         size_t message_size)
{
    bridge_t *bridge = user;
    bridge_handoff_t *const h = &bridge->handoff;
    const bridge_reception_t *r = &bridge->reception;
    h->admitting = 1;
    pthread_mutex_unlock(&h->lock);
    int status = pgem_journal_append(r->journal, r->channel, data, size, r->utime, message,
                                     message_size);
    pthread_mutex_lock(&h->lock);
    h->admitting = 0;
    return status;
}

/* Edges that expired (waited too long for their poses, or made room in a full list), from
 * count `before` to `after`: the latest is noted while fewer than 20 have expired, then once
 * per thousand, like rejections. */
static void log_expiries(bridge_t *bridge, int64_t before, int64_t after, const char *latest)
{
    if (after <= before) {
        return;
    }
    int64_t first = bridge->reception.expiries_logged + 1;
    bridge->reception.expiries_logged += after - before;
    int64_t last = bridge->reception.expiries_logged;
    if (first <= REJECTIONS_LOGGED || last / 1000 > (first - 1) / 1000) {
        bridge_note(bridge, "%s%s", latest, after - before > 1 ? " (and earlier ones)" : "");
    }
}

/* Edges sent as ODOMETRY that entered the graph as loop closures (not a step of the chain),
 * from count `before` to `after`: noted (status and log) while fewer than 20 have, then once
 * per thousand. */
static void log_odometry_notes(bridge_t *bridge, int64_t before, int64_t after,
                               const char *latest)
{
    if (after <= before) {
        return;
    }
    int64_t first = bridge->reception.odometry_notes_logged + 1;
    bridge->reception.odometry_notes_logged += after - before;
    int64_t last = bridge->reception.odometry_notes_logged;
    if (first <= REJECTIONS_LOGGED || last / 1000 > (first - 1) / 1000) {
        bridge_note(bridge, "%s (%lld so far)", latest, (long long)last);
    }
}

/* Takes the lock. */
void bridge_reception_expire(bridge_t *bridge)
{
    bridge_handoff_t *const h = &bridge->handoff;
    char latest[sizeof h->last_message] = "";
    pthread_mutex_lock(&h->lock);
    int64_t before = h->counts.rejected[PGEM_REJECT_EXPIRED];
    if (pgem_ingest_expire(h->ingest, bridge_utime()) > 0) {
        pgem_ingest_counts(h->ingest, &h->counts);
        snprintf(latest, sizeof latest, "%s", pgem_ingest_last_expiry(h->ingest));
    }
    int64_t after = h->counts.rejected[PGEM_REJECT_EXPIRED];
    pthread_mutex_unlock(&h->lock);
    log_expiries(bridge, before, after, latest);
}

void bridge_reception_message(const lcm_recv_buf_t *buffer, const char *channel, void *user)
{
    bridge_t *bridge = user;
    bridge_handoff_t *const h = &bridge->handoff;
    pgem_ingest_result_t result;
    pgem_role_t role = role_of_channel(bridge, channel);
    char latest[sizeof h->last_message] = "";
    char odometry_note[sizeof h->last_message] = "";
    pthread_mutex_lock(&h->lock);
    int64_t expired = h->counts.rejected[PGEM_REJECT_EXPIRED];
    int64_t as_loops = h->counts.odometry_as_loops;
    bridge->reception.channel = channel;
    bridge->reception.utime = buffer->recv_utime;
    pgem_ingest_message(h->ingest, role, buffer->data, buffer->data_size,
                        buffer->recv_utime, &result);
    h->queue.visible = h->queue.tail;
    pgem_ingest_counts(h->ingest, &h->counts);
    if (bridge->reception.journal != NULL) {
        h->journal_records = pgem_journal_records(bridge->reception.journal);
    }
    if (h->counts.rejected[PGEM_REJECT_EXPIRED] > expired) {
        snprintf(latest, sizeof latest, "%s", pgem_ingest_last_expiry(h->ingest));
    }
    int64_t as_loops_now = h->counts.odometry_as_loops;
    if (as_loops_now > as_loops) {
        snprintf(odometry_note, sizeof odometry_note, "%s",
                 pgem_ingest_last_odometry_note(h->ingest));
    }
    if (result.verdict == PGEM_VERDICT_REJECTED) {
        snprintf(h->last_message, sizeof h->last_message, "rejected (%s): %.340s",
                 pgem_reject_name(result.reason), result.message);
    } else if (result.verdict == PGEM_VERDICT_COMMAND) {
        if (result.command == PGEM_COMMAND_T_OPTIMIZE) {
            h->requests.optimize = 1;
            h->requests.optimize_commands++;
        } else if (result.command == PGEM_COMMAND_T_SNAPSHOT) {
            h->requests.snapshot = 1;
            memcpy(h->requests.snapshot_path, result.path, sizeof h->requests.snapshot_path);
        }
    }
    pthread_cond_signal(&h->wake);
    int64_t expired_now = h->counts.rejected[PGEM_REJECT_EXPIRED];
    pthread_mutex_unlock(&h->lock);

    log_expiries(bridge, expired, expired_now, latest);
    log_odometry_notes(bridge, as_loops, as_loops_now, odometry_note);
    if (result.verdict == PGEM_VERDICT_REJECTED) {
        log_rejection(bridge, &result);
    } else if (result.verdict == PGEM_VERDICT_COMMAND) {
        static const char *const names[] = {"", "OPTIMIZE", "RESET", "SNAPSHOT"};
        bridge_log(bridge, "command %s%s%s", names[result.command],
                   result.path[0] != '\0' ? " " : "", result.path);
    }
}

/* A journal record, replayed at start through the same ingest (no admit hook: it is in the
 * journal). Refusals are counted by reason and the first 20 logged; start() decides. */
static void on_journal_record(void *user, const char *channel, const void *data, size_t size,
                              int64_t utime)
{
    (void)channel;
    bridge_t *bridge = user;
    pgem_ingest_result_t result;
    pgem_ingest_message(bridge->handoff.ingest, PGEM_ROLE_ANY, data, size, utime, &result);
    if (result.verdict != PGEM_VERDICT_REJECTED) {
        return;
    }
    int64_t refused = 0;
    for (int r = 0; r < PGEM_REJECT_COUNT; ++r) {
        refused += bridge->reception.replay_refused[r];
    }
    bridge->reception.replay_refused[result.reason]++;
    if (refused == 0) {
        snprintf(bridge->reception.replay_first, sizeof bridge->reception.replay_first,
                 "%s: %.320s", pgem_reject_name(result.reason), result.message);
    }
    if (refused < REJECTIONS_LOGGED) {
        bridge_log(bridge, "journal record refused on replay (%s): %s",
                   pgem_reject_name(result.reason), result.message);
    }
}

/* After the journal's replay: its records refused for the bridge's dimension or capacities
 * mean the options differ from the ones the journal was written with, and starting would drop
 * part of the map, so the start fails (the journal is left as it is). Other refusals (messages
 * a front-end got wrong, in an lcm-logger recording used as a seed) are counted and named. */
static int journal_report(bridge_t *bridge, const pgem_journal_info_t *info, char *message,
                          size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    const int64_t *refused = bridge->reception.replay_refused;
    int64_t total = 0;
    char reasons[512] = "";
    for (int r = 0; r < PGEM_REJECT_COUNT; ++r) {
        if (refused[r] > 0) {
            size_t used = strlen(reasons);
            snprintf(reasons + used, sizeof reasons - used, "%s%s %lld", used > 0 ? ", " : "",
                     pgem_reject_name((pgem_reject_t)r), (long long)refused[r]);
            total += refused[r];
        }
    }
    if (refused[PGEM_REJECT_CAPACITY] > 0 || refused[PGEM_REJECT_DIMENSION] > 0) {
        snprintf(message, message_size,
                 "journal %s: %lld of its %lld records do not fit this bridge (%s; the first, "
                 "%s): start it with the --dimension, --max-poses and --max-edges the journal "
                 "was written with, or with a new journal (this one is left as it is)",
                 o->journal, (long long)total, (long long)info->records, reasons,
                 bridge->reception.replay_first);
        return -1;
    }
    const pgem_ingest_counts_t counts = bridge->handoff.counts;
    bridge_log(bridge, "journal %s: %lld records replayed (%lld poses, %lld edges), %lld with a "
               "checksum", o->journal, (long long)(info->records - total),
               (long long)counts.accepted_poses, (long long)counts.accepted_edges,
               (long long)info->checked);
    if (counts.odometry_as_loops > 0) {
        bridge_log(bridge, "journal %s: %lld edges sent as ODOMETRY entered as loop closures "
                   "(not a step of the chain; the latest: %s)", o->journal,
                   (long long)counts.odometry_as_loops,
                   pgem_ingest_last_odometry_note(bridge->handoff.ingest));
    }
    if (total > 0) {
        bridge_note(bridge, "journal %s: %lld more records refused on replay (%s)", o->journal,
                    (long long)total, reasons);
    }
    bridge_journal_damage(bridge, info);
    return 0;
}

int bridge_reception_open_journal(bridge_t *bridge, char *message, size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    pgem_journal_info_t info;
    bridge->reception.journal = pgem_journal_open(o->journal, o->journal_sync, on_journal_record,
                                        bridge_journal_recognise, bridge, &info, message,
                                        message_size);
    if (bridge->reception.journal == NULL) {
        return -1;
    }
    bridge->handoff.recovered = info.records;
    bridge->handoff.queue.visible = bridge->handoff.queue.tail;
    bridge->handoff.requests.recovery = info.records > 0;
    pgem_ingest_counts(bridge->handoff.ingest, &bridge->handoff.counts);
    bridge->handoff.journal_records = info.records;
    if (journal_report(bridge, &info, message, message_size) != 0) {
        return -1;
    }
    pgem_ingest_set_admit(bridge->handoff.ingest, journal_admit, bridge);
    return 0;
}

