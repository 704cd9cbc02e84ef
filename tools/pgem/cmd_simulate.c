/* pgem simulate: a 2D Manhattan-world walk (like M3500) with ground truth, noisy odometry and
 * loop closures where the walk revisits a place; written as g2o. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

#define SIM_HALF_WIDTH 12        /* the world is cells -12 .. 12 on each axis */
#define SIM_CELLS (2 * SIM_HALF_WIDTH + 1)
#define SIM_SLOTS 4              /* recent visits remembered per cell */
#define SIM_MIN_GAP 10           /* a loop joins poses at least this many steps apart */

/* Command-line choices of one simulation. */
typedef struct sim_args {
    const char *output;          /* noisy graph (initial estimate = odometry composition) */
    const char *truth;           /* same graph with ground-truth vertices (may be NULL) */
    uint32_t poses;              /* walk length */
    uint32_t seed;               /* random seed */
    double sigma_translation;    /* odometry and loop noise, metres */
    double sigma_rotation;       /* radians */
    double loop_probability;     /* chance a revisit yields a loop closure */
} sim_args_t;

static void sim_help(FILE *out)
{
    fprintf(out,
            "usage: pgem simulate -o OUT.g2o [--truth TRUTH.g2o] [--world manhattan] [--poses N]\n"
            "                     [--seed S] [--sigma-translation M] [--sigma-rotation RAD]\n"
            "                     [--loop-probability P]\n"
            "\n"
            "A robot walks a Manhattan grid (1 m steps, 90-degree turns) with noisy odometry;\n"
            "revisiting a place gives a loop closure with probability P. OUT holds the odometry-\n"
            "composed initial estimate, TRUTH the same edges with ground-truth vertices.\n"
            "Defaults: 1000 poses, seed 1, sigmas 0.05 m and 0.01 rad, P 0.3.\n");
}

static int sim_parse_double(const char *option, const char *text, double *value)
{
    char *end = NULL;
    double parsed = text != NULL ? strtod(text, &end) : -1.0;
    if (text == NULL || end == text || *end != '\0' || !(parsed >= 0.0) || !isfinite(parsed)) {
        fprintf(stderr, "pgem simulate: %s needs a non-negative number, got '%s'\n", option,
                text != NULL ? text : "");
        return 0;
    }
    *value = parsed;
    return 1;
}

