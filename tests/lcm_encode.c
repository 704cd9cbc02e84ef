/* Writes one message of each pgem LCM type, encoded by the C types, into a folder, for
 * test_lcm_python.py to decode with the generated Python types (the values are the test's). */
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "pgem_command_t.h"
#include "pgem_covariance_t.h"
#include "pgem_edge2_t.h"
#include "pgem_edge3_t.h"
#include "pgem_graph_t.h"
#include "pgem_pose3_t.h"
#include "pgem_status_t.h"
#include "pgem_team_t.h"

static unsigned char buffer[1 << 16];

/* Writes size bytes of buffer to FOLDER/NAME.bin; 0 or 1. */
static int save(const char *folder, const char *name, int size)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s.bin", folder, name);
    FILE *file = fopen(path, "wb");
    if (size <= 0 || file == NULL || fwrite(buffer, 1, (size_t)size, file) != (size_t)size) {
        fprintf(stderr, "lcm_encode: cannot write %s\n", path);
        if (file != NULL) {
            fclose(file);
        }
        return 1;
    }
    return fclose(file) != 0;
}

static int edges(const char *folder)
{
    static char source[] = "front-end \xc3\xa9";
    pgem_edge2_t edge2;
    memset(&edge2, 0, sizeof edge2);
    edge2.utime = 1700000000000001;
    edge2.source = source;
    edge2.sequence = 42;
    edge2.from = -1; /* 2^64 - 1 as a pose id */
    edge2.to = 7;
    edge2.measurement[0] = 1.5;
    edge2.measurement[1] = -0.25;
    edge2.measurement[2] = 3.0;
    for (int k = 0; k < 6; ++k) {
        edge2.information[k] = 100.0 + k;
    }
    edge2.kind = PGEM_EDGE2_T_LOOP;
    int failed = save(folder, "edge2", pgem_edge2_t_encode(buffer, 0, sizeof buffer, &edge2));
    pgem_edge3_t edge3;
    memset(&edge3, 0, sizeof edge3);
    edge3.utime = 2;
    edge3.source = source;
    edge3.sequence = 43;
    edge3.from = 9;
    edge3.to = 10;
    edge3.measurement[0] = 1.0;
    edge3.measurement[6] = 1.0;
    for (int k = 0; k < 21; ++k) {
        edge3.information[k] = (double)k;
    }
    edge3.kind = PGEM_EDGE3_T_ODOMETRY;
    return failed | save(folder, "edge3", pgem_edge3_t_encode(buffer, 0, sizeof buffer, &edge3));
}

static int graph(const char *folder)
{
    static char trigger[] = "settle";
    static char empty[] = "";
    static char name_a[] = "a";
    static char name_b[] = "b";
    int64_t ids[2] = {0, 5};
    double values[2][3] = {{0.0, 0.0, 0.0}, {1.0, 2.0, 0.5}};
    double *rows[2] = {values[0], values[1]};
    pgem_loop_t loops[2] = {{0, 11, 0, 5, 0.875, PGEM_LOOP_T_ACCEPTED},
                            {1, 12, 5, 0, 0.0, PGEM_LOOP_T_PRUNED}};
    char *sources[2] = {name_a, name_b};
    int64_t last[2] = {11, 12};
    pgem_graph_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = 3;
    msg.dimension = 2;
    msg.num_poses = 2;
    msg.pose_size = 3;
    msg.ids = ids;
    msg.poses = rows;
    msg.num_loops = 2;
    msg.loops = loops;
    msg.num_sources = 2;
    msg.sources = sources;
    msg.last_sequence = last;
    msg.edges_included = 3;
    msg.stats.solve_id = 4;
    msg.stats.trigger = trigger;
    msg.stats.usable = 1;
    msg.stats.message = empty;
    msg.stats.chi2 = 137.91295093603975;
    return save(folder, "graph", pgem_graph_t_encode(buffer, 0, sizeof buffer, &msg));
}

static int others(const char *folder)
{
    static char source[] = "fe";
    static char path[] = "map.g2o";
    static char reason[] = "journal";
    static char message[] = "rejected (journal): ...";
    pgem_pose3_t pose;
    memset(&pose, 0, sizeof pose);
    pose.source = source;
    pose.id = 77;
    pose.pose[6] = 1.0;
    pose.fixed = 1;
    int failed = save(folder, "pose3", pgem_pose3_t_encode(buffer, 0, sizeof buffer, &pose));
    pgem_command_t command = {5, PGEM_COMMAND_T_SNAPSHOT, path};
    failed |= save(folder, "command", pgem_command_t_encode(buffer, 0, sizeof buffer, &command));
    char *reasons[1] = {reason};
    int64_t rejected[1] = {50};
    pgem_status_t status;
    memset(&status, 0, sizeof status);
    status.dimension = 2;
    status.accepted_poses = 100;
    status.num_reasons = 1;
    status.reasons = reasons;
    status.rejected = rejected;
    status.journal_records = 100;
    status.message = message;
    return failed | save(folder, "status", pgem_status_t_encode(buffer, 0, sizeof buffer, &status));
}

/* A 3D covariance: 6 x 6 rows i * 6 + j + 0.5, the pose an identity at (1, 2, 3). */
static int covariance(const char *folder)
{
    double pose[7] = {1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0};
    double values[36];
    double *rows[6];
    for (int i = 0; i < 6; i++) {
        rows[i] = values + 6 * i;
        for (int j = 0; j < 6; j++) {
            values[6 * i + j] = 6.0 * i + j + 0.5;
        }
    }
    pgem_covariance_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = 1234;
    msg.solve_id = 812;
    msg.id = 2499;
    msg.dimension = 3;
    msg.pose_size = 7;
    msg.pose = pose;
    msg.size = 6;
    msg.covariance = rows;
    msg.current = 1;
    return save(folder, "covariance", pgem_covariance_t_encode(buffer, 0, sizeof buffer, &msg));
}

/* A 3D team of two robots: "robot-0" anchored at the identity, "robot-1" in a part of its own,
 * its frame a half turn about z at (10, -12, 1). */
static int team(const char *folder)
{
    static char robot0[] = "robot-0";
    static char robot1[] = "robot-1";
    char *sources[2] = {robot0, robot1};
    int32_t poses[2] = {300, 299};
    int64_t first_ids[2] = {0, 1000000};
    int32_t parts[2] = {0, 1};
    int8_t anchored[2] = {1, 0};
    double values[2][7] = {{0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0},
                           {10.0, -12.0, 1.0, 0.0, 0.0, 1.0, 0.0}};
    double *frames[2] = {values[0], values[1]};
    pgem_team_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = 4321;
    msg.solve_id = 17;
    msg.dimension = 3;
    msg.pose_size = 7;
    msg.num_parts = 2;
    msg.num_robots = 2;
    msg.sources = sources;
    msg.poses = poses;
    msg.first_ids = first_ids;
    msg.parts = parts;
    msg.anchored = anchored;
    msg.frames = frames;
    return save(folder, "team", pgem_team_t_encode(buffer, 0, sizeof buffer, &msg));
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: lcm_encode FOLDER\n");
        return 2;
    }
    return edges(argv[1]) | graph(argv[1]) | others(argv[1]) | covariance(argv[1]) |
           team(argv[1]);
}
