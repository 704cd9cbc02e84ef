/* A test program of the LCM fault tests: what a hostile (or broken) peer sends on a 2D
 * bridge's channels, beyond single malformed messages (lcm_malformed):
 *
 *   lcm_hostile pending COUNT RATE SOURCE [SOURCES]
 *       COUNT well-formed edges to poses that never come (ids from 1e12 on), from SOURCE, or
 *       from SOURCES names SOURCE-0 .. SOURCE-(SOURCES-1) in turn, at RATE per second (0: as
 *       fast as possible): each is accepted to wait, and must expire.
 *   lcm_hostile snapshot NAME
 *       one SNAPSHOT command with NAME as its path.
 *   lcm_hostile snapshots PREFIX COUNT RATE
 *       COUNT SNAPSHOT commands named PREFIX-0 .. PREFIX-(COUNT-1), at RATE per second.
 *   lcm_hostile optimize COUNT RATE
 *       COUNT OPTIMIZE commands at RATE per second.
 *   lcm_hostile odometry SOURCE FROM TO X Y THETA
 *       one edge of kind ODOMETRY from SOURCE (sequence 0) between poses FROM and TO with the
 *       measurement X Y THETA and a confident information (1e4 on the diagonal): a front-end
 *       vouching for a false step.
 *   lcm_hostile graph
 *       a graph_t on PGEM_GRAPH and a status_t on PGEM_STATUS as a rogue publisher could send
 *       them: names that are not UTF-8 or hold control bytes, a NaN and an infinite chi2 (what
 *       pgem-lcm-dump must still write as valid JSON and log escaped).
 *
 * On LCM_DEFAULT_URL, default channel names. Prints "sent N". Exit 0, 1 when LCM fails, 2 on
 * a bad command line. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <lcm/lcm.h>

#include "test_clock.h"

#include "channels.h"
#include "pgem_command_t.h"
#include "pgem_edge2_t.h"
#include "pgem_graph_t.h"
#include "pgem_status_t.h"

#define FIRST_ID 1000000000000LL /* far above any real pose id of the tests */

static int pending(lcm_t *lcm, const pgem_channels_t *channels, long count, double rate,
                   const char *source, long sources)
{
    char name[80];
    double start = now_seconds();
    for (long k = 0; k < count; ++k) {
        if (rate > 0.0) {
            sleep_until(start + (double)k / rate);
        }
        if (sources > 0) {
            snprintf(name, sizeof name, "%s-%ld", source, k % sources);
        } else {
            snprintf(name, sizeof name, "%s", source);
        }
        pgem_edge2_t edge;
        memset(&edge, 0, sizeof edge);
        edge.source = name;
        edge.sequence = k;
        edge.from = FIRST_ID + 2 * k;
        edge.to = FIRST_ID + 2 * k + 1;
        edge.measurement[0] = 1.0;
        edge.information[0] = edge.information[3] = edge.information[5] = 100.0;
        edge.kind = PGEM_EDGE2_T_LOOP;
        if (pgem_edge2_t_publish(lcm, channels->edge, &edge) != 0) {
            return 1;
        }
    }
    printf("sent %ld edges to poses that never come\n", count);
    return 0;
}

static int snapshot(lcm_t *lcm, const pgem_channels_t *channels, char *path)
{
    pgem_command_t command = {1, PGEM_COMMAND_T_SNAPSHOT, path};
    if (pgem_command_t_publish(lcm, channels->command, &command) != 0) {
        return 1;
    }
    printf("sent 1 SNAPSHOT\n");
    return 0;
}

/* COUNT commands at RATE per second; SNAPSHOT names PREFIX-k. */
static int commands(lcm_t *lcm, const pgem_channels_t *channels, int8_t what,
                    char *prefix, long count, double rate)
{
    char name[160];
    double start = now_seconds();
    for (long k = 0; k < count; ++k) {
        if (rate > 0.0) {
            sleep_until(start + (double)k / rate);
        }
        snprintf(name, sizeof name, "%s-%ld", prefix, k);
        pgem_command_t command = {1, what, what == PGEM_COMMAND_T_SNAPSHOT ? name : prefix};
        if (pgem_command_t_publish(lcm, channels->command, &command) != 0) {
            return 1;
        }
    }
    printf("sent %ld commands\n", count);
    return 0;
}

