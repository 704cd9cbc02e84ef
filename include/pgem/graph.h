/** @file
 * pgem graph: poses and edges of a fixed-memory instance, with validation of every input. */
#ifndef PGEM_GRAPH_H
#define PGEM_GRAPH_H

#include <stdint.h>

#include "pgem/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Pose ids are 64-bit and need not be contiguous (GTSAM symbol keys work). */
typedef uint64_t pgem_id_t;

/** Edge kind: odometry edges keep weight 1; loop closures carry a weight the robust layer sets. */
typedef enum pgem_edge_kind {
    PGEM_EDGE_ODOMETRY = 0,
    PGEM_EDGE_LOOP = 1
} pgem_edge_kind_t;

/** Sizes of one pose, tangent vector and information matrix for a dimension (2 or 3). */
#define PGEM_POSE_SIZE(dim) ((dim) == 3 ? 7 : 3)  /* doubles in a pose */
#define PGEM_TANGENT_SIZE(dim) ((dim) == 3 ? 6 : 3) /* rows of an edge error */
#define PGEM_POSE_SIZE_MAX 7
#define PGEM_TANGENT_SIZE_MAX 6

/** A 3D quaternion whose norm is off 1 by more than this is refused; others are normalised. */
#define PGEM_QUAT_NORM_TOLERANCE 0.01

/** Magnitude limits on what goes into a graph: a pose's or measurement's x, y (and z) at most
 * PGEM_TRANSLATION_LIMIT metres in magnitude, every information entry at most
 * PGEM_INFORMATION_LIMIT. Beyond them a call fails with PGEM_ERR_OUT_OF_RANGE. Within them
 * the chi2 of a graph at its inputs is below 1e45 (16 M edges), far from the double range
 * (1.8e308), so no finite input can make a solve start non-finite; 1e8 m holds every frame
 * on Earth (UTM, ECEF), and 1e15 is a standard deviation of 32 nm (the shared datasets reach
 * 2.7e12). 2D angles are wrapped, 3D quaternions normalised: neither needs a limit. A solve
 * that would leave a pose past the translation limit has diverged and fails (pgem_optimize). */
#define PGEM_TRANSLATION_LIMIT 1e8
#define PGEM_INFORMATION_LIMIT 1e15

/** Adds a pose with its initial estimate: 2D [x, y, theta], 3D [x, y, z, qx, qy, qz, qw].
 * A 3D quaternion is normalised; one whose norm is off 1 by more than 1% is rejected.
 * Errors: CAPACITY, DUPLICATE_ID, NOT_FINITE, OUT_OF_RANGE (|x|, |y| or |z| above
 * PGEM_TRANSLATION_LIMIT), ROTATION. */
int pgem_add_pose(pgem_t *graph, pgem_id_t id, const double *pose);

/** Adds an edge: a measurement of pose `to` in the frame of pose `from` (same layout as a pose)
 * with its information matrix, full row-major n x n (n = 3 in 2D, 6 in 3D; in 3D the order is
 * x, y, z then the quaternion-vector rotation error). On success *edge_index (if not NULL)
 * receives the edge's index (edges are numbered 0, 1, ... in the order added).
 * Errors: CAPACITY, UNKNOWN_ID, SELF_LOOP, NOT_FINITE, OUT_OF_RANGE (a translation above
 * PGEM_TRANSLATION_LIMIT or an information entry above PGEM_INFORMATION_LIMIT), INFORMATION
 * (asymmetric or not positive definite), ROTATION, INVALID_ARGUMENT (kind). */
int pgem_add_edge(pgem_t *graph, pgem_id_t from, pgem_id_t to, const double *measurement,
                  const double *information, pgem_edge_kind_t kind, uint32_t *edge_index);

/**
 * The check pgem_add_edge applies to an n x n row-major information matrix (n = 3 or 6), for
 * callers that validate before adding (file checkers, generators): PGEM_OK,
 * PGEM_ERR_NOT_FINITE (an entry is NaN/Inf), PGEM_ERR_OUT_OF_RANGE (an entry's magnitude is
 * above PGEM_INFORMATION_LIMIT), or PGEM_ERR_INFORMATION (not symmetric within 1e-9 of its
 * largest entry, or a Cholesky pivot not above n * DBL_EPSILON * that entry), checked in that
 * order. entry (may be NULL) receives the row-major index of the offending entry: the
 * non-finite or too large one, (i, j) with i < j of an asymmetric pair, or the failing
 * pivot's diagonal entry. Needs no instance and allocates nothing.
 */
int pgem_information_check(const double *information, int n, int *entry);

/**
 * For a matrix pgem_information_check refused at a pivot (PGEM_ERR_INFORMATION on the
 * diagonal): 1 if it is positive definite all the same, every pivot above zero, so what is
 * wrong is its condition number (beyond about 1 / (n * DBL_EPSILON), some 1e15: a factor of
 * it would be rounding noise, e.g. diag(1e15, 1e15, 1e-3)); 0 if a pivot is zero or negative
 * (not positive definite), or for a NULL matrix or another n. For messages; allocates nothing.
 */
