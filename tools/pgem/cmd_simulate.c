/* pgem simulate: a walk in a synthetic world (2D Manhattan grid, 3D sphere or 3D lattice)
 * with ground truth, noisy odometry and loop closures; written as g2o. The walks are in
 * simulate_<world>.c. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "simulate.h"

/* What differs between the worlds: name, dimension, defaults and the walk. */
typedef struct sim_world_info {
    const char *name;            /* --world value */
    int dimension;               /* 2 or 3 */
    uint32_t poses;              /* default walk length */
    double sigma_translation;    /* default noise, metres */
    double sigma_rotation;       /* default noise, radians */
    double loop_probability;     /* default chance of a loop closure per candidate */
    size_t (*capacity)(uint32_t poses);  /* most edges for a walk */
    sim_walk_fn walk;            /* fills the truth and the edges */
} sim_world_info_t;

static const sim_world_info_t sim_worlds[] = {
    {"manhattan", 2, 1000u, 0.05, 0.01, 0.3, pgem_sim_manhattan_capacity, pgem_sim_manhattan},
    {"sphere", 3, 2500u, 0.05, 0.01, 1.0, pgem_sim_sphere_capacity, pgem_sim_sphere},
    {"grid3d", 3, 2000u, 0.05, 0.01, 0.3, pgem_sim_grid3d_capacity, pgem_sim_grid3d},
};

static void sim_help(FILE *out, const void *context)
{
    (void)context;
    fprintf(out,
            "usage: pgem simulate -o OUT.g2o [--truth TRUTH.g2o]\n"
            "                     [--world manhattan|sphere|grid3d] [--poses N] [--seed S]\n"
            "                     [--sigma-translation M] [--sigma-rotation RAD]\n"
            "                     [--loop-probability P] [--robots R] [--false-loops K]\n"
            "\n"
            "Simulates a robot with noisy odometry and loop closures. OUT holds the odometry-\n"
            "composed initial estimate, TRUTH the same edges with ground-truth vertices.\n"
            "\n"
            "  --world manhattan  (default) 2D walk like M3500: 1 m steps, 90-degree turns,\n"
            "                     in a 25 x 25 m square; revisiting a cell gives a loop\n"
            "                     closure to each of its last 4 visits with probability P.\n"
            "                     Defaults: 1000 poses, sigmas 0.05 m and 0.01 rad, P 0.3.\n"
            "  --world sphere     3D, like Sphere2500: a spiral of rings of latitude on a\n"
            "                     sphere of radius 50 m, about sqrt(N) poses per ring (50\n"
            "                     x 50 by default); each pose is tied to the pose beside it\n"
            "                     on the previous ring with probability P.\n"
            "                     Defaults: 2500 poses, sigmas 0.05 m and 0.01 rad, P 1.\n"
            "  --world grid3d     3D walk on a lattice: 1 m steps, quarter turns in yaw or\n"
            "                     pitch, in a cube of at most 1.5 N cells (13^3 for 2000\n"
            "                     poses); a pose gets loop closures to the last 2 visits of\n"
            "                     its cell and of the 6 cells next to it (11 or more steps\n"
            "                     back), each with probability P, at most 4 per pose.\n"
            "                     Defaults: 2000 poses, sigmas 0.05 m and 0.01 rad, P 0.3.\n"
            "\n"
            "  --robots R         a team: the walk split into R stretches (2 to 8), one per\n"
            "                     robot; robot r's poses have ids r*1000000+i, its odometry\n"
            "                     starts at its own origin (its frame unknown), the step\n"
            "                     between two robots' stretches is not measured, and loop\n"
            "                     closures between stretches join robots. TRUTH holds every\n"
            "                     pose in the world frame (robot 0's).\n"
            "  --false-loops K    with --robots: K false inter-robot loop closures (two poses\n"
            "                     of two robots, a random measurement as pgem corrupt's),\n"
            "                     listed in OUT.outliers (one 'from to' per line).\n"
            "\n"
            "Noise: 2D adds N(0, sigma^2) to x, y and the heading. 3D perturbs the true\n"
            "relative pose on the right by (rho, Exp(phi)), rho ~ N(0, sigma_t^2) and\n"
            "phi ~ N(0, sigma_r^2) per axis; its g2o information is 1/sigma_t^2 for the\n"
            "translation and 4/sigma_r^2 for the rotation (g2o's rotation error is the\n"
            "quaternion's vector part, half the angle). The same seed gives the same files on\n"
            "every platform.\n");
}

static int sim_parse_world(const char *text, sim_world_t *world)
{
    for (size_t k = 0; k < sizeof sim_worlds / sizeof sim_worlds[0]; k++) {
        if (strcmp(text, sim_worlds[k].name) == 0) {
            *world = (sim_world_t)k;
            return 1;
        }
    }
    fprintf(stderr, "pgem simulate: --world takes manhattan, sphere or grid3d (got '%s')\n", text);
    return 0;
}

