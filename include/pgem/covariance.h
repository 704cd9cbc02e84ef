/** @file
 * pgem covariance: marginal covariances of poses at the current estimate, from the factor of
 * the normal equations, without allocation. */
#ifndef PGEM_COVARIANCE_H
#define PGEM_COVARIANCE_H

#include <stdint.h>

#include "pgem/core.h"
#include "pgem/graph.h"

#ifdef __cplusplus
extern "C" {
#endif

/**
 * Factors the normal equations H = J^T W J at the current estimate and weights (active edges
 * at their robust weights; pruned loops contribute nothing, and a dormant loop, weighing less
 * than its dormant threshold, may be left out of H) for the calls below, which use that factor
 * until the graph changes: a solve, pgem_update, pgem_set_pose, pgem_fix_pose,
 * pgem_hold_gauge, pgem_robust_reset, an added pose or edge. It does what one Gauss-Newton
 * iteration does before its step (the analysis when the topology changed, the assembly, the
 * factorisation) and moves no pose. Errors: INVALID_ARGUMENT, EMPTY, NOT_POSITIVE_DEFINITE (a
 * part of the graph no held pose holds), NUMERIC, FILL_BUDGET, OUT_OF_MEMORY (as pgem_optimize).
 */
int pgem_covariance_prepare(pgem_t *graph);

/**
 * The marginal covariance of pose id, n x n row-major (n = 3 in 2D, 6 in 3D), in the tangent
 * space on the right of the estimate (body frame), as GTSAM's Pose2 and Pose3: the pose is
 * X exp(d), d ~ N(0, covariance).
 * - 2D: d = (x, y, theta), exactly GTSAM's Pose2 order and frame.
 * - 3D: d = (x, y, z, rx, ry, rz), translation first, the rotation as a rotation vector
 *   (angle-axis, radians) on the right. GTSAM's Pose3 puts the rotation first: its covariance
 *   is P C P^T for P the permutation that swaps the two 3-blocks
 *   (gtsam[i][j] = pgem[(i + 3) % 6][(j + 3) % 6]).
 * A held pose (fixed, or the first pose while none is fixed) has covariance zero. A solve
 * along the pose's path to the root of the factor's elimination tree (or, after
 * pgem_covariances, a read of its block). Errors: INVALID_ARGUMENT, UNKNOWN_ID, NO_FACTOR (no
 * pgem_covariance_prepare since the graph last changed).
 */
int pgem_covariance(pgem_t *graph, pgem_id_t id, double *covariance);

/**
 * The joint marginal covariance of poses a and b, 2n x 2n row-major: a's tangent first, then
 * b's, each as pgem_covariance gives it (the diagonal blocks are the two poses' marginals).
 * Four solves along the two poses' paths. Errors: as pgem_covariance.
 */
int pgem_joint_covariance(pgem_t *graph, pgem_id_t a, pgem_id_t b, double *covariance);

/**
 * Every pose's marginal covariance in one pass: pose_count blocks of n x n (row-major), in
 * insertion order (the order of pgem_pose_at), held poses zero. One sparse inverse of H on
 * the factor's pattern (Takahashi's recursion, written over the factor); pgem_covariance then
 * reads its blocks, and pgem_joint_covariance factors again first. Errors: INVALID_ARGUMENT,
 * NO_FACTOR.
 */
int pgem_covariances(pgem_t *graph, double *covariances);

/**
 * The marginal covariance of pose id from the incremental factor of the last pgem_update, as
 * pgem_covariance gives it (n x n row-major, body frame, a held pose zero), without factoring
 * anything: a solve along the pose's path to the root of that factor's elimination tree. New
 * poses are ordered last, so the newest pose's path is a few blocks and the call costs
 * microseconds whatever the map's size (an older pose's path may cross the whole tree). The
 * factor is linearised where pgem_update left its points (each pose within its
 * relinearize_threshold of the estimate), with the weights its gate gave: the marginal at
 * those points, as iSAM2's; pgem_covariance_prepare and pgem_covariance give the one at the
 * estimate itself (they agree once the updates have converged). Nothing is allocated; the
 * factor is not changed. Errors: INVALID_ARGUMENT, UNKNOWN_ID, CONFIG (no config.online_fill),
 * NO_FACTOR (no successful pgem_update since the last change to the graph by anything else:
 * what pgem_covariance_prepare lists, a solve included; or no edge of the pose is in the
 * factor yet).
 */
int pgem_update_covariance(pgem_t *graph, pgem_id_t id, double *covariance);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_COVARIANCE_H */
