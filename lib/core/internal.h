/* Private layout of a pgem instance and the helpers shared by the core's files. */
#ifndef PGEM_INTERNAL_H
#define PGEM_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "pgem/pgem.h"
#include "pgem/robust.h"
#include "pgem_cs.h"
#include "linalg/factor.h"
#include "linalg/online.h"

#define PGEM_MESSAGE_SIZE 256

/* A bump allocator over the caller's block; with base == NULL it only measures. */
typedef struct pgem_arena {
    unsigned char *base;  /* start of the block (NULL: measuring pass) */
    size_t size;          /* bytes available */
    size_t used;          /* bytes carved so far, including alignment padding */
    size_t carves;        /* slices asked for from the block (not counted when measuring) */
    size_t failed;        /* number (1, 2, ...) of the first slice that could not be carved,
                             0 if none */
    size_t failed_bytes;  /* bytes that slice asked for */
} pgem_arena_t;

/* Returns an aligned slice of count * item bytes, or NULL when measuring or out of room
 * (then used still grows, so a measuring pass yields the total, and a failed carve is
 * recorded in failed). */
void *pgem_arena_take(pgem_arena_t *arena, size_t count, size_t item);

/* Fault injection for the memory-exhaustion test (tests/test_exhaustion.c), compiled only into
 * a test copy of the core (PGEM_FAULT_INJECTION; the released library never has it):
 * pgem_fault_next() is asked once per carve from the block and once per CSparse allocation
 * from its pool, and says 1 for the one the test chose. Without the define it is 0. */
#ifdef PGEM_FAULT_INJECTION
int pgem_fault_next(void);
/* From now on, request number `index` (0, 1, ...) fails; a negative index counts only. */
void pgem_fault_arm(long index);
/* Requests seen since pgem_fault_arm (the sweep is over once a run sees no more than index). */
long pgem_fault_seen(void);
#else
#define pgem_fault_next() 0
#endif

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
typedef struct pgem_linear {
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
    int *scratch;          /* [3 * max_edges + 4 * max_poses + 4] symbolic workspace */
    int *lower_start;      /* [max_poses + 1] permuted lower triangle of H: first value of
                                  each block column (its scalar columns follow each other, see
                                  pgem_lower_column); the rows are implied by the block
                                  pattern (see linalg/analyze.c), so only values are stored */
    double *lower_values;      /* [max_edges * b^2 + max_poses * b(b+1)/2] refilled every
                                  iteration */
    pgem_factor_t factor;      /* L, supernodal (linalg/factor.h) */
    const pgem_dense_ops_t *dense; /* the dense kernels this CPU runs (linalg/dense.h) */
    double *rhs;               /* [max_poses * block] -b in permuted order, then the step */
    double *diagonal;          /* [max_poses * block] diagonal of H (LM damping) */
    double *gradient;          /* [max_poses * block] copy of -b kept across LM retries */
    uint32_t analyses;         /* symbolic analyses run so far */
    uint32_t left_out;         /* couplings the last assembly left out of the structure */
    pgem_cs_pool_t cs_pool;    /* CSparse's workspace during analyses */
    const pgem_solve_options_t *progress; /* the running solve's options (its on_progress),
                                  NULL outside a solve */
    uint32_t progress_iteration; /* the iteration the next factorisation belongs to */
} pgem_linear_t;

/* First value of scalar column c of block column `block` of H's lower triangle: each of the
 * block's scalar columns holds its diagonal block's rows c .. b-1, then b rows per
 * off-diagonal block in block_rows order. */
static inline int pgem_lower_column(const pgem_linear_t *linear, int block, int c)
{
    const int b = linear->block;
    const int off_diagonal = (linear->block_colptr[block + 1] - linear->block_colptr[block]) * b;
    return linear->lower_start[block] + c * (b + off_diagonal) - c * (c - 1) / 2;
}