/* Options not given take the world's defaults (0 poses and NaN sigmas mean "not given"). */
static void sim_defaults(sim_args_t *args)
{
    const sim_world_info_t *info = &sim_worlds[args->world];
    args->poses = args->poses != 0u ? args->poses : info->poses;
    if (isnan(args->sigma_translation)) {
        args->sigma_translation = info->sigma_translation;
    }
    if (isnan(args->sigma_rotation)) {
        args->sigma_rotation = info->sigma_rotation;
    }
    if (isnan(args->loop_probability)) {
        args->loop_probability = info->loop_probability;
    }
}

static int sim_probability(const char *name, const char *value, double *probability)
{
    if (!pgem_cli_parse_number("pgem simulate", name, value, 0, probability)) {
        return 0;
    }
    if (*probability > 1.0) {
        fprintf(stderr, "pgem simulate: --loop-probability must be at most 1, got '%s'\n", value);
        return 0;
    }
    return 1;
}

static int sim_value(void *user, const char *name, const char *value)
{
    sim_args_t *args = user;
    if (strcmp(name, "--poses") == 0) {
        return pgem_cli_parse_at_least("pgem simulate", name, value, 2u, "poses", &args->poses);
    }
    if (strcmp(name, "--seed") == 0) {
        return pgem_cli_parse_u32("pgem", name, value, &args->seed);
    }
    if (strcmp(name, "--loop-probability") == 0) {
        return sim_probability(name, value, &args->loop_probability);
    }
    if (strcmp(name, "--robots") == 0) {
        return pgem_cli_parse_at_least("pgem simulate", name, value, 1u, "robots", &args->robots);
    }
    if (strcmp(name, "--false-loops") == 0) {
        return pgem_cli_parse_u32("pgem", name, value, &args->false_loops);
    }
    if (strcmp(name, "--sigma-translation") == 0 || strcmp(name, "--sigma-rotation") == 0) {
        double *sigma = strcmp(name, "--sigma-translation") == 0 ? &args->sigma_translation
                                                                 : &args->sigma_rotation;
        return pgem_cli_parse_number("pgem simulate", name, value, 0, sigma);
    }
    if (value == NULL) {
        fprintf(stderr, "pgem simulate: %s needs a value\n", name);
        return 0;
    }
    if (strcmp(name, "--world") == 0) {
        return sim_parse_world(value, &args->world);
    }
    *(strcmp(name, "-o") == 0 ? &args->output : &args->truth) = value;
    return 1;
}

/* A team's bounds: 1 to 8 robots of at least 2 poses and fewer than 1000000 each; false
 * inter-robot loops need two robots. */
