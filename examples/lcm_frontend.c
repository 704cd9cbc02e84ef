/* A front-end for pgem-lcm-bridge, in one file to copy from.
 *
 * A simulated robot drives three times around a 5 m square. At every step it publishes its
 * new pose (pgem.pose2_t, the dead-reckoning estimate) and the odometry edge from the previous
 * pose (pgem.edge2_t). Each time it is back at the start, its place recognition closes a loop
 * to pose 0; once, on the second lap, it is fooled: it takes a spot on the far side of the
 * square for one near the start.
 * Then the program listens for the bridge's optimized graph (pgem.graph_t) and prints what
 * the EM back-end made of each loop closure: the false one should be pruned, the true ones
 * accepted.
 *
 *   pgem-lcm-bridge &                    (in another terminal)
 *   ./example_lcm_frontend [SECONDS]     (how long to wait for the graph; default 10)
 *
 * Exit code 0 when the false loop closure was pruned and the true ones accepted, else 1 (also
 * when no graph including every edge arrived in time). LCM's URL comes from LCM_DEFAULT_URL,
 * as for every LCM program. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <lcm/lcm.h>

#include "pgem_command_t.h"
#include "pgem_edge2_t.h"
#include "pgem_graph_t.h"
#include "pgem_pose2_t.h"

/* The bridge's default channels (pgem-lcm-bridge --channel-prefix changes the PGEM_). */
#define POSE_CHANNEL "PGEM_POSE2"
#define EDGE_CHANNEL "PGEM_EDGE2"
#define GRAPH_CHANNEL "PGEM_GRAPH"
#define COMMAND_CHANNEL "PGEM_COMMAND"

#define SOURCE "example-frontend" /* names this front-end in every message */
#define ID_BASE 1000000           /* pose ids are global in the bridge: this robot's range */
#define SIDE 5                    /* one-metre steps per side of the square */
#define LAP (4 * SIDE)            /* steps per lap */
#define LAPS 3
#define STEPS (LAPS * LAP)        /* poses 0 .. STEPS */
#define MAX_LOOPS (LAPS + 1)
#define FALSE_FROM (LAP + 12)     /* the false loop: on lap 2, on the far side of the square, */
#define FALSE_TO 3                /* "recognises" a place near the start of lap 1 */

/* ---- A little 2D geometry: poses are x, y (metres), theta (radians) ----------------------- */

static double wrap_angle(double angle)
{
    return atan2(sin(angle), cos(angle));
}

/* out = a * b: pose b, given in the frame of a, in the world frame. */
static void compose(const double a[3], const double b[3], double out[3])
{
    double c = cos(a[2]), s = sin(a[2]);
    double x = a[0] + c * b[0] - s * b[1];
    double y = a[1] + s * b[0] + c * b[1];
    out[0] = x;
    out[1] = y;
    out[2] = wrap_angle(a[2] + b[2]);
}

/* out = a^-1 * b: pose b in the frame of a (what an edge a -> b measures). */
static void between(const double a[3], const double b[3], double out[3])
{
    double c = cos(a[2]), s = sin(a[2]);
    double dx = b[0] - a[0], dy = b[1] - a[1];
    out[0] = c * dx + s * dy;
    out[1] = -s * dx + c * dy;
    out[2] = wrap_angle(b[2] - a[2]);
}

/* ---- Noise from a fixed seed, so every run sends the same numbers ------------------------- */

static uint64_t random_state = 20131103u;

static double uniform(void) /* in (0, 1), xorshift64* */
{
    random_state ^= random_state >> 12;
    random_state ^= random_state << 25;
    random_state ^= random_state >> 27;
    uint64_t bits = (random_state * UINT64_C(2685821657736338717)) >> 11;
    return ((double)bits + 0.5) / 9007199254740992.0;
}

static double gaussian(double sigma) /* Box-Muller */
{
    return sigma * sqrt(-2.0 * log(uniform())) * cos(6.283185307179586 * uniform());
}

