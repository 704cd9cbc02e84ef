/* pgem simulate --robots R: one world's walk split across R robots. Robot r drives the r-th
 * stretch of the walk; its poses get ids r * PGEM_SIM_ROBOT_IDS + i (i from 0), its odometry
 * starts at its own origin (the estimate of its first pose is the identity: a frame nobody
 * knows), the odometry step between two robots' stretches is not measured, and loop closures
 * between two robots' stretches are inter-robot loops. --false-loops K adds K false
 * inter-robot loops, listed in OUT.outliers as pgem corrupt lists its own. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "simulate.h"

/* Robot r drives walk poses ceil(r N / R) .. ceil((r + 1) N / R) - 1: stretches of N / R
 * poses, rounded down or up. */
uint32_t pgem_sim_robot(const sim_args_t *args, uint32_t k)
{
    return (uint32_t)((uint64_t)k * args->robots / args->poses);
}

uint32_t pgem_sim_robot_first(const sim_args_t *args, uint32_t robot)
{
    return (uint32_t)(((uint64_t)robot * args->poses + args->robots - 1u) / args->robots);
}

pgem_id_t pgem_sim_robot_id(const sim_args_t *args, uint32_t k)
{
    const uint32_t robot = pgem_sim_robot(args, k);
    return (pgem_id_t)robot * PGEM_SIM_ROBOT_IDS + (pgem_id_t)(k - pgem_sim_robot_first(args, robot));
}

/* Drops the odometry steps from one robot's stretch to the next (no robot measured them). */
static void sim_team_odometry(const sim_args_t *args, pgem_io_graph_t *graph)
{
    size_t kept = 0;
    for (size_t e = 0; e < graph->edge_count; e++) {
        const pgem_io_edge_t *edge = &graph->edges[e];
        if (edge->kind == PGEM_EDGE_ODOMETRY &&
            pgem_sim_robot(args, (uint32_t)edge->from) != pgem_sim_robot(args, (uint32_t)edge->to)) {
            continue;
        }
        graph->edges[kept++] = *edge;
    }
    graph->edge_count = kept;
}

/* Appends the false inter-robot loops (two poses of two robots drawn uniformly, a random
 * measurement, the first loop closure's information) and lists them in `outliers`. */
static int sim_team_false_loops(const sim_args_t *args, pgem_io_graph_t *graph, FILE *outliers)
{
    pgem_io_edge_t model = graph->edges[0];
    for (size_t e = 0; e < graph->edge_count; e++) {
        if (graph->edges[e].kind == PGEM_EDGE_LOOP) {
            model = graph->edges[e];
            break;
        }
    }
    pgem_io_edge_t *edges = realloc(graph->edges, (graph->edge_count + args->false_loops) * sizeof *edges);
    if (edges == NULL) {
        return -1;
    }
    graph->edges = edges;
    graph->edge_capacity = graph->edge_count + args->false_loops;
    uint64_t rng = (uint64_t)args->seed ^ UINT64_C(0x5eed0f7ea1);
    for (uint32_t added = 0; added < args->false_loops;) {
        const uint32_t a = (uint32_t)(pgem_cli_uniform(&rng) * args->poses) % args->poses;
        const uint32_t b = (uint32_t)(pgem_cli_uniform(&rng) * args->poses) % args->poses;
        if (pgem_sim_robot(args, a) == pgem_sim_robot(args, b)) {
            continue;
        }
        pgem_io_edge_t *edge = &graph->edges[graph->edge_count++];
        *edge = model;
        pgem_cli_random_pose(&rng, graph->dimension, edge->measurement);
        edge->from = a;
        edge->to = b;
        edge->kind = PGEM_EDGE_LOOP;
        edge->line = 0;
        fprintf(outliers, "%llu %llu\n", (unsigned long long)pgem_sim_robot_id(args, a),
                (unsigned long long)pgem_sim_robot_id(args, b));
        added++;
    }
    return 0;
}

int pgem_sim_team(const sim_args_t *args, pgem_io_graph_t *graph, FILE *outliers)
{
    sim_team_odometry(args, graph);
    if (args->false_loops > 0u && sim_team_false_loops(args, graph, outliers) != 0) {
        return -1;
    }
    for (size_t e = 0; e < graph->edge_count; e++) { /* pose indices to the robots' ids */
        graph->edges[e].from = pgem_sim_robot_id(args, (uint32_t)graph->edges[e].from);
        graph->edges[e].to = pgem_sim_robot_id(args, (uint32_t)graph->edges[e].to);
    }
    return 0;
}
