/* Status messages and the bridge's log. */
#define _POSIX_C_SOURCE 200809L
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "bridge_internal.h"
#include "pgem_status_t.h"

double bridge_now(void)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

int64_t bridge_utime(void)
{
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    return (int64_t)now.tv_sec * 1000000 + now.tv_nsec / 1000;
}

static void vlog(bridge_t *bridge, const char *format, va_list args)
{
    if (bridge->options.log != NULL) {
        char line[1024];
        vsnprintf(line, sizeof line, format, args);
        bridge->options.log(bridge->options.log_user, line);
    }
}

void bridge_log(bridge_t *bridge, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    vlog(bridge, format, args);
    va_end(args);
}

void bridge_note(bridge_t *bridge, const char *format, ...)
{
    char text[sizeof bridge->handoff.last_message];
    va_list args;
    va_start(args, format);
    vsnprintf(text, sizeof text, format, args);
    va_end(args);
    pthread_mutex_lock(&bridge->handoff.lock);
    memcpy(bridge->handoff.last_message, text, sizeof text);
    pthread_mutex_unlock(&bridge->handoff.lock);
    bridge_log(bridge, "%s", text);
}

int bridge_stopping(bridge_t *bridge)
{
    pthread_mutex_lock(&bridge->handoff.lock);
    const int stopping = bridge->handoff.stopping;
    pthread_mutex_unlock(&bridge->handoff.lock);
    return stopping;
}

void bridge_publish_status(bridge_t *bridge)
{
    char *reasons[PGEM_REJECT_COUNT];
    int64_t rejected[PGEM_REJECT_COUNT];
    char message[sizeof bridge->handoff.last_message];
    pgem_status_t status;
    memset(&status, 0, sizeof status);
    pgem_ingest_counts_t counts;

    pthread_mutex_lock(&bridge->handoff.lock);
    counts = bridge->handoff.counts;
    status.queued = (int32_t)(bridge->handoff.queue.tail - bridge->handoff.queue.head);
    status.poses = bridge->handoff.graph.poses;
    status.edges = bridge->handoff.graph.edges;
    status.loops = bridge->handoff.graph.loops;
    status.pruned = bridge->handoff.graph.pruned;
    status.solves = bridge->handoff.graph.solves;
    status.solving = (int8_t)bridge->handoff.graph.solving;
    status.recovered = bridge->handoff.recovered;
    status.journal_records = bridge->handoff.journal_records;
    counts.rejected[PGEM_REJECT_CORE] +=
        bridge->handoff.graph.core_rejections + bridge->handoff.queue.overflows;
    counts.rejected[PGEM_REJECT_FULL] += bridge->handoff.graph.full_rejections;
    memcpy(message, bridge->handoff.last_message, sizeof message);
    pthread_mutex_unlock(&bridge->handoff.lock);

    for (int r = 0; r < PGEM_REJECT_COUNT; ++r) {
        /* lcm-gen's struct wants char *; the encoder only reads the names */
        reasons[r] = (char *)(uintptr_t)pgem_reject_name((pgem_reject_t)r); // NOLINT(performance-no-int-to-ptr)
        rejected[r] = counts.rejected[r];
    }
    status.utime = bridge_utime();
    status.dimension = (int8_t)bridge->options.dimension;
    status.received = counts.received;
    status.accepted_poses = counts.accepted_poses;
    status.accepted_edges = counts.accepted_edges;
    status.replays = counts.replays;
    status.num_reasons = PGEM_REJECT_COUNT;
    status.reasons = reasons;
    status.rejected = rejected;
    status.pending = (int32_t)counts.pending;
    status.max_poses = (int32_t)bridge->options.max_poses;
    status.max_edges = (int32_t)bridge->options.max_edges;
    status.max_pending = (int32_t)bridge->options.max_pending;
    status.commands = counts.commands;
    status.message = message;

    unsigned char buffer[8192];
    int size = pgem_status_t_encoded_size(&status);
    if (size > 0 && (size_t)size <= sizeof buffer &&
        pgem_status_t_encode(buffer, 0, size, &status) == size) {
        lcm_publish(bridge->lcm, bridge->options.channels.status, buffer, (unsigned)size);
    }
}