static int sim_team_check(const sim_args_t *args)
{
    if (args->robots > PGEM_SIM_ROBOTS_MAX) {
        fprintf(stderr, "pgem simulate: --robots takes 1 to %u, got %u\n", PGEM_SIM_ROBOTS_MAX,
                args->robots);
        return PGEM_EXIT_USAGE;
    }
    if (args->poses < 2u * args->robots || args->poses / args->robots >= PGEM_SIM_ROBOT_IDS) {
        fprintf(stderr, "pgem simulate: %u poses cannot be split across %u robots (each needs 2 "
                        "to 999999)\n", args->poses, args->robots);
        return PGEM_EXIT_USAGE;
    }
    if (args->false_loops > 0u && args->robots < 2u) {
        fprintf(stderr, "pgem simulate: --false-loops needs --robots 2 or more\n");
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

static int sim_parse(int argc, char **argv, sim_args_t *args)
{
    static const char *const valued[] = {"-o",     "--truth",       "--world",
                                         "--poses", "--seed",        "--sigma-translation",
                                         "--sigma-rotation", "--loop-probability",
                                         "--robots", "--false-loops"};
    const pgem_cli_parser_t parser = {
        "pgem simulate", valued, sizeof valued / sizeof valued[0], sim_value, NULL, NULL, sim_help,
        NULL, NULL};
    *args = (sim_args_t){NULL, NULL, SIM_WORLD_MANHATTAN, 0u, 1u, (double)NAN, (double)NAN, (double)NAN, 1u, 0u};
    const int status = pgem_cli_parse_args(&parser, args, argc, argv);
    if (status != 0) {
        return status;
    }
    if (args->output == NULL) {
        fprintf(stderr, "pgem simulate: -o OUT.g2o is required\n");
        return PGEM_EXIT_USAGE;
    }
    sim_defaults(args);
    return sim_team_check(args);
}

/* Vertices of the graph: truth, or the composition of the noisy odometry from pose 0 (each
 * robot's from its own first pose, at the identity, in a team). */
static void sim_vertices(const sim_args_t *args, pgem_io_graph_t *graph, const double *truth,
                         int use_truth)
{
    size_t size = (size_t)PGEM_POSE_SIZE(graph->dimension), odometry = 0;
    double estimate[PGEM_POSE_SIZE_MAX];
    memcpy(estimate, truth, size * sizeof estimate[0]); /* pose 0: the identity */
    for (uint32_t k = 0; k < graph->pose_count; k++) {
        pgem_io_pose_t *pose = &graph->poses[k];
        memset(pose, 0, sizeof *pose);
        pose->id = args->robots > 1u ? pgem_sim_robot_id(args, k) : k;
        const int first = args->robots > 1u && pgem_sim_robot_first(args, pgem_sim_robot(args, k)) == k;
        if (first && !use_truth) {
            memcpy(estimate, truth, size * sizeof estimate[0]);
        } else if (k > 0 && !use_truth) {
            while (graph->edges[odometry].kind != PGEM_EDGE_ODOMETRY) {
                odometry++;
            }
            const double *step = graph->edges[odometry++].measurement;
            if (size == 3u) {
                pgem_se2_compose(estimate, step, estimate);
            } else {
                pgem_se3_compose(estimate, step, estimate);
                pgem_quat_normalize(estimate + 3);
            }
        }
        memcpy(pose->pose, use_truth ? truth + size * k : estimate, size * sizeof estimate[0]);
    }
}

/* Allocates the graph and the truth and runs the world's walk; 0 or -1 (no memory). */
static int sim_run(const sim_args_t *args, const sim_world_info_t *info, pgem_io_graph_t *graph,
                   double **truth)
{
    size_t size = (size_t)PGEM_POSE_SIZE(info->dimension), capacity = info->capacity(args->poses);
    *truth = malloc(sizeof(double) * size * args->poses);
    graph->dimension = info->dimension;
    graph->poses = calloc(args->poses, sizeof *graph->poses);
    graph->edges = calloc(capacity, sizeof *graph->edges);
    graph->pose_count = graph->pose_capacity = args->poses;
    graph->edge_capacity = capacity;
    if (*truth == NULL || graph->poses == NULL || graph->edges == NULL) {
        return -1;
    }
    return info->walk(args, *truth, graph);
}

/* OUT.outliers, for a team's false loops. */
static int sim_outliers_open(const sim_args_t *args, pgem_cli_file_t *outliers)
{
    char path[4096];
    if ((size_t)snprintf(path, sizeof path, "%s.outliers", args->output) >= sizeof path) {
        fprintf(stderr, "pgem simulate: %s: the path is too long\n", args->output);
        return PGEM_EXIT_USAGE;
    }
    return pgem_cli_file_open(outliers, "pgem simulate", path) == 0 ? PGEM_EXIT_OK : PGEM_EXIT_IO;
}

/* The one line that says what was written. */
static void sim_report(const sim_args_t *args, const sim_world_info_t *info,
                       const pgem_io_graph_t *graph)
{
    const size_t loops = graph->edge_count - (args->poses - args->robots);
    printf("simulated %s world: %u poses, %zu edges (%zu loop closures), seed %u", info->name,
           args->poses, graph->edge_count, loops, args->seed);
    if (args->robots > 1u) {
        printf(", %u robots (%u false inter-robot loops)", args->robots, args->false_loops);
    }
    printf(" -> %s%s%s\n", args->output, args->truth != NULL ? ", truth " : "",
           args->truth != NULL ? args->truth : "");
}

int pgem_cmd_simulate(int argc, char **argv)
{
    sim_args_t args;
    int status = sim_parse(argc, argv, &args);
    if (status != PGEM_EXIT_OK) {
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    const sim_world_info_t *info = &sim_worlds[args.world];
    pgem_io_graph_t graph = {0};
    double *truth = NULL;
    if (sim_run(&args, info, &graph, &truth) != 0) {
        fprintf(stderr, "pgem simulate: out of memory for %u poses\n", args.poses);
        free(truth);
        pgem_io_graph_free(&graph);
        return PGEM_EXIT_FAILURE;
    }
    pgem_cli_file_t outliers = {0};
    status = args.false_loops > 0u ? sim_outliers_open(&args, &outliers) : PGEM_EXIT_OK;
    if (status == PGEM_EXIT_OK && args.robots > 1u &&
        pgem_sim_team(&args, &graph, outliers.stream) != 0) {
        fprintf(stderr, "pgem simulate: out of memory for %u false loops\n", args.false_loops);
        status = PGEM_EXIT_FAILURE;
    }
    if (status == PGEM_EXIT_OK && args.truth != NULL) {
        sim_vertices(&args, &graph, truth, 1);
        status = pgem_cli_write_graph("pgem simulate", &graph, args.truth);
    }
    sim_vertices(&args, &graph, truth, 0);
    if (status == PGEM_EXIT_OK) {
        status = pgem_cli_write_graph("pgem simulate", &graph, args.output);
    }
    if (outliers.stream != NULL && status != PGEM_EXIT_OK) {
        pgem_cli_file_discard(&outliers); /* no list of loops that were never written */
    } else if (outliers.stream != NULL) {
        status = pgem_cli_file_commit(&outliers, 0);
    }
    if (status == PGEM_EXIT_OK) {
        sim_report(&args, info, &graph);
    }
    free(truth);
    pgem_io_graph_free(&graph);
    return status;
}
