/* The files the bridge holds (issue 31): what its journal's replay skipped, which journal
 * records without a checksum hold a message the bridge takes, and the periodic look that the
 * journal is still where a restart finds it. Reception thread (and start). */
#define _POSIX_C_SOURCE 200809L
#include <stdio.h>
#include <string.h>

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
    if (bridge->journal == NULL) {
        return;
    }
    int now = pgem_journal_check(bridge->journal, message, sizeof message) != 0;
    if (now && !*away) {
        bridge_note(bridge, "journal: %s; nothing is accepted meanwhile", message);
    } else if (!now && *away) {
        bridge_note(bridge, "journal %s is in place again: accepting", bridge->options.journal);
    }
    *away = now;
}
