/* The graph layer, private to lib/core: pose and edge storage in fixed arrays, the id map,
 * each edge's kind, state and weight, and a topology version the layers above compare to
 * notice changes (graph knows nothing of them). Also the edge's error and its chi2. Its calls
 * take the store, the dimension (`tangent`: an edge's error rows, 3 or 6; `dimension`: 2 or
 * 3) or the configuration (for the capacities) and, where they fail with a message, the
 * message buffer (PGEM_MESSAGE_SIZE bytes), never the instance; the public graph calls are
 * these over the instance's store (instance/graph.c). */
#ifndef PGEM_GRAPH_LAYER_H
#define PGEM_GRAPH_LAYER_H

#include "common/common.h"
#include "union_find.h" /* lib/support: the parts of a graph (built into pgem_core) */

/* States of an edge (edge_active). A dormant loop closure (EM weight below the prune
 * threshold) stays in the problem with its weight, but H's structure is not built for it: its
 * coupling block is left out of the Newton matrix unless the structure already has a place
 * for it (linalg/assemble.c). Random false loops would otherwise make the factor dense. */
typedef enum pgem_edge_state {
    PGEM_EDGE_PRUNED = 0,  /* out of the problem until pgem_robust_reset or the gate */
    PGEM_EDGE_ACTIVE = 1,  /* in the problem and in H's structure */
    PGEM_EDGE_DORMANT = 2  /* in the problem; in the structure only if it already was */
} pgem_edge_state_t;

/* What pose_fixed holds for a pose. */
#define PGEM_POSE_FIXED 1u /* held constant: no column in the normal equations */
#define PGEM_POSE_GAUGE 2u /* free, its block damped by PGEM_GAUGE_DAMPING (a part's gauge) */
#define PGEM_POSE_PART 3u  /* the same, held by a robust solve: pruning left its part without a
                              held pose (kept until the next robust solve or pgem_robust_reset) */
#define PGEM_POSE_PART_NEW 4u /* the same, held during the robust solve running (released if
                                 it fails) */

/* 1 if a pose's pose_fixed value damps its block (its part's gauge, held by the user or by a
 * robust solve). */
#define PGEM_POSE_DAMPED(flag) ((flag) >= PGEM_POSE_GAUGE)

/* 1 if pose p is held constant: fixed, or the first pose while none is (the gauge). */
#define PGEM_POSE_HELD(store, p) \
    ((store)->pose_fixed[p] == PGEM_POSE_FIXED || ((store)->fixed_count == 0u && (p) == 0u))

/* The graph's poses and edges (graph->store). */
typedef struct pgem_store {
    uint32_t pose_count;       /* poses added */
    uint32_t topology;         /* +1 on every pose or edge added and every pose fixed or
                                  freed: linalg keeps the version its structure describes */
    uint32_t revision;         /* +1 when estimates or loop weights change outside a solve
                                  (pgem_set_pose, pgem_update, pgem_robust_reset): with
                                  topology, what the covariance calls' factor was made for */
    uint32_t edited_low;       /* the lowest pose index pgem_set_pose moved or whose fixed flag
                                  changed since the incremental update last looked (it sets
                                  UINT32_MAX); it rebuilds when that pose is in its factor */
    pgem_id_t *pose_id;        /* [max_poses] id of each pose, insertion order */
    double *pose;              /* [max_poses * pose_size] current estimate */
    uint8_t *pose_fixed;       /* [max_poses] PGEM_POSE_FIXED if held constant by pgem_fix_pose,
                                  PGEM_POSE_GAUGE if free but damped (pgem_hold_gauge),
                                  PGEM_POSE_PART(_NEW) if damped by a robust solve, else 0 */
    uint32_t fixed_count;      /* poses with pose_fixed PGEM_POSE_FIXED */
    uint32_t map_mask;         /* id map slots - 1 (power of two) */
    uint32_t *map_slot;        /* [map_mask + 1] pose index + 1, 0 = empty */

    uint32_t edge_count;       /* edges added */
    uint32_t solves;           /* pgem_optimize calls and pgem_robust_reset calls that
                                  changed a weight or state: the estimate or the loops moved
                                  outside pgem_update, whose factor is rebuilt when this
                                  changed since it looked */
    uint32_t *edge_from;       /* [max_edges] pose index of the first pose */
    uint32_t *edge_to;         /* [max_edges] pose index of the second pose */
    double *edge_measurement;  /* [max_edges * pose_size] */
    double *edge_information;  /* [max_edges * tangent * tangent] full, row-major */
    uint8_t *edge_kind;        /* [max_edges] pgem_edge_kind_t */
    uint8_t *edge_active;      /* [max_edges] pgem_edge_state_t: active, dormant or pruned */
    double *edge_weight;       /* [max_edges] robust weight, 1 for odometry */
} pgem_store_t;

