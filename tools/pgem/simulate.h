/* Pieces of pgem simulate shared by its files: the options, one walk per world, 3D noise. */
#ifndef PGEM_SIMULATE_H
#define PGEM_SIMULATE_H

#include <stddef.h>
#include <stdint.h>

#include "cli.h"

#define SIM_PI 3.14159265358979323846

/* The simulated worlds (--world). */
typedef enum sim_world {
    SIM_WORLD_MANHATTAN = 0,     /* 2D grid walk, like M3500 */
    SIM_WORLD_SPHERE = 1,        /* 3D rings of latitude on a sphere, like Sphere2500 */
    SIM_WORLD_GRID3D = 2         /* 3D walk on a cubic lattice */
} sim_world_t;

/* Command-line choices of one simulation (every value filled, per-world defaults applied). */
typedef struct sim_args {
    const char *output;          /* noisy graph (initial estimate = odometry composition) */
    const char *truth;           /* same graph with ground-truth vertices (may be NULL) */
    sim_world_t world;           /* which walk */
    uint32_t poses;              /* walk length, >= 2 */
    uint32_t seed;               /* random seed */
    double sigma_translation;    /* odometry and loop noise, metres (per axis) */
    double sigma_rotation;       /* radians (2D: heading; 3D: per axis of the rotation vector) */
    double loop_probability;     /* chance a candidate revisit yields a loop closure */
    uint32_t robots;             /* robots the walk is split across (1: one robot) */
    uint32_t false_loops;        /* false inter-robot loops to add (robots > 1) */
} sim_args_t;

/* Ids of a team's poses: robot r's pose i is r * PGEM_SIM_ROBOT_IDS + i. */
#define PGEM_SIM_ROBOT_IDS UINT64_C(1000000)
#define PGEM_SIM_ROBOTS_MAX 8u

/* The robot that drives walk pose k, a robot's first walk pose, and pose k's id
 * (simulate_team.c). */
uint32_t pgem_sim_robot(const sim_args_t *args, uint32_t k);
uint32_t pgem_sim_robot_first(const sim_args_t *args, uint32_t robot);
pgem_id_t pgem_sim_robot_id(const sim_args_t *args, uint32_t k);
/* The walk's graph (pose indices as ids) made a team's: the odometry steps between robots
 * dropped, args->false_loops false inter-robot loops appended (their ids listed in
 * `outliers`), every edge's ends turned into the robots' ids. 0, or -1 when out of memory. */
int pgem_sim_team(const sim_args_t *args, pgem_io_graph_t *graph, FILE *outliers);

/* A world's walk: fills truth (args->poses poses of 3 or 7 values, the first the identity)
 * and appends odometry and loop edges to graph, whose edge array holds at least the world's
 * capacity. Returns 0, or -1 when out of memory. */
typedef int (*sim_walk_fn)(const sim_args_t *args, double *truth, pgem_io_graph_t *graph);

/* Most edges each world makes for a walk of `poses` poses. */
size_t pgem_sim_manhattan_capacity(uint32_t poses);
size_t pgem_sim_sphere_capacity(uint32_t poses);
size_t pgem_sim_grid3d_capacity(uint32_t poses);

int pgem_sim_manhattan(const sim_args_t *args, double *truth, pgem_io_graph_t *graph);
int pgem_sim_sphere(const sim_args_t *args, double *truth, pgem_io_graph_t *graph);
int pgem_sim_grid3d(const sim_args_t *args, double *truth, pgem_io_graph_t *graph);

/* Appends the 3D edge from -> to: the true relative pose perturbed on the right by
 * (rho, Exp(phi)), rho ~ N(0, sigma_t^2 I), phi ~ N(0, sigma_r^2 I), with the information
 * that noise has in g2o's error (translation 1/sigma_t^2, quaternion vector 4/sigma_r^2). */
void pgem_sim_se3_edge(pgem_io_graph_t *graph, uint32_t from, uint32_t to, const double *truth,
                       const sim_args_t *args, uint64_t *rng);

/* Unit quaternion [qx qy qz qw], qw >= 0, of a row-major rotation matrix. */
void pgem_sim_quat_from_matrix(const double rotation[9], double q[4]);

/* Negates a quaternion [qx qy qz qw] whose qw is negative (the same rotation, qw >= 0). */
void pgem_sim_quat_positive(double q[4]);

#endif /* PGEM_SIMULATE_H */