/* States of an edge (edge_active). A dormant loop closure (EM weight below the prune
 * threshold) stays in the problem with its weight, but H's structure is not built for it: its
 * coupling block is left out of the Newton matrix unless the structure already has a place
 * for it (linalg/assemble.c). Random false loops would otherwise make the factor dense. */
typedef enum pgem_edge_state {
    PGEM_EDGE_PRUNED = 0,  /* out of the problem until pgem_robust_reset or the gate */
    PGEM_EDGE_ACTIVE = 1,  /* in the problem and in H's structure */
    PGEM_EDGE_DORMANT = 2  /* in the problem; in the structure only if it already was */
} pgem_edge_state_t;

struct pgem {
    pgem_config_t config;      /* resolved configuration */
    int pose_size;             /* doubles per pose: 3 or 7 */
    int tangent;               /* error rows per edge: 3 or 6 */
    size_t block_bytes;        /* size of the caller's block */
    size_t used_bytes;         /* bytes carved at init */
    void *hosted_block;        /* block malloc'ed by pgem_create (NULL for pgem_init) */

    uint32_t pose_count;       /* poses added */
    pgem_id_t *pose_id;        /* [max_poses] id of each pose, insertion order */
    double *pose;              /* [max_poses * pose_size] current estimate */
    double *pose_saved;        /* [max_poses * pose_size] estimate before a solve */
    double *pose_accepted;     /* [max_poses * pose_size] last accepted LM estimate */
    double *pose_initial;      /* [max_poses * pose_size] estimate before a robust solve */
    uint8_t *pose_fixed;       /* [max_poses] 1 if held constant by pgem_fix_pose */
    uint32_t fixed_count;      /* poses with pose_fixed set */
    uint32_t map_mask;         /* id map slots - 1 (power of two) */
    uint32_t *map_slot;        /* [map_mask + 1] pose index + 1, 0 = empty */

    uint32_t edge_count;       /* edges added */
    uint32_t *edge_from;       /* [max_edges] pose index of the first pose */
    uint32_t *edge_to;         /* [max_edges] pose index of the second pose */
    double *edge_measurement;  /* [max_edges * pose_size] */
    double *edge_information;  /* [max_edges * tangent * tangent] full, row-major */
    uint8_t *edge_kind;        /* [max_edges] pgem_edge_kind_t */
    uint8_t *edge_active;      /* [max_edges] pgem_edge_state_t: active, dormant or pruned */
    double *edge_weight;       /* [max_edges] robust weight, 1 for odometry */
    double *edge_weight_saved; /* [max_edges] weights before a robust solve, and */
    uint8_t *edge_active_saved; /* [max_edges] states: put back if the solve fails */
    double *edge_distance;     /* [max_edges] a loop's distance in the last E-step or test */
    uint8_t *edge_checked;     /* [max_edges] 1 if the map predicted the loop (innovation) */

    pgem_linear_t linear;      /* normal equations */
    pgem_executor_t executor;  /* threads of the factorisation (run NULL: the caller's only) */
    pgem_online_t online;      /* the incremental factor of pgem_update (linalg/online.h) */
    char message[PGEM_MESSAGE_SIZE]; /* last error message */
};

/* Bytes of the whole estimate (every pose), for copies between the estimate buffers. */
static inline size_t pgem_pose_bytes(const pgem_t *graph)
{
    return (size_t)graph->pose_count * (size_t)graph->pose_size * sizeof(double);
}

/* Carves every array of an instance from the arena (measuring when arena->base is NULL). */
void pgem_carve(pgem_t *graph, pgem_arena_t *arena);

/* Text building without stdio (firmware-safe): appends to a NUL-terminated text of size
 * bytes, truncating. */
void pgem_text_append(char *text, size_t size, const char *piece);
void pgem_text_u64(char *text, size_t size, uint64_t value);

