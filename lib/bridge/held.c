/* The files the bridge holds (issue 31): what its journal's replay skipped, which journal
 * records without a checksum hold a message the bridge takes, the periodic look that the
 * journal is still where a restart finds it, and SNAPSHOT's refusal of a name that is the
 * journal or the file its output goes to. Reception thread (and start). */
#define _POSIX_C_SOURCE 200809L
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "bridge_internal.h"

void bridge_journal_damage(bridge_t *bridge, const pgem_journal_info_t *info)
{
    const char *path = bridge->options.journal;
    for (int64_t i = 0; i < info->skipped && i < PGEM_JOURNAL_DAMAGE_LISTED; ++i) {
        bridge_log(bridge, "journal %s: skipped damaged bytes %lld-%lld (%lld bytes; %s), left "
                   "in place; the records after them replayed", path,
                   (long long)info->damage[i].start, (long long)info->damage[i].end,
                   (long long)(info->damage[i].end - info->damage[i].start),
                   info->damage[i].why);
    }
    if (info->skipped > PGEM_JOURNAL_DAMAGE_LISTED) {
        bridge_log(bridge, "journal %s: and %lld more damaged stretches", path,
                   (long long)(info->skipped - PGEM_JOURNAL_DAMAGE_LISTED));
    }
    char damage[200] = "";
    if (info->skipped > 0) {
        snprintf(damage, sizeof damage, "skipped %lld damaged bytes in %lld place%s (the first "
                 "at bytes %lld-%lld: %s), left in place", (long long)info->skipped_bytes,
                 (long long)info->skipped, info->skipped > 1 ? "s" : "",
                 (long long)info->damage[0].start, (long long)info->damage[0].end,
                 info->damage[0].why);
    }
    if (info->torn_bytes > 0) {
        bridge_note(bridge, "journal %s: cut %lld bytes of a torn last record%s%s", path,
                    (long long)info->torn_bytes, damage[0] != '\0' ? "; " : "", damage);
    } else if (damage[0] != '\0') {
        bridge_note(bridge, "journal %s: %s", path, damage);
    }
}

int bridge_journal_recognise(void *user, const char *channel, const void *data, size_t size)
{
    const bridge_t *bridge = user;
    const pgem_channels_t *c = &bridge->options.channels;
    pgem_role_t role = pgem_ingest_wire_role(data, size);
    if (role == PGEM_ROLE_ANY) {
        return 0;
    }
    if (strcmp(channel, c->pose) == 0) {
        return role == PGEM_ROLE_POSE;
    }
    if (strcmp(channel, c->edge) == 0) {
        return role == PGEM_ROLE_EDGE;
    }
    if (strcmp(channel, c->command) == 0) {
        return role == PGEM_ROLE_COMMAND;
    }
    return 1; /* a journal written under another --channel-prefix */
}

void bridge_journal_watch(bridge_t *bridge, int *away)
{
    char message[512];
    if (bridge->reception.journal == NULL) {
        return;
    }
    int now = pgem_journal_check(bridge->reception.journal, message, sizeof message) != 0;
    if (now && !*away) {
        bridge_note(bridge, "journal: %s; nothing is accepted meanwhile", message);
    } else if (!now && *away) {
        bridge_note(bridge, "journal %s is in place again: accepting", bridge->options.journal);
    }
    *away = now;
}

/* What a SNAPSHOT of `name` would replace that the bridge holds: its journal, or the file its
 * standard output or error goes to; "" when nothing. */
static const char *held(const bridge_t *bridge, const char *name)
{
    if (bridge->reception.journal != NULL &&
        pgem_journal_is_named(bridge->reception.journal, bridge->snapshot_dir, name)) {
        return "the bridge's journal";
    }
    struct stat target;
    if (fstatat(bridge->snapshot_dir, name, &target, AT_SYMLINK_NOFOLLOW) != 0) {
        return "";
    }
    static const char *const streams[3] = {"", "the bridge's standard output",
                                           "the bridge's standard error"};
    for (int fd = 1; fd <= 2; ++fd) {
        struct stat st;
        if (fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_dev == target.st_dev &&
            st.st_ino == target.st_ino) {
            return streams[fd];
        }
    }
    return "";
}