/* ---- Publishing ---------------------------------------------------------------------------- */

static int64_t now_utime(void) /* microseconds since the epoch, for every utime field */
{
    struct timespec now;
    clock_gettime(CLOCK_REALTIME, &now);
    return (int64_t)now.tv_sec * 1000000 + now.tv_nsec / 1000;
}

/* Pose `step` of the drive, as pose ID_BASE + step. The first one is an anchor, held still:
 * the bridge holds the very first pose it gets anyway, but when other front-ends share the
 * bridge, this robot's part of the map needs a fixed pose of its own, or nothing holds it. */
static int publish_pose(lcm_t *lcm, int step, const double estimate[3])
{
    pgem_pose2_t pose;
    memset(&pose, 0, sizeof pose);
    pose.utime = now_utime();
    pose.source = SOURCE;
    pose.id = ID_BASE + step;
    memcpy(pose.pose, estimate, sizeof pose.pose);
    pose.fixed = step == 0;
    return pgem_pose2_t_publish(lcm, POSE_CHANNEL, &pose);
}

/* Sigma (metres, radians) -> information: the upper triangle xx xy xt yy yt tt of the inverse
 * covariance, here diagonal. */
static void information(double sigma_xy, double sigma_theta, double upper[6])
{
    memset(upper, 0, 6 * sizeof upper[0]);
    upper[0] = upper[3] = 1.0 / (sigma_xy * sigma_xy);
    upper[5] = 1.0 / (sigma_theta * sigma_theta);
}

/* Every edge gets the next sequence number: (SOURCE, sequence) names it for the bridge, which
 * then recognises a resent edge as a replay. A real front-end keeps the counter across
 * restarts (or restarts it under a new source name). */
static int64_t next_sequence = 0;

/* An edge from pose `from` to pose `to` (steps of the drive): the measurement is pose `to`
 * in the frame of pose `from`. */
static int publish_edge(lcm_t *lcm, int from, int to, const double measured[3],
                        const double upper[6], int8_t kind, int64_t *sequence)
{
    pgem_edge2_t edge;
    memset(&edge, 0, sizeof edge);
    edge.utime = now_utime();
    edge.source = SOURCE;
    edge.sequence = *sequence = next_sequence++;
    edge.from = ID_BASE + from;
    edge.to = ID_BASE + to;
    memcpy(edge.measurement, measured, sizeof edge.measurement);
    memcpy(edge.information, upper, sizeof edge.information);
    edge.kind = kind;
    return pgem_edge2_t_publish(lcm, EDGE_CHANNEL, &edge);
}

/* ---- The drive ----------------------------------------------------------------------------- */

/* One loop closure this front-end sent, and the bridge's verdict on it. */
typedef struct loop {
    int64_t sequence;
    int from, to;          /* steps of the drive */
    int is_false;
    int seen;              /* found in the bridge's graph */
    double weight;
    int pruned;
} loop_t;

typedef struct frontend {
    loop_t loops[MAX_LOOPS];
    int loop_count;
    int64_t last_sequence; /* of the last edge sent */
    int done;              /* a graph with every edge arrived */
} frontend_t;

/* The true motion of step k (1-based): one metre forward, then a left turn at each corner. */
static void true_step(int k, double step[3])
{
    step[0] = 1.0;
    step[1] = 0.0;
    step[2] = k % SIDE == 0 ? 1.5707963267948966 : 0.0;
}

static void pause_ms(long milliseconds)
{
    struct timespec pause = {0, milliseconds * 1000000L};
    nanosleep(&pause, NULL);
}