/* Doubles per pose for an edge's tangent rows (3: SE(2), 6: SE(3)). */
static inline size_t pgem_pose_doubles(int tangent)
{
    return tangent == 6 ? 7u : 3u;
}

/* Carves the store's arrays for config's capacities and the dimension (doubles per pose, rows
 * per edge) from the arena (measuring when arena->base is NULL). */
void pgem_store_carve(pgem_store_t *store, const pgem_config_t *config, int pose_size,
                      int tangent, pgem_arena_t *arena);
/* A graph's poses and edges into an empty instance of the same dimension with room for them
 * (the checks are pgem_copy's). */
void pgem_store_copy(pgem_store_t *to, const pgem_store_t *from, int pose_size, int tangent);
/* Loop closure `index`'s robust weight and state (graph/loop.c; PGEM_ERR_INVALID_ARGUMENT if
 * there is no such edge or no output): pgem_loop_weight and pgem_loop_state on the store. */
int pgem_store_loop_weight(const pgem_store_t *store, uint32_t index, double *weight);
int pgem_store_loop_state(const pgem_store_t *store, uint32_t index, pgem_loop_state_t *state);
/* A robust solve's hold on pose `index` (graph/hold.c): flag PGEM_POSE_PART or
 * PGEM_POSE_PART_NEW, damped as a gauge; the pose stays free, so the structure stands. */
void pgem_pose_hold_part(pgem_store_t *store, uint32_t index, uint8_t flag);
/* Frees the poses a robust solve holds with `flag` (PGEM_POSE_PART_NEW), or with either flag
 * (0); returns how many. */
uint32_t pgem_pose_release_parts(pgem_store_t *store, uint8_t flag);

/* Edges ka and kb, which meet at pose index p, composed into one edge between their other
 * ends (graph/compose.c): *from the other end of ka, *to that of kb, the measurement and
 * information that keep the pair's quadratic form about the estimate (p marginalised out), taking
 * the shares share_a and share_b (in (0, 1]) of the two edges' information. Returns 0 when
 * that information is not a usable one (singular, or refused by pgem_information_check). */
int pgem_edge_compose(const pgem_store_t *store, uint32_t ka, double share_a, uint32_t kb,
                      double share_b, uint32_t p, uint32_t *from, uint32_t *to,
                      double *measurement, double *information, int tangent);

/* Edges ka and kb, which join the same two poses (either way round), fused into one edge
 * from ka's first pose to its second (graph/compose.c): the measurement where the two,
 * weighted by weight_a and weight_b, agree best, and their information together. Returns 0
 * when that information is not a usable one. */
int pgem_edge_fuse(const pgem_store_t *store, uint32_t ka, double weight_a, uint32_t kb,
                   double weight_b, double *measurement, double *information, int tangent);

/* pgem_add_pose, pgem_fix_pose and pgem_hold_gauge (flag PGEM_POSE_FIXED, PGEM_POSE_GAUGE or
 * 0), pgem_pose_index, pgem_pose, pgem_set_pose and pgem_pose_at on the store
 * (graph/pose.c): the checks and messages are those calls'. */
int pgem_store_add_pose(pgem_store_t *store, const pgem_config_t *config, pgem_id_t id,
                        const double *pose, char *message);
