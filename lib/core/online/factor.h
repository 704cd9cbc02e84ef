/* The incremental factor behind pgem_update: L of the Newton matrix at a linearisation point
 * of its own, one block column per free pose in a pool of blocks that columns grow in, kept
 * current by rank updates along elimination-tree paths. Private to lib/core/online/: the other
 * layers see only online/online.h. */
#ifndef PGEM_ONLINE_FACTOR_H
#define PGEM_ONLINE_FACTOR_H

#include <stddef.h>
#include <stdint.h>

#include "online/online.h"
#include "pgem/geometry.h"
#include "pgem/update.h"

/* Block column j of L lives in the pool from block start[j]: its diagonal block, then
 * count[j] off-diagonal blocks (room for capacity[j]), their block rows rows[start[j] + 1 ..]
 * ascending, all after j. Each block is b x b doubles stored by column: element (r, c) of the
 * block at values[(start + q) b^2 + c b + r]. The diagonal block holds its lower triangle
 * (the upper one is zero). A column that outgrows its room moves to the pool's end; columns
 * never shrink until a rebuild packs them again. */
struct pgem_online {
    int ready;                /* 1 while the factor is L of the system at lin */
    uint32_t solves_seen;     /* graph->store.solves when ready was last brought up to date */
    int block;                /* b: 3 or 6 */
    int columns;              /* block columns in use */
    uint32_t poses_seen;      /* poses the factor has looked at (pose_count at the last update) */
    uint32_t edges_seen;      /* edges the factor has looked at */
    uint32_t poses_linked;    /* poses with pose_edge and lin set up */
    uint32_t edges_linked;    /* edges on their poses' lists */
    uint32_t pool_blocks;     /* b x b blocks in the pool */
    uint32_t pool_used;       /* blocks handed out (holes of moved columns and room included) */
    uint32_t live_blocks;     /* blocks of the columns' patterns: the factor's size */
    uint32_t packed_blocks;   /* live_blocks after the last rebuild */
    uint32_t updates;         /* pgem_update calls that changed the factor since the rebuild */
    uint32_t skipped;         /* updates since poses were last relinearised (or the rebuild) */
    uint32_t skipped_poses;   /* poses added since then */
    int full;                 /* 1: a column could not grow (the pool is full): rebuild */
    int *pose_column;         /* [max_poses] block column of each pose, -1 (held, or not yet in) */
    int *column_pose;         /* [max_poses] pose of each block column */
    int *parent;              /* [max_poses] elimination tree: first off-diagonal row, -1 */
    int *start;               /* [max_poses] first pool block (the diagonal block) of a column */
    int *count;               /* [max_poses] off-diagonal blocks of a column */
    int *capacity;            /* [max_poses] off-diagonal blocks a column has room for */
    int *rows;                /* [pool_blocks] block row of each pool block */
    double *values;           /* [pool_blocks * b * b] */
    double *lin;              /* [max_poses * pose_size] linearisation point of every pose */
    double *delta;            /* [max_poses * b] the step from lin, by column */
    double *forward;          /* [max_poses * b] y with L y = -J^T W e at lin, by column: the
                                 rotations of the updates carry it along */
    double beta[PGEM_TANGENT_SIZE_MAX]; /* the right-hand side of the vectors of an update */
    int *child;               /* [max_poses] first child of a column in the tree, -1 */
    int *sibling;             /* [max_poses] next child of the same parent, -1 */
    int *previous;            /* [max_poses] previous child of the same parent, -1 */
    int *changed;             /* [max_poses] 1: the back-substitution changed the column's step */
    int *recomputed;          /* [max_poses] columns the last back-substitution recomputed */
    int recomputed_count;
    int root;                 /* first root column, -1 */
    double *vector;           /* [max_poses * b * b] a rank-one update's vector (or b of them
                                 interleaved, the marginal's), zero between uses */
    double *edge_weight_in;   /* [max_edges] weight the edge has in the factor (0: not in) */
    int *edge_next;           /* [2 * max_edges] next edge of the same pose (per end), -1 */
    int *pose_edge;           /* [max_poses] first edge end (2 k + side) of a pose, -1 */
    int *mark;                /* [max_poses] stamps of the symbolic passes */
    int *list;                /* [max_poses] a column's rows being gathered; the ordering */
    int *head;                /* [max_poses] rebuild: first column waiting to update a column */
    int *next;                /* [max_poses] rebuild: the next one in the same list */
    int *position;            /* [max_poses] rebuild: next block of a column to update from */
    int *adjacent_start;      /* [max_poses + 1] rebuild: the system's block graph, */
    int *adjacent;            /* [2 * max_edges] by column */
    int *touched;             /* [max_poses] stamp of the update that last changed a column */
    int stamp;                /* stamp of the update under way */
    uint32_t topology_after;  /* the graph's topology and revision after the last successful */
    uint32_t revision_after;  /* update: while both hold, the factor is the graph's */
    pgem_update_summary_t last; /* counters of the update under way; its loops and
                                   loops_pruned run on from update to update */
};