static int sim_parse(int argc, char **argv, sim_args_t *args)
{
    *args = (sim_args_t){NULL, NULL, 1000u, 1u, 0.05, 0.01, 0.3};
    for (int k = 1; k < argc; k++) {
        const char *arg = argv[k], *value = k + 1 < argc ? argv[k + 1] : NULL;
        int ok = 1;
        if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            sim_help(stdout);
            return -1;
        } else if (strcmp(arg, "-o") == 0 && value != NULL) {
            args->output = value;
        } else if (strcmp(arg, "--truth") == 0 && value != NULL) {
            args->truth = value;
        } else if (strcmp(arg, "--world") == 0 && value != NULL) {
            ok = strcmp(value, "manhattan") == 0;
            if (!ok) {
                fprintf(stderr, "pgem simulate: only --world manhattan exists so far\n");
            }
        } else if (strcmp(arg, "--poses") == 0) {
            ok = pgem_cli_parse_u32(arg, value, &args->poses) && args->poses >= 2u;
        } else if (strcmp(arg, "--seed") == 0) {
            ok = pgem_cli_parse_u32(arg, value, &args->seed);
        } else if (strcmp(arg, "--sigma-translation") == 0) {
            ok = sim_parse_double(arg, value, &args->sigma_translation);
        } else if (strcmp(arg, "--sigma-rotation") == 0) {
            ok = sim_parse_double(arg, value, &args->sigma_rotation);
        } else if (strcmp(arg, "--loop-probability") == 0) {
            ok = sim_parse_double(arg, value, &args->loop_probability) && args->loop_probability <= 1.0;
        } else {
            fprintf(stderr, "pgem simulate: unknown or incomplete option '%s' (see --help)\n", arg);
            return PGEM_EXIT_USAGE;
        }
        if (!ok) {
            return PGEM_EXIT_USAGE;
        }
        k++;
    }
    if (args->output == NULL) {
        fprintf(stderr, "pgem simulate: -o OUT.g2o is required\n");
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

/* Next heading: straight on, or a 90-degree turn; never off the grid. */
static int sim_heading(uint64_t *rng, const int *cell, int heading)
{
    static const int step[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
    double turn = pgem_cli_uniform(rng);
    int next = turn < 0.15 ? (heading + 1) % 4 : turn < 0.3 ? (heading + 3) % 4 : heading;
    for (int tries = 0; tries < 4; tries++) {
        int x = cell[0] + step[next][0], y = cell[1] + step[next][1];
        if (abs(x) <= SIM_HALF_WIDTH && abs(y) <= SIM_HALF_WIDTH) {
            return next;
        }
        next = (next + 1) % 4;
    }
    return next;
}

static void sim_edge(pgem_io_graph_t *graph, uint32_t from, uint32_t to, const double *truth,
                     const sim_args_t *args, uint64_t *rng)
{
    pgem_io_edge_t *edge = &graph->edges[graph->edge_count++];
    memset(edge, 0, sizeof *edge);
    edge->from = from;
    edge->to = to;
    pgem_se2_between(truth + 3 * from, truth + 3 * to, edge->measurement);
    edge->measurement[0] += args->sigma_translation * pgem_cli_gaussian(rng);
    edge->measurement[1] += args->sigma_translation * pgem_cli_gaussian(rng);
    edge->measurement[2] = pgem_wrap_angle(edge->measurement[2] + args->sigma_rotation * pgem_cli_gaussian(rng));
    double t = 1.0 / fmax(args->sigma_translation * args->sigma_translation, 1e-12);
    double r = 1.0 / fmax(args->sigma_rotation * args->sigma_rotation, 1e-12);
    double information[9] = {t, 0, 0, 0, t, 0, 0, 0, r};
    memcpy(edge->information, information, sizeof information);
    edge->kind = to == from + 1u ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP;
}

/* Loop closures from pose k to earlier visits of the same cell. */
static void sim_loops(pgem_io_graph_t *graph, uint32_t k, uint32_t *visits, const double *truth,
                      const sim_args_t *args, uint64_t *rng)
{
    for (int slot = 0; slot < SIM_SLOTS; slot++) {
        uint32_t earlier = visits[slot];
        if (earlier != UINT32_MAX && earlier + SIM_MIN_GAP < k && pgem_cli_uniform(rng) < args->loop_probability) {
            sim_edge(graph, k, earlier, truth, args, rng);
        }
    }
    memmove(visits + 1, visits, (SIM_SLOTS - 1) * sizeof visits[0]);
    visits[0] = k;
}

/* Walks the grid; fills truth[3 n] and the edges; returns 0 or -1 (no memory). */
static int sim_walk(const sim_args_t *args, double *truth, pgem_io_graph_t *graph)
{
    uint64_t rng = args->seed;
    uint32_t *visits = malloc(sizeof(uint32_t) * SIM_CELLS * SIM_CELLS * SIM_SLOTS);
    if (visits == NULL) {
        return -1;
    }
    memset(visits, 0xff, sizeof(uint32_t) * SIM_CELLS * SIM_CELLS * SIM_SLOTS);
    int cell[2] = {0, 0}, heading = 0;
    static const int step[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
    for (uint32_t k = 0; k < args->poses; k++) {
        if (k > 0) {
            heading = sim_heading(&rng, cell, heading);
            cell[0] += step[heading][0];
            cell[1] += step[heading][1];
        }
        truth[3 * k] = cell[0];
        truth[3 * k + 1] = cell[1];
        truth[3 * k + 2] = pgem_wrap_angle(1.5707963267948966 * heading);
        if (k > 0) {
            sim_edge(graph, k - 1, k, truth, args, &rng);
        }
        int index = (cell[0] + SIM_HALF_WIDTH) * SIM_CELLS + (cell[1] + SIM_HALF_WIDTH);
        sim_loops(graph, k, visits + (size_t)index * SIM_SLOTS, truth, args, &rng);
    }
    free(visits);
    return 0;
}

/* Vertices of the graph: truth, or the odometry composition of the noisy measurements. */
static void sim_vertices(pgem_io_graph_t *graph, const double *truth, int use_truth)
{
    double estimate[3] = {0.0, 0.0, 0.0};
    size_t odometry = 0;
    for (uint32_t k = 0; k < graph->pose_count; k++) {
        pgem_io_pose_t *pose = &graph->poses[k];
        memset(pose, 0, sizeof *pose);
        pose->id = k;
        if (k > 0 && !use_truth) {
            while (graph->edges[odometry].kind != PGEM_EDGE_ODOMETRY) {
                odometry++;
            }
            pgem_se2_compose(estimate, graph->edges[odometry++].measurement, estimate);
        }
        memcpy(pose->pose, use_truth ? truth + 3 * k : estimate, sizeof estimate);
    }
}

static int sim_write(const char *path, pgem_io_graph_t *graph)
{
    char message[1024];
    if (pgem_io_write(path, PGEM_FORMAT_G2O, graph, message, sizeof message) != PGEM_OK) {
        fprintf(stderr, "pgem simulate: %s\n", message);
        return PGEM_EXIT_IO;
    }
    return PGEM_EXIT_OK;
}

int pgem_cmd_simulate(int argc, char **argv)
{
    sim_args_t args;
    int status = sim_parse(argc, argv, &args);
    if (status != PGEM_EXIT_OK) {
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    pgem_io_graph_t graph = {0};
    double *truth = malloc(sizeof(double) * 3u * args.poses);
    graph.dimension = 2;
    graph.poses = calloc(args.poses, sizeof *graph.poses);
    graph.edges = calloc((size_t)args.poses * (1u + SIM_SLOTS), sizeof *graph.edges);
    graph.pose_count = graph.pose_capacity = args.poses;
    graph.edge_capacity = (size_t)args.poses * (1u + SIM_SLOTS);
    if (truth == NULL || graph.poses == NULL || graph.edges == NULL || sim_walk(&args, truth, &graph) != 0) {
        fprintf(stderr, "pgem simulate: out of memory for %u poses\n", args.poses);
        free(truth);
        pgem_io_graph_free(&graph);
        return PGEM_EXIT_FAILURE;
    }
    status = PGEM_EXIT_OK;
    if (args.truth != NULL) {
        sim_vertices(&graph, truth, 1);
        status = sim_write(args.truth, &graph);
    }
    sim_vertices(&graph, truth, 0);
    if (status == PGEM_EXIT_OK) {
        status = sim_write(args.output, &graph);
    }
    if (status == PGEM_EXIT_OK) {
        printf("simulated manhattan world: %u poses, %zu edges (%zu loop closures), seed %u -> %s%s%s\n",
               args.poses, graph.edge_count, graph.edge_count - (args.poses - 1u), args.seed,
               args.output, args.truth != NULL ? ", truth " : "", args.truth != NULL ? args.truth : "");
    }
    free(truth);
    pgem_io_graph_free(&graph);
    return status;
}
