/* pgem simulate, 3D pieces shared by the sphere and grid worlds: noisy SE(3) edges with the
 * information matching their noise, and rotation matrices to quaternions. */
#include <math.h>
#include <string.h>

#include "simulate.h"

void pgem_sim_se3_edge(pgem_io_graph_t *graph, uint32_t from, uint32_t to, const double *truth,
                       const sim_args_t *args, uint64_t *rng)
{
    pgem_io_edge_t *edge = &graph->edges[graph->edge_count++];
    memset(edge, 0, sizeof *edge);
    edge->from = from;
    edge->to = to;
    double between[7], noise[6];
    pgem_se3_between(truth + 7 * (size_t)from, truth + 7 * (size_t)to, between);
    for (int axis = 0; axis < 3; axis++) {
        noise[axis] = args->sigma_translation * pgem_cli_gaussian(rng);
    }
    for (int axis = 3; axis < 6; axis++) {
        noise[axis] = args->sigma_rotation * pgem_cli_gaussian(rng);
    }
    /* Z = T (rho, Exp(phi)), so at the truth the g2o error is that of (rho, Exp(phi))^-1:
     * translation -Exp(phi)^T rho (isotropic, variance sigma_t^2 per axis) and quaternion
     * vector -sin(|phi|/2) phi/|phi| ~ -phi/2 (variance sigma_r^2 / 4 per axis). */
    pgem_se3_boxplus(between, noise, edge->measurement);
    pgem_sim_quat_positive(edge->measurement + 3);
    double t = 1.0 / fmax(args->sigma_translation * args->sigma_translation, 1e-12);
    double r = 4.0 / fmax(args->sigma_rotation * args->sigma_rotation, 1e-12);
    for (int axis = 0; axis < 6; axis++) {
        edge->information[axis * 6 + axis] = axis < 3 ? t : r;
    }
    edge->kind = to == from + 1u ? PGEM_EDGE_ODOMETRY : PGEM_EDGE_LOOP;
}

/* Shepperd's method: build the quaternion from its largest component (well conditioned). */
void pgem_sim_quat_from_matrix(const double rotation[9], double q[4])
{
    const double *m = rotation;
    double trace = m[0] + m[4] + m[8];
    if (trace >= m[0] && trace >= m[4] && trace >= m[8]) {
        double s = 2.0 * sqrt(1.0 + trace);
        q[0] = (m[7] - m[5]) / s;
        q[1] = (m[2] - m[6]) / s;
        q[2] = (m[3] - m[1]) / s;
        q[3] = 0.25 * s;
    } else if (m[0] >= m[4] && m[0] >= m[8]) {
        double s = 2.0 * sqrt(1.0 + m[0] - m[4] - m[8]);
        q[0] = 0.25 * s;
        q[1] = (m[1] + m[3]) / s;
        q[2] = (m[2] + m[6]) / s;
        q[3] = (m[7] - m[5]) / s;
    } else if (m[4] >= m[8]) {
        double s = 2.0 * sqrt(1.0 + m[4] - m[0] - m[8]);
        q[0] = (m[1] + m[3]) / s;
        q[1] = 0.25 * s;
        q[2] = (m[5] + m[7]) / s;
        q[3] = (m[2] - m[6]) / s;
    } else {
        double s = 2.0 * sqrt(1.0 + m[8] - m[0] - m[4]);
        q[0] = (m[2] + m[6]) / s;
        q[1] = (m[5] + m[7]) / s;
        q[2] = 0.25 * s;
        q[3] = (m[3] - m[1]) / s;
    }
    pgem_sim_quat_positive(q);
    pgem_quat_normalize(q);
}

void pgem_sim_quat_positive(double q[4])
{
    if (q[3] < 0.0) {
        for (int k = 0; k < 4; k++) {
            q[k] = -q[k];
        }
    }
}
