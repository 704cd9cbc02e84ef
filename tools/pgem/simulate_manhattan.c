/* pgem simulate, 2D Manhattan world (like M3500): a walk on a grid with 1 m steps and
 * 90-degree turns; a loop closure where the walk revisits a cell. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "simulate.h"

#define SIM_HALF_WIDTH 12        /* the world is cells -12 .. 12 on each axis */
#define SIM_CELLS (2 * SIM_HALF_WIDTH + 1)
#define SIM_SLOTS 4              /* recent visits remembered per cell */
#define SIM_MIN_GAP 10           /* a loop joins poses at least this many steps apart */

static const int sim_step[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};

size_t pgem_sim_manhattan_capacity(uint32_t poses)
{
    return (size_t)poses * (1u + SIM_SLOTS);
}

/* Next heading: straight on, or a 90-degree turn; never off the grid. */
static int sim_heading(uint64_t *rng, const int *cell, int heading)
{
    double turn = pgem_cli_uniform(rng);
    int next = turn < 0.15 ? (heading + 1) % 4 : turn < 0.3 ? (heading + 3) % 4 : heading;
    for (int tries = 0; tries < 4; tries++) {
        int x = cell[0] + sim_step[next][0], y = cell[1] + sim_step[next][1];
        if (abs(x) <= SIM_HALF_WIDTH && abs(y) <= SIM_HALF_WIDTH) {
            return next;
        }
        next = (next + 1) % 4;
    }
    return next;
}

/* The 2D edge from -> to: true relative pose plus independent noise on x, y and heading. */
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

int pgem_sim_manhattan(const sim_args_t *args, double *truth, pgem_io_graph_t *graph)
{
    uint64_t rng = args->seed;
    uint32_t *visits = malloc(sizeof(uint32_t) * SIM_CELLS * SIM_CELLS * SIM_SLOTS);
    if (visits == NULL) {
        return -1;
    }
    memset(visits, 0xff, sizeof(uint32_t) * SIM_CELLS * SIM_CELLS * SIM_SLOTS);
    int cell[2] = {0, 0}, heading = 0;
    for (uint32_t k = 0; k < args->poses; k++) {
        if (k > 0) {
            heading = sim_heading(&rng, cell, heading);
            cell[0] += sim_step[heading][0];
            cell[1] += sim_step[heading][1];
        }
        truth[3 * k] = cell[0];
        truth[3 * k + 1] = cell[1];
        truth[3 * k + 2] = pgem_wrap_angle(0.5 * SIM_PI * heading);
        if (k > 0) {
            sim_edge(graph, k - 1, k, truth, args, &rng);
        }
        int index = (cell[0] + SIM_HALF_WIDTH) * SIM_CELLS + (cell[1] + SIM_HALF_WIDTH);
        sim_loops(graph, k, visits + (size_t)index * SIM_SLOTS, truth, args, &rng);
    }
    free(visits);
    return 0;
}
