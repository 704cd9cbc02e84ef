/* The supernodal Cholesky factor L of the Newton matrix: its layout (decided by the symbolic
 * analysis), the workspace of a numeric factorisation and the dense kernels behind it. Private
 * to lib/core: linalg's own state, opaque to the other layers (linalg/linear.h). */
#ifndef PGEM_FACTOR_H
#define PGEM_FACTOR_H

#include <stddef.h>
#include <stdint.h>

#include "dense.h"
#include "pgem/graph.h"

struct pgem_linear;

/* Doubles of the dense workspace of one worker (the packed operands of the update products:
 * PGEM_DENSE_KC x (144 + 240), linalg/factor/dense_kernel.h), at most; smaller instances get less
 * (pgem_factor_work_doubles; PGEM_WORK_BYTES in pgem/core.h states the same). */
#define PGEM_DENSE_WORK_MAX 49152u

/* Factorisations of at least this many multiply-adds report their progress. */
#define PGEM_PROGRESS_FLOPS 1e8

/* Supernodes whose subtree holds less than a 1/PGEM_SUBTREE_SHARE of the factorisation's
 * flops are factorised whole by one worker (see linalg/factor/schedule.c). */
#define PGEM_SUBTREE_SHARE 64

/* One worker's private workspace, carved from the block at init. */
typedef struct pgem_factor_worker {
    int *map;            /* [max_poses] block row -> block position inside the target supernode */
    double *work;        /* [work_doubles] packed operands and a product tile */
    size_t work_doubles; /* doubles in work */
} pgem_factor_worker_t;

/* How the factor is laid out, and how a factorisation proceeds.
 *
 * Supernode s owns the block columns super_first[s] .. super_first[s+1]-1 (consecutive after
 * the postordering) and shares one structure below them: the block rows
 * rows[row_start[s] .. row_start[s+1]), ascending, all after its last column. With
 * c = super_first[s+1]-super_first[s] block columns (nc = c b scalar columns) and m block rows
 * below, its values are a lower trapezoid of R = nc + m b rows by nc columns, stored by column
 * from values[value_start[s]]: scalar column j holds local rows j .. R-1 (the supernode's own
 * rows j .. nc-1, then b rows per block row below), so column j starts j R - j (j - 1) / 2
 * values after the supernode's first. A supernode of one block column is exactly the layout of
 * one pose's columns (its diagonal block's rows, then b rows per block below). Relaxed
 * amalgamation merges a chain into one supernode at the price of explicit zeros, counted in
 * nonzeros (what the fill budget must hold). */
/* The fill-reducing orderings (linalg/analysis/ordering.c). */
typedef enum pgem_ordering {
    PGEM_ORDERING_AMD = 0,   /* CSparse's approximate minimum degree on the block graph */
    PGEM_ORDERING_NESTED = 1, /* nested dissection of the block graph (linalg/analysis/nested.c) */
    PGEM_ORDERING_ORDERER = 2 /* the instance's orderer (pgem_set_ordering) */
} pgem_ordering_t;

typedef struct pgem_factor {
    int block;              /* scalar size of a pose block: 3 or 6 */
    pgem_ordering_t ordering; /* the ordering the analysis chose */
    double amd_flops;       /* exact flops (as exact_flops) under each ordering it measured, */
    double nested_flops;    /* -1 if not tried */
    double orderer_flops;
    int block_count;        /* block columns (free poses) */
    int super_count;        /* supernodes */
    int nonzeros;           /* values stored (exact pattern plus amalgamation's zeros) */
    int exact_nonzeros;     /* nonzeros of the exact pattern of L */
    double flops;           /* multiply-adds of a numeric factorisation (with the zeros) */
    double exact_flops;     /* sum of squared scalar column counts of the exact pattern
                               (CHOLMOD's measure of an ordering, about twice the
                               multiply-adds) */
    int *super_first;       /* [max_poses + 1] first block column of each supernode */
    int *block_super;       /* [max_poses] supernode of each block column */
    int *row_start;         /* [max_poses + 1] start of each supernode's rows */
    int *rows;              /* [fill_budget / b^2 + 1] block rows below each supernode */
    int *value_start;       /* [max_poses + 1] first value of each supernode */
    double *values;         /* [fill_budget] */
    /* schedule (linalg/factor/schedule.c): supernodes in the order a factorisation visits them,
     * the subtrees (task_first[t] .. task_first[t+1]-1 of order) that run whole on one
     * worker, then the rest (order[task_first[task_count]] ..), run one by one */
    int *order;             /* [max_poses] */
    int *task_first;        /* [max_poses + 1] */
    int *task_worker;       /* [max_poses] worker of each subtree task for `workers` workers */
    int task_count;         /* subtrees */
    int task_workers;       /* workers task_worker was assigned for (0: not yet) */
    /* numeric state during a factorisation */
    int *head;              /* [max_poses] first supernode waiting to update supernode s */
    int *next;              /* [max_poses] next supernode in the same list */
    int *position;          /* [max_poses] next row (index into rows) a supernode updates */
    pgem_factor_worker_t *workers; /* [worker_count] */
    double *shared;         /* [shared_doubles] the region the analysis's scratch
                               (pgem_linear_scratch), worker 0's dense workspace and the vectors of
                               the solves after a factorisation (the Newton step's conjugate
                               gradients, the marginals' right-hand sides, the inverse's blocks)
                               take turns in: none of them outlives its call */
    size_t shared_doubles;  /* pgem_factor_shared_doubles */
    double progress_done;   /* multiply-adds done by worker 0, times the workers, so far */
    double progress_next;   /* when to report next */
    double progress_share;  /* workers sharing the tasks while worker 0 counts its own */
    int worker_count;       /* workers carved (config.threads) */
} pgem_factor_t;

