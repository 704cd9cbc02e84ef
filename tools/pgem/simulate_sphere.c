/* pgem simulate, sphere world (like Sphere2500): a robot drives a spiral of rings of latitude
 * on a sphere from near its south pole to near its north pole; each pose is tied by a loop
 * closure to its neighbour on the previous ring. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "simulate.h"

#define SPHERE_RADIUS 50.0       /* metres (Sphere2500's rings are about 3.1 m apart: R ~ 50) */
#define SPHERE_MIN_RING 3u       /* fewest poses per ring */

size_t pgem_sim_sphere_capacity(uint32_t poses)
{
    return 2u * (size_t)poses;
}

/* Poses per ring for a walk of `poses` poses. */
static uint32_t sphere_ring_size(uint32_t poses)
{
    uint32_t size = (uint32_t)lround(sqrt((double)poses));
    return size < SPHERE_MIN_RING ? SPHERE_MIN_RING : size;
}

static void sphere_cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

/* World pose of step k. The walk is the spiral
 *   polar angle from the south pole  theta(k) = pi (k / ring + 1) / (rings + 1),
 *   longitude                        phi(k)   = -2 pi k / ring,
 * so a ring of `ring` poses climbs by one ring spacing and pose k - ring lies beside pose k.
 * The body frame has x along the circle of latitude (the climb is a small sideways drift), z
 * along the outward normal and y = z x x: the robot turns left around the pole it started
 * from and the next ring is on its right (y < 0), as in Sphere2500. */
static void sphere_pose(uint32_t k, uint32_t ring, uint32_t rings, double pose[7])
{
    double theta = SIM_PI * ((double)k / ring + 1.0) / (rings + 1.0);
    double phi = -2.0 * SIM_PI * ((double)(k % ring) / ring);
    double normal[3] = {sin(theta) * cos(phi), sin(theta) * sin(phi), -cos(theta)};
    double along[3] = {sin(phi), -cos(phi), 0.0};
    double left[3], rotation[9];
    sphere_cross(normal, along, left);
    for (int row = 0; row < 3; row++) {
        pose[row] = SPHERE_RADIUS * normal[row];
        rotation[3 * row] = along[row];
        rotation[3 * row + 1] = left[row];
        rotation[3 * row + 2] = normal[row];
    }
    pgem_sim_quat_from_matrix(rotation, pose + 3);
}

int pgem_sim_sphere(const sim_args_t *args, double *truth, pgem_io_graph_t *graph)
{
    uint64_t rng = args->seed;
    uint32_t ring = sphere_ring_size(args->poses);
    uint32_t rings = args->poses / ring + (args->poses % ring != 0u);
    double origin[7], world[7];
    sphere_pose(0, ring, rings, origin);
    for (uint32_t k = 0; k < args->poses; k++) {
        double *pose = truth + 7 * (size_t)k;
        sphere_pose(k, ring, rings, world);
        pgem_se3_between(origin, world, pose);   /* pose 0 is the identity */
        pgem_sim_quat_positive(pose + 3);
        if (k > 0) {
            pgem_sim_se3_edge(graph, k - 1, k, truth, args, &rng);
        }
        if (k >= ring && pgem_cli_uniform(&rng) < args->loop_probability) {
            pgem_sim_se3_edge(graph, k - ring, k, truth, args, &rng);
        }
    }
    return 0;
}
