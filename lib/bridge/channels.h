/* LCM channel names of the bridge and its tools. Every name is PREFIX + a fixed suffix; the
 * default prefix is "PGEM_", so the defaults are PGEM_POSE2, PGEM_EDGE2, PGEM_POSE3,
 * PGEM_EDGE3, PGEM_GRAPH, PGEM_STATUS, PGEM_COMMAND, PGEM_COMPACTION, PGEM_COVARIANCE and
 * PGEM_TEAM. Each
 * can also be set alone. */
#ifndef PGEM_BRIDGE_CHANNELS_H
#define PGEM_BRIDGE_CHANNELS_H

#define PGEM_CHANNEL_PREFIX_DEFAULT "PGEM_"
#define PGEM_CHANNEL_MAX 128 /* bytes of a channel name, NUL included (LCM allows 63 chars) */

typedef struct pgem_channels {
    char pose[PGEM_CHANNEL_MAX];    /* pgem.pose2_t or pgem.pose3_t (by dimension) */
    char edge[PGEM_CHANNEL_MAX];    /* pgem.edge2_t or pgem.edge3_t */
    char graph[PGEM_CHANNEL_MAX];   /* pgem.graph_t, published after every solve */
    char status[PGEM_CHANNEL_MAX];  /* pgem.status_t */
    char command[PGEM_CHANNEL_MAX]; /* pgem.command_t */
    char compaction[PGEM_CHANNEL_MAX]; /* pgem.compaction_t, published after each compaction */
    char covariance[PGEM_CHANNEL_MAX]; /* pgem.covariance_t, published after each graph */
    char team[PGEM_CHANNEL_MAX];    /* pgem.team_t, published right after each graph */
} pgem_channels_t;

/* Fills every name from a prefix (NULL means the default) for a dimension (2 or 3).
 * Returns 0, or -1 when a name would be longer than LCM's 63 characters. */
int pgem_channels_init(pgem_channels_t *channels, const char *prefix, int dimension);

/* Sets one name (e.g. from --graph-channel); -1 when empty or longer than 63 characters. */
int pgem_channel_set(char *name, const char *value);

#endif /* PGEM_BRIDGE_CHANNELS_H */