/* Message building into the instance: clear, then append pieces. */
void pgem_message_clear(pgem_t *graph);
void pgem_message_text(pgem_t *graph, const char *text);
void pgem_message_u64(pgem_t *graph, uint64_t value);
void pgem_message_i64(pgem_t *graph, int64_t value);
/* Sets the message to text and returns code (for one-line error returns). */
int pgem_fail(pgem_t *graph, int code, const char *text);

/* Id map: pose index of id, or -1. */
int64_t pgem_map_find(const pgem_t *graph, pgem_id_t id);
void pgem_map_insert(pgem_t *graph, pgem_id_t id, uint32_t index);

/* Checks and normalises a pose; names the field in the message on failure. */
int pgem_check_pose(pgem_t *graph, const double *pose, double *normalised, const char *what);

/* Checks an n x n information matrix (finite, symmetric, positive definite). */
int pgem_check_information(pgem_t *graph, const double *information);

/* Error and Jacobians of edge k under the current estimate (Jacobians may be NULL). */
void pgem_edge_error(const pgem_t *graph, uint32_t k, double *error, double *jacobian_from,
                     double *jacobian_to);
/* e^T Omega e for edge k. */
double pgem_edge_mahalanobis(const pgem_t *graph, uint32_t k);
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

/* Block pattern of H (linalg/pattern.c). */
/* 1 if edge k has an off-diagonal block in H's structure: both poses free, and the edge
 * active (or every edge, in the fallback). *a, *b receive the poses' permuted blocks. */
static inline int pgem_edge_blocks(const pgem_t *graph, uint32_t k, int *a, int *b)
{
    *a = graph->linear.pose_block[graph->edge_from[k]];
    *b = graph->linear.pose_block[graph->edge_to[k]];
    return *a >= 0 && *b >= 0 &&
           (graph->linear.all_edges || graph->edge_active[k] == PGEM_EDGE_ACTIVE);
}
int pgem_pattern_number_free(pgem_t *graph);
int pgem_pattern_order(pgem_t *graph, int block_count);
void pgem_pattern_build(pgem_t *graph, int block_count, int *colptr, int *rows, int *work);
/* The transpose of a block pattern (block_count columns, rows sorted): sorted rows again. */
void pgem_pattern_transpose(int block_count, const int *colptr, const int *rows, int *out_colptr,
                            int *out_rows);

/* Linear layer. */
int pgem_linear_analyze(pgem_t *graph);
/* PGEM_ERR_NOT_POSITIVE_DEFINITE, naming a pose, if a part of the graph (edges not pruned)
 * has no held pose; needs the numbering of a valid analysis (linalg/analyze.c). */
int pgem_linear_check_parts(pgem_t *graph);
/* PGEM_ERR_INVALID_ARGUMENT with "option NAME is not a finite number" unless value is finite
 * (solver/optimize.c). */
int pgem_check_option(pgem_t *graph, double value, const char *name);
/* The method and every double of solve options (NULL: fine), as pgem_optimize checks them. */
int pgem_check_solve_options(pgem_t *graph, const pgem_solve_options_t *options);
double pgem_linear_assemble(pgem_t *graph);
void pgem_linear_damp(pgem_t *graph, double lambda);
int pgem_linear_factor(pgem_t *graph);
void pgem_linear_solve(pgem_t *graph, double *step);
void pgem_linear_invalidate(pgem_t *graph);
/* y = H x with the assembled values (linalg/multiply.c); y += D x for the couplings the
 * assembly left out (linalg/assemble.c). */
void pgem_linear_multiply(const pgem_t *graph, const double *x, double *y);
void pgem_linear_left_out_multiply(const pgem_t *graph, const double *x, double *y);
/* Solves (H + D) step = rhs in place (rhs: linear->rhs): the factor's solve, refined by
 * conjugate gradients preconditioned with it when couplings were left out (solver/newton.c).
 * Returns PGEM_OK, or PGEM_ERR_NUMERIC if the refinement did not converge. */
int pgem_solve_newton(pgem_t *graph);
/* out = A H^-1 A^T (n x n) for A = [a_from a_to] on poses from and to (n x n blocks,
 * row-major), from the current factor (linalg/marginal.c). */