/* The SNAPSHOTs accepted in the last minute, and their bytes; older ones leave the ring. */
static uint64_t snapshots_recent(bridge_t *bridge, double now)
{
    const uint32_t limit = bridge->options.snapshot_limit;
    while (bridge->handoff.snapshots.count > 0 &&
           now - bridge->handoff.snapshots.ring[bridge->handoff.snapshots.first].accepted >=
               BRIDGE_SNAPSHOT_PERIOD) {
        bridge->handoff.snapshots.first = (bridge->handoff.snapshots.first + 1) % limit;
        bridge->handoff.snapshots.count--;
    }
    uint64_t bytes = 0;
    for (uint32_t k = 0; k < bridge->handoff.snapshots.count; ++k) {
        bytes +=
            bridge->handoff.snapshots.ring[(bridge->handoff.snapshots.first + k) % limit].bytes;
    }
    return bytes;
}

/* SNAPSHOT's bounds: at most --snapshot-limit accepted in any minute, and none that would take
 * the bytes snapshots wrote in the last minute past --snapshot-budget (the next one is taken
 * to be as large as the last). 0 and the request counted, or -1 with the reason. */
static int snapshot_allowed(bridge_t *bridge, const char *name, char *message,
                            size_t message_size)
{
    const pgem_bridge_options_t *o = &bridge->options;
    const double now = bridge_now();
    const uint64_t bytes = snapshots_recent(bridge, now);
    const double budget = o->snapshot_budget * 1048576.0;
    const double wait =
        bridge->handoff.snapshots.count > 0
            ? BRIDGE_SNAPSHOT_PERIOD -
                  (now - bridge->handoff.snapshots.ring[bridge->handoff.snapshots.first].accepted)
            : 0.0;
    if (bridge->handoff.snapshots.count >= o->snapshot_limit) {
        snprintf(message, message_size,
                 "SNAPSHOT %s refused: %u snapshots in the last minute (--snapshot-limit %u "
                 "per minute); the next is allowed in %.1f s", name,
                 (unsigned)bridge->handoff.snapshots.count, (unsigned)o->snapshot_limit, wait);
        return -1;
    }
    if (bridge->handoff.snapshots.count > 0 &&
        (double)(bytes + bridge->handoff.snapshots.last_size) > budget) {
        snprintf(message, message_size,
                 "SNAPSHOT %s refused: snapshots wrote %.1f MiB in the last minute and the "
                 "last took %.1f MiB, past --snapshot-budget %g MiB per minute; the next is "
                 "allowed in %.1f s at the latest", name, (double)bytes / 1048576.0,
                 (double)bridge->handoff.snapshots.last_size / 1048576.0, o->snapshot_budget, wait);
        return -1;
    }
    const uint32_t entry =
        (bridge->handoff.snapshots.first + bridge->handoff.snapshots.count) % o->snapshot_limit;
    bridge->handoff.snapshots.ring[entry].accepted = now;
    bridge->handoff.snapshots.ring[entry].bytes = 0;
    bridge->handoff.snapshots.count++;
    bridge->handoff.snapshots.latest = entry;
    return 0;
}

void bridge_snapshot_written(bridge_t *bridge, uint64_t bytes)
{
    bridge->handoff.snapshots.last_size = bytes;
    /* the entry of the request written, if it is still in the window */
    const uint32_t limit = bridge->options.snapshot_limit;
    const uint32_t from_first =
        (bridge->handoff.snapshots.latest + limit - bridge->handoff.snapshots.first) % limit;
    if (from_first < bridge->handoff.snapshots.count) {
        bridge->handoff.snapshots.ring[bridge->handoff.snapshots.latest].bytes = bytes;
    }
}

int bridge_snapshot_check(void *user, const char *name, char *message, size_t message_size)
{
    bridge_t *bridge = user;
    char weights[PGEM_SNAPSHOT_NAME_MAX + 16];
    snprintf(weights, sizeof weights, "%s.weights", name);
    const char *targets[2] = {name, weights};
    for (int i = 0; i < 2; ++i) {
        const char *what = held(bridge, targets[i]);
        if (what[0] != '\0') {
            snprintf(message, message_size,
                     "SNAPSHOT %s refused: %s/%s is %s, which the snapshot would replace; "
                     "choose another name", name, bridge->options.snapshot_dir, targets[i],
                     what);
            return -1;
        }
    }
    return snapshot_allowed(bridge, name, message, message_size);
}