/* Drives the robot and publishes everything. Returns 0, or -1 when a publish failed. */
static int drive(lcm_t *lcm, frontend_t *frontend)
{
    static double truth[STEPS + 1][3];
    double estimate[3] = {0.0, 0.0, 0.0};
    double odometry[6], loop_information[6];
    information(0.05, 0.01, odometry);           /* wheel odometry: 5 cm, 0.01 rad per step */
    information(0.1, 0.02, loop_information);    /* place recognition: 10 cm, 0.02 rad */
    int failed = publish_pose(lcm, 0, estimate); /* the robot starts at the origin */
    for (int k = 1; k <= STEPS && !failed; k++) {
        double step[3], measured[3];
        int64_t sequence;
        true_step(k, step);
        compose(truth[k - 1], step, truth[k]);
        /* What the wheel encoders report, and the dead-reckoning estimate built from it: the
         * pose the robot thinks it is at, which is what the bridge starts from. */
        measured[0] = step[0] + gaussian(0.05);
        measured[1] = step[1] + gaussian(0.05);
        measured[2] = wrap_angle(step[2] + gaussian(0.01));
        compose(estimate, measured, estimate);
        /* The pose first, then the edges that use it (an edge that arrives before its poses
         * waits in the bridge, but in order is the normal case). */
        failed |= publish_pose(lcm, k, estimate);
        failed |= publish_edge(lcm, k - 1, k, measured, odometry, PGEM_EDGE2_T_ODOMETRY,
                               &sequence);
        /* Place recognition: back at the start, it matches pose 0 (a true loop closure,
         * measured with a little noise); once it is fooled (a false one: "same place"). */
        int back_at_start = k % LAP == 0, fooled = k == FALSE_FROM;
        if (back_at_start || fooled) {
            loop_t *loop = &frontend->loops[frontend->loop_count++];
            double z[3] = {0.0, 0.0, 0.0};
            loop->from = k;
            loop->to = fooled ? FALSE_TO : 0;
            loop->is_false = fooled;
            if (!fooled) {
                between(truth[k], truth[0], z);
                z[0] += gaussian(0.1);
                z[1] += gaussian(0.1);
                z[2] = wrap_angle(z[2] + gaussian(0.02));
            }
            failed |= publish_edge(lcm, loop->from, loop->to, z, loop_information,
                                   PGEM_EDGE2_T_LOOP, &loop->sequence);
        }
        frontend->last_sequence = next_sequence - 1;
        pause_ms(10); /* a real robot makes a pose every so often, not all at once */
    }
    return failed ? -1 : 0;
}

/* ---- Listening for the optimized graph ---------------------------------------------------- */

/* Every graph the bridge publishes: the poses of every front-end, and each loop closure with
 * its source, sequence, weight and state. Take our loops from the first graph that includes
 * our last edge and every loop closure we sent. */
static void on_graph(const lcm_recv_buf_t *buffer, const char *channel,
                     const pgem_graph_t *graph, void *user)
{
    frontend_t *frontend = user;
    (void)buffer;
    (void)channel;
    int32_t source = -1;
    for (int32_t s = 0; s < graph->num_sources; s++) {
        if (strcmp(graph->sources[s], SOURCE) == 0) {
            source = s;
        }
    }
    if (frontend->done || source < 0 || graph->last_sequence[source] < frontend->last_sequence) {
        return; /* not ours yet, or an older solve */
    }
    int found = 0;
    for (int l = 0; l < frontend->loop_count; l++) {
        loop_t *loop = &frontend->loops[l];
        loop->seen = 0;
        for (int32_t k = 0; k < graph->num_loops; k++) {
            const pgem_loop_t *theirs = &graph->loops[k];
            if (theirs->source_index == source && theirs->sequence == loop->sequence) {
                loop->seen = 1;
                loop->weight = theirs->weight;
                loop->pruned = theirs->state == PGEM_LOOP_T_PRUNED;
            }
        }
        found += loop->seen;
    }
    if (found == frontend->loop_count) {
        frontend->done = 1;
        printf("graph from solve %lld: %d poses, %d loop closures, chi2 %.3f\n",
               (long long)graph->stats.solve_id, (int)graph->num_poses, (int)graph->num_loops,
               graph->stats.chi2);
    }
}