static int odometry(lcm_t *lcm, const pgem_channels_t *channels, char **argv)
{
    pgem_edge2_t edge;
    memset(&edge, 0, sizeof edge);
    edge.utime = 1;
    edge.source = argv[2];
    edge.sequence = 0;
    edge.from = strtoll(argv[3], NULL, 10);
    edge.to = strtoll(argv[4], NULL, 10);
    for (int k = 0; k < 3; ++k) {
        edge.measurement[k] = strtod(argv[5 + k], NULL);
    }
    edge.information[0] = edge.information[3] = edge.information[5] = 1e4;
    edge.kind = PGEM_EDGE2_T_ODOMETRY;
    if (pgem_edge2_t_publish(lcm, channels->edge, &edge) != 0) {
        return 1;
    }
    printf("sent 1 ODOMETRY edge %lld -> %lld\n", (long long)edge.from, (long long)edge.to);
    return 0;
}

static int rogue(lcm_t *lcm, const pgem_channels_t *channels)
{
    static char bad_name[] = "fe\xff\x1b[2J";
    static char trigger[] = "loops\n";
    static char why[] = "forged\nline \xc0\xaf";
    static char reason[] = "decode\x1b[31m";
    char *sources[1] = {bad_name};
    int64_t last[1] = {3};
    int64_t ids[1] = {0};
    double values[3] = {0.0, 0.0, 0.0};
    double *rows[1] = {values};
    pgem_graph_t graph;
    memset(&graph, 0, sizeof graph);
    graph.dimension = 2;
    graph.num_poses = 1;
    graph.pose_size = 3;
    graph.ids = ids;
    graph.poses = rows;
    graph.num_sources = 1;
    graph.sources = sources;
    graph.last_sequence = last;
    graph.stats.solve_id = 1;
    graph.stats.trigger = trigger;
    graph.stats.message = why;
    graph.stats.initial_chi2 = (double)INFINITY;
    graph.stats.chi2 = (double)NAN;
    char *reasons[1] = {reason};
    int64_t rejected[1] = {1};
    pgem_status_t status;
    memset(&status, 0, sizeof status);
    status.dimension = 2;
    status.num_reasons = 1;
    status.reasons = reasons;
    status.rejected = rejected;
    status.message = why;
    /* the status first: a dump that stops at its first graph has it by then */
    if (pgem_status_t_publish(lcm, channels->status, &status) != 0 ||
        pgem_graph_t_publish(lcm, channels->graph, &graph) != 0) {
        return 1;
    }
    printf("sent 1 graph and 1 status\n");
    return 0;
}

int main(int argc, char **argv)
{
    pgem_channels_t channels;
    pgem_channels_init(&channels, NULL, 2);
    int pending_mode = argc >= 5 && argc <= 6 && strcmp(argv[1], "pending") == 0;
    int snapshot_mode = argc == 3 && strcmp(argv[1], "snapshot") == 0;
    int graph_mode = argc == 2 && strcmp(argv[1], "graph") == 0;
    int snapshots_mode = argc == 5 && strcmp(argv[1], "snapshots") == 0;
    int optimize_mode = argc == 4 && strcmp(argv[1], "optimize") == 0;
    int odometry_mode = argc == 8 && strcmp(argv[1], "odometry") == 0;
    if (!pending_mode && !snapshot_mode && !graph_mode && !snapshots_mode && !optimize_mode &&
        !odometry_mode) {
        fprintf(stderr, "usage: lcm_hostile pending COUNT RATE SOURCE [SOURCES] | snapshot NAME | "
                        "snapshots PREFIX COUNT RATE | optimize COUNT RATE | odometry SOURCE "
                        "FROM TO X Y THETA | graph\n");
        return 2;
    }
    lcm_t *lcm = lcm_create(NULL);
    if (lcm == NULL) {
        fprintf(stderr, "lcm_hostile: cannot open LCM\n");
        return 1;
    }
    static char no_path[] = "";
    int status = snapshots_mode  ? commands(lcm, &channels, PGEM_COMMAND_T_SNAPSHOT, argv[2],
                                            strtol(argv[3], NULL, 10), strtod(argv[4], NULL))
                 : optimize_mode ? commands(lcm, &channels, PGEM_COMMAND_T_OPTIMIZE, no_path,
                                            strtol(argv[2], NULL, 10), strtod(argv[3], NULL))
                 : odometry_mode ? odometry(lcm, &channels, argv)
                 : pending_mode  ? pending(lcm, &channels, strtol(argv[2], NULL, 10),
                                           strtod(argv[3], NULL), argv[4],
                                           argc == 6 ? strtol(argv[5], NULL, 10) : 0)
                 : snapshot_mode ? snapshot(lcm, &channels, argv[2])
                                 : rogue(lcm, &channels);
    if (status != 0) {
        fprintf(stderr, "lcm_hostile: publishing failed\n");
    }
    lcm_destroy(lcm);
    return status;
}