int pgem_store_hold(pgem_store_t *store, pgem_id_t id, uint8_t flag, char *message);
int pgem_store_pose_index(const pgem_store_t *store, pgem_id_t id, uint32_t *index);
int pgem_store_pose(const pgem_store_t *store, int dimension, pgem_id_t id, double *pose);
int pgem_store_set_pose(pgem_store_t *store, int dimension, pgem_id_t id, const double *pose,
                        char *message);
int pgem_store_pose_at(const pgem_store_t *store, int dimension, uint32_t index, pgem_id_t *id,
                       double *pose, int *fixed);
/* pgem_add_edge and pgem_edge_at on the store (graph/edge.c). */
int pgem_store_add_edge(pgem_store_t *store, const pgem_config_t *config, pgem_id_t from,
                        pgem_id_t to, const double *measurement, const double *information,
                        pgem_edge_kind_t kind, uint32_t *edge_index, char *message);
int pgem_store_edge_at(const pgem_store_t *store, uint32_t index, pgem_edge_view_t *view,
                       int tangent);
/* Appends edge k's pose ids, "FROM-TO", to message (graph/edge.c). */
void pgem_store_edge_name(const pgem_store_t *store, uint32_t k, char *message);

/* Id map: pose index of id, or -1. */
int64_t pgem_map_find(const pgem_store_t *store, pgem_id_t id);
void pgem_map_insert(pgem_store_t *store, pgem_id_t id, uint32_t index);

/* Checks and normalises a pose of the dimension (2 or 3); on failure message names `what`
 * and the field. */
int pgem_check_pose(char *message, int dimension, const double *pose, double *normalised,
                    const char *what);

/* Checks a tangent x tangent information matrix (finite, symmetric, positive definite); on
 * failure message (PGEM_MESSAGE_SIZE bytes) names the entry. */
int pgem_check_information(char *message, int tangent, const double *information);

/* Error and Jacobians of edge k under the current estimate (Jacobians may be NULL). */
void pgem_edge_error(const pgem_store_t *store, uint32_t k, double *error, double *jacobian_from,
                     double *jacobian_to, int tangent);
/* e^T Omega e for edge k. */
double pgem_edge_mahalanobis(const pgem_store_t *store, uint32_t k, int tangent);
/* e^T Omega e for an n x n Omega (n a constant at each call, so the loops unroll). The one sum
 * behind every chi2: an assembly's and pgem_weighted_chi2's agree to the last bit. */
static inline double pgem_quadratic_form(const double *information, const double *error, int n)
{
    double chi2 = 0.0;
    for (int r = 0; r < n; r++) {
        double row = 0.0;
        for (int c = 0; c < n; c++) {
            row += information[r * n + c] * error[c];
        }
        chi2 += error[r] * row;
    }
    return chi2;
}

/* The blocks one edge contributes (n x n each, row-major, stride n) and its gradient rows.
 * The diagonal blocks are filled in their upper triangle only: all the assembly stores. */
typedef struct pgem_edge_linearisation {
    double from_from[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX]; /* Jf^T W Jf */
    double to_to[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];     /* Jt^T W Jt */
    double from_to[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];   /* Jf^T W Jt */
    double gradient_from[PGEM_TANGENT_SIZE_MAX];                     /* Jf^T W e */
    double gradient_to[PGEM_TANGENT_SIZE_MAX];                       /* Jt^T W e */
} pgem_edge_blocks_t;
/* Edge k linearised at the current estimate and its robust weight w: Jf^T wOmega Jf,
 * Jt^T wOmega Jt, Jf^T wOmega Jt and the gradients Jf^T wOmega e, Jt^T wOmega e into out;
 * returns the weighted chi2 w e^T Omega e (graph/linearise.c; tangent 3 or 6). */
double pgem_edge_linearise(const pgem_store_t *store, uint32_t k, pgem_edge_blocks_t *out,
                           int tangent);

/* Weighted chi2 (edges not pruned, robust weights) under the current estimate; the chi2 of
 * every edge, unweighted (pgem_total_chi2). */
double pgem_weighted_chi2(const pgem_store_t *store, int tangent);
double pgem_store_total_chi2(const pgem_store_t *store, int tangent);

#endif /* PGEM_GRAPH_LAYER_H */