/* Asks the bridge to solve now. Not needed in normal operation (a new loop closure makes the
 * bridge solve); here it makes a rerun against a running bridge, whose edges are then all
 * replays, still get a graph. */
static int request_solve(lcm_t *lcm)
{
    pgem_command_t command;
    memset(&command, 0, sizeof command);
    command.utime = now_utime();
    command.command = PGEM_COMMAND_T_OPTIMIZE;
    command.path = "";
    return pgem_command_t_publish(lcm, COMMAND_CHANNEL, &command);
}

/* Handles messages until a graph with every edge arrived or `seconds` passed. */
static void wait_for_graph(lcm_t *lcm, frontend_t *frontend, double seconds)
{
    struct timespec start, now;
    clock_gettime(CLOCK_MONOTONIC, &start);
    for (;;) {
        clock_gettime(CLOCK_MONOTONIC, &now);
        double left = seconds - (double)(now.tv_sec - start.tv_sec) -
                      1e-9 * (double)(now.tv_nsec - start.tv_nsec);
        if (frontend->done || left <= 0.0) {
            return;
        }
        if (lcm_handle_timeout(lcm, (int)ceil(left * 1000.0)) < 0) {
            return;
        }
    }
}

/* Prints each loop closure's verdict; returns the exit code. */
static int report(const frontend_t *frontend, double seconds)
{
    if (!frontend->done) {
        printf("no graph with all %lld edges within %g s: is pgem-lcm-bridge running (2D, same "
               "LCM_DEFAULT_URL)?\n", (long long)(frontend->last_sequence + 1), seconds);
        return 1;
    }
    int false_pruned = 0, true_accepted = 0, true_loops = 0;
    for (int l = 0; l < frontend->loop_count; l++) {
        const loop_t *loop = &frontend->loops[l];
        printf("loop %2d -> %d  weight %.3f  %-8s  (%s)\n", loop->from, loop->to, loop->weight,
               loop->pruned ? "pruned" : "accepted", loop->is_false ? "false" : "true");
        false_pruned += loop->is_false && loop->pruned;
        true_accepted += !loop->is_false && !loop->pruned;
        true_loops += !loop->is_false;
    }
    printf("false loop closure pruned: %s; true loop closures accepted: %d of %d\n",
           false_pruned ? "yes" : "no", true_accepted, true_loops);
    return false_pruned == 1 && true_accepted == true_loops ? 0 : 1;
}

int main(int argc, char **argv)
{
    double seconds = argc > 1 ? atof(argv[1]) : 10.0;
    frontend_t frontend;
    memset(&frontend, 0, sizeof frontend);
    lcm_t *lcm = lcm_create(NULL); /* NULL: the URL in LCM_DEFAULT_URL, or LCM's default */
    if (lcm == NULL) {
        fprintf(stderr, "cannot create LCM (check LCM_DEFAULT_URL and the multicast route)\n");
        return 1;
    }
    /* Subscribe before publishing, so that no graph is missed. Graphs can be large (tens of
     * bytes per pose): a real program that must not miss one raises the queue capacity and the
     * kernel receive buffer (the URL's recv_buf_size). */
    pgem_graph_t_subscription_t *subscription =
        pgem_graph_t_subscribe(lcm, GRAPH_CHANNEL, on_graph, &frontend);
    pgem_graph_t_subscription_set_queue_capacity(subscription, 16);
    int status = drive(lcm, &frontend) == 0 && request_solve(lcm) == 0 ? 0 : 1;
    if (status != 0) {
        fprintf(stderr, "publishing failed\n");
    } else {
        printf("sent %d poses and %lld edges (%d loop closures) as '%s'\n", STEPS + 1,
               (long long)next_sequence, frontend.loop_count, SOURCE);
        wait_for_graph(lcm, &frontend, seconds > 0.0 ? seconds : 10.0);
        status = report(&frontend, seconds > 0.0 ? seconds : 10.0);
    }
    pgem_graph_t_unsubscribe(lcm, subscription);
    lcm_destroy(lcm);
    return status;
}