int pgem_information_positive(const double *information, int n);

/**
 * The check pgem_add_pose and pgem_set_pose apply to a pose, and pgem_add_edge to a
 * measurement (same layout, dimension 2 or 3), for callers that validate before adding:
 * PGEM_OK, PGEM_ERR_NOT_FINITE (a value is NaN/Inf), PGEM_ERR_OUT_OF_RANGE (|x|, |y| or |z|
 * above PGEM_TRANSLATION_LIMIT), or PGEM_ERR_ROTATION (3D: the quaternion's norm off 1 by
 * more than PGEM_QUAT_NORM_TOLERANCE), checked in that order; PGEM_ERR_INVALID_ARGUMENT for
 * a NULL pose or another dimension. field (may be NULL) receives the index of the offending
 * value (3 for a 3D rotation), else -1. Needs no instance and allocates nothing.
 */
int pgem_pose_check(const double *pose, int dimension, int *field);

/** Holds a pose constant during optimisation (fixed != 0) or frees it. If no pose is fixed
 * when optimising, the first pose added is held (the gauge). Errors: UNKNOWN_ID. */
int pgem_fix_pose(pgem_t *graph, pgem_id_t id, int fixed);

/** The damping (PGEM_GAUGE_DAMPING on the diagonal of its block of the normal equations)
 * that a pose held by pgem_hold_gauge gets: information about nothing, small beside any
 * measurement's, so the pose is free but the part of the graph it is in cannot float. */
#define PGEM_GAUGE_DAMPING 1e-6

/** Holds the gauge of the part of the graph a pose is in without fixing the pose (on != 0),
 * or frees it (a pose fixed by pgem_fix_pose is freed too). The pose stays free: every
 * Gauss-Newton step is damped on its block by PGEM_GAUGE_DAMPING, which leaves the solution
 * where the measurements put it (a converged step is zero whatever the damping) but gives a
 * part no fixed pose holds a definite step: an island of poses joined to the rest by loop
 * closures alone (lost odometry, a second robot), which loop closures may then place, and
 * which stays where it is when they are pruned. pgem_pose_at reports such a pose as free (0).
 * Errors: UNKNOWN_ID. */
int pgem_hold_gauge(pgem_t *graph, pgem_id_t id, int on);

/** Reads or overwrites a pose estimate. Errors: UNKNOWN_ID (and for set: NOT_FINITE,
 * OUT_OF_RANGE, ROTATION). */
int pgem_pose(const pgem_t *graph, pgem_id_t id, double *pose);
int pgem_set_pose(pgem_t *graph, pgem_id_t id, const double *pose);
#ifndef PGEM_NO_FORMER_NAMES
#define pgem_get_pose pgem_pose /* the former name (getters lost get_: docs/API.md) */
#endif

/** Counts and enumeration in insertion order. */
int pgem_dimension(const pgem_t *graph);
uint32_t pgem_pose_count(const pgem_t *graph);
uint32_t pgem_edge_count(const pgem_t *graph);

/** The pose at index (0 .. pose_count-1): its id, estimate (may be NULL) and fixed flag (may be
 * NULL; 1 when fixed by pgem_fix_pose). Errors: INVALID_ARGUMENT. */
int pgem_pose_at(const pgem_t *graph, uint32_t index, pgem_id_t *id, double *pose, int *fixed);
/** The index (insertion order) of the pose with this id. Errors: UNKNOWN_ID, INVALID_ARGUMENT. */
int pgem_pose_index(const pgem_t *graph, pgem_id_t id, uint32_t *index);

/** A read-only view of one edge. */
typedef struct pgem_edge_view {
    pgem_id_t from;                               /**< id of the first pose */
    pgem_id_t to;                                 /**< id of the second pose */
    pgem_edge_kind_t kind;                        /**< odometry or loop closure */
    double measurement[PGEM_POSE_SIZE_MAX];       /**< 3 (2D) or 7 (3D) values used */
    double information[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX]; /**< n x n row-major */
    double weight;                                /**< robust weight in [0, 1]; 1 for odometry */
    int active;                                   /**< 0 once pruned by the robust layer */
} pgem_edge_view_t;

int pgem_edge_at(const pgem_t *graph, uint32_t index, pgem_edge_view_t *view);

/** chi2 of one edge (e^T Omega e, unweighted) under the current estimate. */
int pgem_edge_chi2(const pgem_t *graph, uint32_t index, double *chi2);

/** Total chi2 (sum of e^T Omega e over all edges, unweighted) under the current estimate. */
double pgem_total_chi2(const pgem_t *graph);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_GRAPH_H */
