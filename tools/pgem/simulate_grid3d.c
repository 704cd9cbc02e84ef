/* pgem simulate, 3D grid world: a walk on a cubic lattice (1 m steps along the body x axis,
 * quarter turns in yaw or pitch) inside a cube sized from the walk length; a loop closure
 * where the walk comes back to a cell it visited, or to one next to it. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "simulate.h"

#define GRID_CELLS_PER_POSE 1.5  /* the cube holds at most 1.5 cells per pose */
#define GRID_SLOTS 2             /* recent visits remembered per cell */
#define GRID_MIN_GAP 10          /* a loop joins poses at least this many steps apart */
#define GRID_MAX_LOOPS 4         /* loop closures per pose at most */
#define GRID_TURN 0.3            /* chance of a turn per step (split among the four) */
#define GRID_MOVES 5             /* straight on, yaw left, yaw right, pitch up, pitch down */
#define GRID_NEIGHBOURS 7        /* the cell itself and its six face neighbours */

/* Body-frame rotation of each move, row-major (the new orientation is R * move). */
static const int grid_move[GRID_MOVES][9] = {
    {1, 0, 0, 0, 1, 0, 0, 0, 1},   /* straight on */
    {0, -1, 0, 1, 0, 0, 0, 0, 1},  /* yaw left: +90 degrees about z */
    {0, 1, 0, -1, 0, 0, 0, 0, 1},  /* yaw right */
    {0, 0, -1, 0, 1, 0, 1, 0, 0},  /* pitch up: x turns to +z */
    {0, 0, 1, 0, 1, 0, -1, 0, 0},  /* pitch down */
};

static const int grid_neighbour[GRID_NEIGHBOURS][3] = {
    {0, 0, 0}, {1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

/* The walk's state: the cube, the current cell and orientation, recent visits per cell. */
typedef struct grid_walk {
    int half_width;              /* cells -half_width .. half_width on each axis */
    int side;                    /* 2 half_width + 1 */
    int cell[3];                 /* current cell */
    int rotation[9];             /* current orientation, a signed permutation, row-major */
    uint32_t *visits;            /* side^3 x GRID_SLOTS pose indices, newest first */
} grid_walk_t;

size_t pgem_sim_grid3d_capacity(uint32_t poses)
{
    return (size_t)poses * (1u + GRID_MAX_LOOPS);
}

static int grid_half_width(uint32_t poses)
{
    double side = cbrt(GRID_CELLS_PER_POSE * poses);
    int half_width = (int)floor(0.5 * (side - 1.0));
    return half_width < 1 ? 1 : half_width;
}

static int grid_inside(const grid_walk_t *walk, const int cell[3])
{
    return abs(cell[0]) <= walk->half_width && abs(cell[1]) <= walk->half_width &&
           abs(cell[2]) <= walk->half_width;
}

static uint32_t *grid_slots(const grid_walk_t *walk, const int cell[3])
{
    size_t index = 0;
    for (int axis = 0; axis < 3; axis++) {
        index = index * (size_t)walk->side + (size_t)(cell[axis] + walk->half_width);
    }
    return walk->visits + index * GRID_SLOTS;
}

/* One step: a random move (turns with probability GRID_TURN), the next move in turn when
 * it would leave the cube. From any cell and heading one of the five stays inside. */
static void grid_step(grid_walk_t *walk, uint64_t *rng)
{
    double draw = pgem_cli_uniform(rng);
    int choice = draw >= GRID_TURN ? 0 : draw < 0.25 * GRID_TURN ? 1 : draw < 0.5 * GRID_TURN ? 2
               : draw < 0.75 * GRID_TURN ? 3 : 4;
    for (int tries = 0; tries < GRID_MOVES; tries++) {
        const int *move = grid_move[(choice + tries) % GRID_MOVES];
        int rotation[9], next[3];
        for (int row = 0; row < 3; row++) {
            for (int col = 0; col < 3; col++) {
                rotation[3 * row + col] = walk->rotation[3 * row] * move[col] +
                                          walk->rotation[3 * row + 1] * move[3 + col] +
                                          walk->rotation[3 * row + 2] * move[6 + col];
            }
            next[row] = walk->cell[row] + rotation[3 * row];
        }
        if (grid_inside(walk, next)) {
            memcpy(walk->rotation, rotation, sizeof rotation);
            memcpy(walk->cell, next, sizeof next);
            return;
        }
    }
}

/* Loop closures from pose k to earlier visits of its cell and of the cells next to it
 * (newest first, at most GRID_MAX_LOOPS), then records the visit. */
static void grid_loops(grid_walk_t *walk, uint32_t k, const double *truth, const sim_args_t *args,
                       pgem_io_graph_t *graph, uint64_t *rng)
{
    int added = 0;
    for (int n = 0; n < GRID_NEIGHBOURS && added < GRID_MAX_LOOPS; n++) {
        int cell[3] = {walk->cell[0] + grid_neighbour[n][0], walk->cell[1] + grid_neighbour[n][1],
                       walk->cell[2] + grid_neighbour[n][2]};
        if (!grid_inside(walk, cell)) {
            continue;
        }
        const uint32_t *visits = grid_slots(walk, cell);
        for (int slot = 0; slot < GRID_SLOTS && added < GRID_MAX_LOOPS; slot++) {
            uint32_t earlier = visits[slot];
            if (earlier != UINT32_MAX && earlier + GRID_MIN_GAP < k &&
                pgem_cli_uniform(rng) < args->loop_probability) {
                pgem_sim_se3_edge(graph, k, earlier, truth, args, rng);
                added++;
            }
        }
    }
    uint32_t *own = grid_slots(walk, walk->cell);
    memmove(own + 1, own, (GRID_SLOTS - 1) * sizeof own[0]);
    own[0] = k;
}

int pgem_sim_grid3d(const sim_args_t *args, double *truth, pgem_io_graph_t *graph)
{
    grid_walk_t walk = {.half_width = grid_half_width(args->poses),
                        .rotation = {1, 0, 0, 0, 1, 0, 0, 0, 1}};
    walk.side = 2 * walk.half_width + 1;
    size_t slots = (size_t)walk.side * (size_t)walk.side * (size_t)walk.side * GRID_SLOTS;
    walk.visits = malloc(slots * sizeof walk.visits[0]);
    if (walk.visits == NULL) {
        return -1;
    }
    memset(walk.visits, 0xff, slots * sizeof walk.visits[0]);
    uint64_t rng = args->seed;
    for (uint32_t k = 0; k < args->poses; k++) {
        double *pose = truth + 7 * (size_t)k, rotation[9];
        if (k > 0) {
            grid_step(&walk, &rng);
        }
        for (int c = 0; c < 9; c++) {
            rotation[c] = walk.rotation[c];
        }
        for (int axis = 0; axis < 3; axis++) {
            pose[axis] = walk.cell[axis];
        }
        pgem_sim_quat_from_matrix(rotation, pose + 3);
        if (k > 0) {
            pgem_sim_se3_edge(graph, k - 1, k, truth, args, &rng);
        }
        grid_loops(&walk, k, truth, args, graph, &rng);
    }
    free(walk.visits);
    return 0;
}
