/* LCM channel names from a prefix. */
#include "channels.h"

#include <stdio.h>
#include <string.h>

#define PGEM_LCM_CHANNEL_LIMIT 63 /* LCM refuses longer channel names */

int pgem_channel_set(char *name, const char *value)
{
    size_t length = strlen(value);
    if (length == 0 || length > PGEM_LCM_CHANNEL_LIMIT) {
        return -1;
    }
    memcpy(name, value, length + 1);
    return 0;
}

static int join(char *name, const char *prefix, const char *suffix)
{
    char joined[PGEM_CHANNEL_MAX * 2];
    snprintf(joined, sizeof joined, "%s%s", prefix, suffix);
    return pgem_channel_set(name, joined);
}

int pgem_channels_init(pgem_channels_t *channels, const char *prefix, int dimension)
{
    if (prefix == NULL) {
        prefix = PGEM_CHANNEL_PREFIX_DEFAULT;
    }
    if (strlen(prefix) >= PGEM_CHANNEL_MAX) {
        return -1;
    }
    int status = 0;
    status |= join(channels->pose, prefix, dimension == 3 ? "POSE3" : "POSE2");
    status |= join(channels->edge, prefix, dimension == 3 ? "EDGE3" : "EDGE2");
    status |= join(channels->graph, prefix, "GRAPH");
    status |= join(channels->status, prefix, "STATUS");
    status |= join(channels->command, prefix, "COMMAND");
    status |= join(channels->compaction, prefix, "COMPACTION");
    status |= join(channels->covariance, prefix, "COVARIANCE");
    status |= join(channels->team, prefix, "TEAM");
    return status == 0 ? 0 : -1;
}