void pgem_linear_marginal(pgem_t *graph, uint32_t from, uint32_t to, const double *a_from,
                          const double *a_to, double *out);
/* A loop's innovation (robust/innovation.c): its distance with the odometry allowance, the
 * same without it (inflation 1), and the predicted rotation's standard deviation (radians). */
typedef struct pgem_innovation {
    double distance;     /* d^2 under Omega^-1 + inflation J Sigma_-k J^T */
    double plain;        /* d^2 under Omega^-1 + J Sigma_-k J^T */
    double rotation_sd;  /* sqrt of the rotation block's trace of J Sigma_-k J^T */
} pgem_innovation_t;
/* Loop k's innovation under the current factor, in which it has weight `weight` (0 when
 * pruned); its marginal from the sparse inverse (from_inverse) or by a solve with L. */
void pgem_loop_innovation(pgem_t *graph, uint32_t k, double weight, double inflation,
                          int from_inverse, pgem_innovation_t *out);
/* For a pruned loop, after pgem_linear_invert: 1 if it passes `gate` however the map predicts
 * it (its chi2 and its predicted error are below it), -1 if it fails it however (its chi2 and
 * a lower bound of its innovation are above it), 0 if only the innovation can tell;
 * *distance is the measure that decided (robust/innovation.c). */
int pgem_loop_screen(pgem_t *graph, uint32_t k, double inflation, double gate, double *distance);
/* EM's E-step (robust/estep.c): every loop's distance (every loop, pruned ones included, in
 * the consistency test: gating), then the weights; returns the largest weight change. */
void pgem_em_distances(pgem_t *graph, const pgem_robust_options_t *options, int gating,
                       double gate);
double pgem_em_e_step(pgem_t *graph, const pgem_robust_options_t *options);
/* H^-1 on the factor's pattern, over the factor (linalg/inverse.c); then the marginal of two
 * poses joined by a block of the pattern (PGEM_ERR_INVALID_ARGUMENT if they are not). */
void pgem_linear_invert(pgem_t *graph);
int pgem_linear_marginal_inverse(pgem_t *graph, uint32_t from, uint32_t to, const double *a_from,
                                 const double *a_to, double *out);
/* The same without the cross term: A_f Z_ff A_f^T + A_t Z_tt A_t^T, which is at least half of
 * A H^-1 A^T (for any pair of poses, on the pattern or not). */
void pgem_linear_marginal_diagonal(pgem_t *graph, uint32_t from, uint32_t to, const double *a_from,
                                   const double *a_to, double *out);

/* Weighted chi2 (edges not pruned, robust weights) under the current estimate. */
double pgem_weighted_chi2(const pgem_t *graph);

/* Solver pieces shared by Gauss-Newton and Levenberg-Marquardt. */
/* Applies the step held in linear->rhs (permuted order) to every free pose. */
void pgem_apply_step(pgem_t *graph, const double *step);
/* Euclidean norm of a vector; NaN/Inf propagate. */
double pgem_norm(const double *values, int count);
/* Reports an iteration to the callback; returns non-zero if it asks to stop. */
int pgem_report(const pgem_solve_options_t *options, uint32_t iteration, double chi2,
                double step_norm, double lambda, int accepted);
/* Relative chi2 decrease below tolerance (negative tolerance: never; zero chi2: always). */
int pgem_chi2_converged(double before, double after, double tolerance);
/* Sets the message for a non-finite chi2 or step and returns PGEM_ERR_NUMERIC. */
int pgem_fail_numeric(pgem_t *graph, const char *what, uint32_t iteration);

int pgem_gauss_newton(pgem_t *graph, const pgem_solve_options_t *options, pgem_summary_t *summary);
int pgem_levenberg_marquardt(pgem_t *graph, const pgem_solve_options_t *options,
                             pgem_summary_t *summary);

#endif /* PGEM_INTERNAL_H */