/* A batch solve (pgem_optimize: store->solves) moved the estimate since the factor was last
 * current: the factor is not ready (the next update rebuilds). Called by every entry that
 * reads or sets online->ready. */
static inline void pgem_online_sync(const pgem_online_parts_t *parts)
{
    pgem_online_t *online = parts->online;
    if (online->solves_seen != parts->store->solves) {
        online->ready = 0;
        online->solves_seen = parts->store->solves;
    }
}

/* Pose p's marginal covariance in the system's tangent (b x b, row-major) from the factor: a
 * forward solve along its column's path to the root. 0 when p has no column (held, or not in
 * the factor yet: out untouched), else 1. */
int pgem_online_covariance(const pgem_online_parts_t *parts, uint32_t p, double *out);

/* online/rebuild.c and online/factor.c */
/* The system's ordering, pattern and factor from scratch at lin (poses with columns, edges
 * with edge_weight_in > 0). PGEM_OK, PGEM_ERR_FILL_BUDGET (the pool cannot hold the packed
 * factor: the message gives the blocks needed), PGEM_ERR_OUT_OF_MEMORY (CSparse's ordering),
 * PGEM_ERR_NOT_POSITIVE_DEFINITE. The newest `recent` columns are ordered last. */
int pgem_online_rebuild(const pgem_online_parts_t *parts, int recent);
/* The rows of sqrt(w) U J_from, sqrt(w) U J_to (n x n each, row-major) and sqrt(w) U e of
 * edge k at the poses given (Omega = U^T U): the edge's square-root linearisation. */
void pgem_online_edge(const pgem_store_t *store, int tangent, uint32_t k, const double *from,
                      const double *to, double weight, double *a_from, double *a_to,
                      double *residual);
/* L L^T + sign A A^T for the `rank` (1 .. b) vectors in online->vector (interleaved: entry
 * (scalar s, vector k) at s rank + k; non-zero only in the block columns listed, ascending,
 * at most 2), growing the pattern along the path. PGEM_OK, PGEM_ERR_FILL_BUDGET (the pool is
 * full: online->full), PGEM_ERR_NOT_POSITIVE_DEFINITE (a downdate lost definiteness). The
 * vectors are zero afterwards. */
int pgem_online_rank_update(const pgem_online_parts_t *parts, const int *columns, int column_count,
                            double sign, int rank);
/* Appends a block column for pose p with diagonal block sqrt(seed) I and no rows. */
int pgem_online_append(const pgem_online_parts_t *parts, uint32_t p, double seed);
/* Pool block of block row i in column j (its diagonal block for i == j), or -1. */
int pgem_online_find(const pgem_online_t *online, int j, int i);
/* Marks touched the columns whose values relinearising the `count` poses listed changes
 * (theirs, their neighbours' and all their ancestors) and lists them in online->adjacent;
 * returns how many, and in *work the cost of refactoring them (the sum over the columns of
 * the squared number of blocks they update there: blocks updated, x b^3 flops). */
int pgem_online_affected(const pgem_online_parts_t *parts, const int *poses, int count,
                         double *work);
/* Takes those `count` marks off again. */
void pgem_online_unaffected(const pgem_online_parts_t *parts, int count);
/* Refactors the `count` columns pgem_online_affected marked at lin, in place on the present
 * pattern and from the present values of the other columns, with their part of forward.
 * PGEM_OK or PGEM_ERR_NOT_POSITIVE_DEFINITE (online->ready cleared). */
int pgem_online_refactor(const pgem_online_parts_t *parts, int count);
/* delta = L^-T forward from the roots down, recomputing a column when it was touched by this
 * update or a row's step changed by more than tolerance (negative: every column); the
 * recomputed columns into online->recomputed. */
void pgem_online_back(const pgem_online_parts_t *parts, double tolerance);
/* Column j's parent becomes p (-1: a root), in the tree's child lists. */
void pgem_online_set_parent(pgem_online_t *online, int j, int p);
/* The child lists from parent[] for columns 0 .. columns-1. */
void pgem_online_link_tree(pgem_online_t *online);
/* Y = L^-1 A^T for A (n x (2 b), row-major, by the two columns ca < cb, either -1 when held):
 * the forward solve along the two paths; returns A H^-1 A^T (n x n, row-major) in out. */
void pgem_online_marginal(const pgem_online_parts_t *parts, int ca, int cb, const double *a_a,
                          const double *a_b, int n, double *out);

#endif /* PGEM_ONLINE_FACTOR_H */