/* Parent of supernode s in the supernodal elimination tree, -1 for a root. */
static inline int pgem_factor_parent(const pgem_factor_t *factor, const int *block_parent, int s)
{
    const int up = block_parent[factor->super_first[s + 1] - 1];
    return up >= 0 ? factor->block_super[up] : -1;
}

/* Multiply-adds of factorising a trapezoid's columns: column j of h - j values costs
 * (h - j)^2 / 2 (half the measure CHOLMOD reports as flops). */
static inline double pgem_factor_trapezoid_flops(double height, double width)
{
    const double top = height, bottom = height - width; /* sum of t^2, t = bottom+1 .. top */
    return (top * (top + 1.0) * (2.0 * top + 1.0) - bottom * (bottom + 1.0) * (2.0 * bottom + 1.0)) / 12.0;
}

/* Multiply-adds of supernode s's columns. */
double pgem_factor_supernode_flops(const pgem_factor_t *factor, int s);

/* Scalar rows of supernode s's first column (R above). */
static inline int pgem_factor_height(const pgem_factor_t *factor, int s)
{
    return (factor->super_first[s + 1] - factor->super_first[s] +
            factor->row_start[s + 1] - factor->row_start[s]) * factor->block;
}

/* Offset, from value_start[s], of local scalar column j of a trapezoid of `height` rows. */
static inline size_t pgem_factor_column(int height, int j)
{
    return (size_t)j * (size_t)height - (size_t)j * (size_t)(j - 1) / 2u;
}

/* Doubles of dense workspace of a worker (0, 1, ...) of an instance of max_poses poses of
 * block b. */
size_t pgem_factor_work_doubles(uint32_t max_poses, int block, int worker);

/* Doubles of the shared region (pgem_factor_t.shared) of an instance: the most of the
 * analysis's scratch (3 ints per edge, 4 per pose, 4), worker 0's dense workspace and one
 * b x b block per pose (the solves'). */
size_t pgem_factor_shared_doubles(uint32_t max_poses, uint32_t max_edges, int block);

/* Block column J of L as the sparse inverse and the forward solves read it, whatever its
 * supernode: its scalar column c starts at base[c] (the diagonal entry); the diagonal block's
 * element (r, c), r >= c, is base[c][r - c], and off-diagonal block q's element (r, c) is
 * base[c][(b - c) + q b + r]. Block q's block row is J + 1 + q for q < inside (the
 * supernode's own later columns), then below[q - inside]: ascending, and a clique of the
 * stored pattern (relaxed amalgamation's zeros included), so every pair of them is a block
 * of some later column. */
typedef struct pgem_factor_column {
    double *base[PGEM_TANGENT_SIZE_MAX];
    int inside;         /* off-diagonal blocks inside the supernode */
    int count;          /* off-diagonal blocks in all */
    const int *below;   /* the block rows of the rest */
} pgem_factor_column_t;

pgem_factor_column_t pgem_factor_column_view(const pgem_factor_t *factor, int column);

static inline int pgem_factor_column_row(const pgem_factor_column_t *view, int column, int q)
{
    return q < view->inside ? column + 1 + q : view->below[q - view->inside];
}

/* The parent of block column J in the tree the stored pattern follows: the next column of
 * its supernode, or the block elimination tree's parent of the supernode's last column (-1
 * at a root). Every block row of column J is on its path to the root. */
static inline int pgem_factor_column_parent(const pgem_factor_t *factor, const int *block_parent,
                                            int column)
{
    const int s = factor->block_super[column];
    return column + 1 < factor->super_first[s + 1] ? column + 1 : block_parent[column];
}

/* linalg/factor/supernodes.c: supernodes, their rows and the layout from the block elimination tree
 * (linear->block_parent, postordered) and block column counts; returns the nonzeros the
 * factor needs (more than fill_budget: nothing else was written), or a negative error. */
int64_t pgem_supernodes_analyze(struct pgem_linear *linear, const int *counts,
                                uint32_t fill_budget);

/* linalg/factor/schedule.c: tasks and order of a factorisation; tasks to workers. */
void pgem_schedule_analyze(struct pgem_linear *linear);
void pgem_schedule_assign(pgem_factor_t *factor, int workers);

/* linalg/factor/blocks.c: one-block supernodes. The update of d (a single block column) into
 * ancestor s, its rows from position[d] on, the first `inside` of them in s; map as the
 * worker's. The factorisation of a one-block trapezoid; returns the failing column or -1. */
void pgem_block_update(const pgem_factor_t *factor, int d, int s, int inside, const int *map);
int pgem_block_factor(double *values, int height, int block);

/* linalg/factor/numeric.c: a factorisation is pgem_numeric_begin, every task (in any order, at
 * the same time on different workers), then pgem_numeric_top. The last two return PGEM_OK or
 * PGEM_ERR_NOT_POSITIVE_DEFINITE with *failed the scalar column of the first pivot that was
 * not positive. */
void pgem_numeric_begin(struct pgem_linear *linear);
int pgem_numeric_task(struct pgem_linear *linear, int task, const pgem_factor_worker_t *worker,
                      int *failed);
int pgem_numeric_top(struct pgem_linear *linear, const pgem_factor_worker_t *worker, int *failed);

#endif /* PGEM_FACTOR_H */
