/* The linalg layer's state, private to lib/core/linalg: the sparse structure of H, its
 * values, the factor and the solves' vectors, with the helpers linalg's files share. The other
 * layers see pgem_linear_t as an opaque type and use the calls of linalg/linalg.h. */
#ifndef PGEM_LINEAR_H
#define PGEM_LINEAR_H

#include "linalg/factor/factor.h"
#include "linalg/linalg.h"
#include "pgem_cs.h"

/* CSparse's workspace inside the block (source-built CSparse only; see linalg/cs_pool.c).
 * With the system CSparse the region is empty and CSparse uses the C heap. */
typedef struct pgem_cs_pool {
    unsigned char *base;   /* start of the region */
    size_t size;           /* bytes in the region */
    size_t used;           /* bytes handed out (with headers) while open */
    size_t top;            /* offset of the topmost slice's header */
    size_t peak;           /* most bytes ever in use */
} pgem_cs_pool_t;

/* Bytes of the region for the given capacities (0 with the system CSparse). */
size_t pgem_cs_pool_bytes(uint32_t max_poses, uint32_t max_edges);
/* Routes CSparse's allocations to pool, emptied, until close. */
void pgem_cs_open(pgem_cs_pool_t *pool);
void pgem_cs_close(pgem_cs_pool_t *pool);

/* Sparse structure and numeric workspace of the normal equations H dx = -b. */
struct pgem_linear {
    int valid;                 /* 1 while the structure matches the graph's topology */
    int ordered;               /* 1 while pose_block holds a fill-reducing ordering of the
                                  graph's topology (kept when an analysis fails on the fill
                                  budget, handed over by pgem_copy) */
    int all_edges;             /* 1: the structure also holds pruned (inactive) edges, the
                                  fallback when leaving them out would need more fill */
    int block;             /* scalar size of a pose block: 3 (2D) or 6 (3D) */
    int block_count;       /* free poses in the structure */
    int scalar_count;      /* block_count * block */
    int *pose_block;       /* [max_poses] pose index -> permuted block, -1 if held fixed */
    int *edge_offset;      /* [max_edges] offset of the edge's off-diagonal block inside
                                  its scalar column's off-diagonal part, -1 if the edge
                                  touches a fixed pose */
    uint8_t *edge_transposed;  /* [max_edges] 1 if the stored block is H_ji, not H_ij */
    int *block_colptr;     /* [max_poses + 1] block pattern of H (strictly lower, permuted) */
    int *block_rows;       /* [max_edges] block row indices of that pattern */
    int *block_parent;     /* [max_poses] elimination tree of the block pattern (postordered) */
    int *lower_start;      /* [max_poses + 1] permuted lower triangle of H: first value of
                                  each block column (its scalar columns follow each other, see
                                  pgem_lower_column); the rows are implied by the block
                                  pattern (see linalg/analysis/analyze.c), so only values are
                                  stored */
    double *lower_values;      /* [max_edges * b^2 + max_poses * b(b+1)/2] refilled every
                                  iteration */
    pgem_factor_t factor;      /* L, supernodal (linalg/factor/factor.h) */
    const pgem_dense_ops_t *dense; /* the dense kernels this CPU runs (linalg/factor/dense.h) */
    double *rhs;               /* [max_poses * block] -b in permuted order, then the step */
    double *diagonal;          /* [max_poses * block] diagonal of H (LM damping) */
    double *gradient;          /* [max_poses * block] copy of -b kept across LM retries */
    uint32_t analyses;         /* symbolic analyses run so far */
    uint32_t left_out;         /* couplings the last assembly left out of the structure */
    pgem_cs_pool_t cs_pool;    /* CSparse's workspace during analyses */
    const pgem_solve_options_t *progress; /* the running solve's options (its on_progress),
                                  NULL outside a solve */
    uint32_t progress_iteration; /* the iteration the next factorisation belongs to */
    uint32_t topology;         /* the graph's topology version valid and ordered refer to */
    pgem_orderer_t orderer;    /* an ordering to weigh against AMD's (order NULL: none) */
    pgem_order_choice_t ordering_choice; /* which orderings the analysis uses */
    int covariance;            /* what the factor holds for the covariance calls
                                  (linalg/query/covariance.c): PGEM_COVARIANCE_NONE (every assembly,
                                  factorisation, inverse and analysis sets it), _FACTOR (L of H
                                  at the estimate pgem_covariance_prepare saw) or _INVERSE (H^-1
                                  on L's pattern, written over L) */
    uint32_t covariance_topology; /* the graph's topology version when it was set */
    uint32_t covariance_revision; /* the graph's revision (estimate and weights) then */
};

/* Forgets the structure and the ordering if the graph's topology changed since they were
 * built, and takes its version (linalg/analysis/structure.c). */
void pgem_linear_follow(pgem_linear_t *linear, const pgem_store_t *store);

/* First value of scalar column c of block column `block` of H's lower triangle: each of the
 * block's scalar columns holds its diagonal block's rows c .. b-1, then b rows per
 * off-diagonal block in block_rows order. */
static inline int pgem_lower_column(const pgem_linear_t *linear, int block, int c)
{
    const int b = linear->block;
    const int off_diagonal = (linear->block_colptr[block + 1] - linear->block_colptr[block]) * b;
    return linear->lower_start[block] + c * (b + off_diagonal) - c * (c - 1) / 2;
}

/* The symbolic workspace of an analysis ([3 * max_edges + 4 * max_poses + 4] ints): the start
 * of the region it shares with worker 0's dense workspace and the solves' vectors. */
static inline int *pgem_linear_scratch(const pgem_linear_t *linear)
{
    return (int *)(void *)linear->factor.shared;
}

/* Block pattern of H (linalg/analysis/pattern.c). */
/* 1 if edge k has an off-diagonal block in H's structure: both poses free, and the edge
 * active (or every edge, in the fallback). *a, *b receive the poses' permuted blocks. */
static inline int pgem_edge_blocks(const pgem_linear_t *linear, const pgem_store_t *store,
                                   uint32_t k, int *a, int *b)
{
    *a = linear->pose_block[store->edge_from[k]];
    *b = linear->pose_block[store->edge_to[k]];
    return *a >= 0 && *b >= 0 &&
           (linear->all_edges || store->edge_active[k] == PGEM_EDGE_ACTIVE);
}
int pgem_pattern_number_free(pgem_linear_t *linear, const pgem_store_t *store);
/* The fill-reducing ordering into pose_block (linalg/analysis/ordering.c); nested dissection
 * works in H's values, sized by the config's capacities. */
int pgem_pattern_order(pgem_linear_t *linear, const pgem_store_t *store,
                       const pgem_config_t *config, int block_count);
void pgem_pattern_build(const pgem_linear_t *linear, const pgem_store_t *store, int block_count,
                        int *colptr, int *rows, int *work);
/* The transpose of a block pattern (block_count columns, rows sorted): sorted rows again. */
void pgem_pattern_transpose(int block_count, const int *colptr, const int *rows, int *out_colptr,
                            int *out_rows);

#endif /* PGEM_LINEAR_H */
