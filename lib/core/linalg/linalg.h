/* The linalg layer's calls, private to lib/core: the normal equations H dx = -b of the graph
 * (structure, assembly, factor, solves, marginals). Its state (linalg/linear.h) is opaque to
 * the layers above, which reach it only through these calls; it reads the graph layer and
 * notices topology changes by the graph's version. */
#ifndef PGEM_LINALG_LAYER_H
#define PGEM_LINALG_LAYER_H

#include "graph/graph.h"

typedef struct pgem_linear pgem_linear_t; /* defined in linalg/linear.h */

/* Carves the linear system's state and arrays for a resolved config and the tangent size (3
 * or 6); returns the state, NULL when measuring (arena->base NULL) or out of room. Then picks
 * the dense kernels of this CPU (pgem_linear_start, on a carved state). */
pgem_linear_t *pgem_linear_carve(const pgem_config_t *config, int tangent, pgem_arena_t *arena);
void pgem_linear_start(pgem_linear_t *linear);
/* The fill-reducing ordering into a system whose store received from_store's graph
 * (pgem_copy), when it is still that graph's (and not the every-edge fallback's). */
void pgem_linear_copy_ordering(pgem_linear_t *to, const pgem_store_t *to_store,
                               const pgem_linear_t *from, const pgem_store_t *from_store);
/* The parts of linalg's share of the block for a resolved config: the factor's values and row
 * indices, CSparse's pool (parts->factor, parts->csparse_pool). */
void pgem_linear_memory_parts(const pgem_config_t *config, pgem_memory_parts_t *parts);
/* The factor's nonzeros, analyses and CSparse pool figures into stats. */
void pgem_linear_memory_stats(const pgem_linear_t *linear, pgem_memory_stats_t *stats);

/* The structure (ordering, symbolic analysis) for the store's current topology and edge
 * states: analysed when the graph changed or the structure was invalidated, else kept. The
 * config gives the fill budget and the capacities; a failure is described in message
 * (PGEM_MESSAGE_SIZE bytes). */
int pgem_linear_prepare(pgem_linear_t *linear, const pgem_store_t *store,
                        const pgem_config_t *config, char *message);
int pgem_linear_analyze(pgem_linear_t *linear, const pgem_store_t *store,
                        const pgem_config_t *config, char *message);
/* The nonzeros the factor of the graph's structure (edge states as they are) needs, whatever
 * the budget; the ordering is kept (and the analysis, within the budget); message cleared. */
int pgem_linear_fill_needed(pgem_linear_t *linear, const pgem_store_t *store,
                            const pgem_config_t *config, char *message, uint32_t *nonzeros);
/* How the next analyses order (choice) and the orderer they may use (NULL: none); the
 * ordering is made anew (linalg/analysis/ordering.c; checked by pgem_set_ordering). */
void pgem_linear_set_ordering(pgem_linear_t *linear, pgem_order_choice_t choice,
                              const pgem_orderer_t *orderer);
/* AMD's order of a symmetric pattern of n columns given by one triangle (compressed columns,
 * CSparse's workspace from linalg's pool): order[k] is the column placed k-th. PGEM_OK or
 * PGEM_ERR_OUT_OF_MEMORY (no message: the caller names what it was ordering). */
int pgem_linear_amd(pgem_linear_t *linear, int n, int *colptr, int *rows, int *order);
/* Forgets the structure (edge states changed so that it no longer fits). */
void pgem_linear_invalidate(pgem_linear_t *linear);
/* Keeps the structure fit for the next solve after edge states changed: invalidated when an
 * active edge has no place in it, or when idle loops in it are too many
 * (linalg/analysis/structure.c). */
void pgem_linear_review(pgem_linear_t *linear, const pgem_store_t *store);
/* 1 if loop k's poses meet on the factor's pattern (or one is held). */
int pgem_linear_on_pattern(const pgem_linear_t *linear, const pgem_store_t *store, uint32_t k);
/* PGEM_ERR_NOT_POSITIVE_DEFINITE, naming a pose in message, if a part of the graph (edges
 * not pruned) has no held pose; needs the numbering of a valid analysis
 * (linalg/analysis/analyze.c). */
int pgem_linear_check_parts(pgem_linear_t *linear, const pgem_store_t *store, char *message);
/* The parts of the graph (every edge, or the edges in the problem: not pruned, not a loop at
 * weight 0) that no held pose holds: how many, and unless flag is 0 each held at its pose with
 * the smallest id (pgem_pose_hold_part with flag). */
uint32_t pgem_linear_unheld_parts(pgem_linear_t *linear, pgem_store_t *store, int every_edge,
                                  uint8_t flag);
/* The shared region of the factor (the analysis's scratch, the dense workspace and the solves'
 * vectors take turns in it; none outlives its call), lent to a robust-layer stage that runs
 * between solves (robust/frames.c): at least (3 max_edges + 4 max_poses) ints and
 * max_poses * block^2 doubles; its size in bytes into *bytes. */
void *pgem_linear_shared_region(pgem_linear_t *linear, size_t *bytes);

/* Assembles H and -b at the store's estimate and weights; returns the weighted chi2. */
double pgem_linear_assemble(pgem_linear_t *linear, const pgem_store_t *store);
void pgem_linear_damp(pgem_linear_t *linear, double lambda);
/* The numeric factorisation of the assembled H on the executor's workers (run NULL: the
 * caller's thread only); PGEM_ERR_NOT_POSITIVE_DEFINITE names the pivot and its pose (the
 * store's id) in message (PGEM_MESSAGE_SIZE bytes). */
int pgem_linear_factor(pgem_linear_t *linear, const pgem_store_t *store,
                       const pgem_executor_t *executor, char *message);
void pgem_linear_solve(const pgem_linear_t *linear, double *step);
/* Solves (H + D) step = rhs in place (rhs: pgem_linear_step): the factor's solve, refined by
 * conjugate gradients preconditioned with it when couplings were left out (linalg/query/newton.c).
 * Returns PGEM_OK, or PGEM_ERR_NUMERIC if the refinement did not converge. */
int pgem_solve_newton(pgem_linear_t *linear, const pgem_store_t *store);
/* y = H x with the assembled values (linalg/multiply.c); y += D x for the couplings the
 * assembly left out (linalg/assemble.c). */
void pgem_linear_multiply(const pgem_linear_t *linear, const double *x, double *y);
void pgem_linear_left_out_multiply(const pgem_linear_t *linear, const pgem_store_t *store,
                                   const double *x, double *y);

/* The right-hand side -b after an assembly, the step after a solve (permuted order), and the
 * number of unknowns it holds. */
double *pgem_linear_step(const pgem_linear_t *linear);
int pgem_linear_unknowns(const pgem_linear_t *linear);
/* Pose p's part of a vector in permuted order, or NULL if p is held fixed. */
const double *pgem_linear_pose_delta(const pgem_linear_t *linear, const double *vector,
                                     uint32_t p);
/* Levenberg-Marquardt's pieces: -b kept across retries and put back, the largest diagonal
 * entry of H, and the decrease step^T (-b + lambda step) the damped model predicts. */
void pgem_linear_keep_gradient(pgem_linear_t *linear);
void pgem_linear_restore_gradient(pgem_linear_t *linear);
double pgem_linear_largest_diagonal(const pgem_linear_t *linear);
double pgem_linear_predicted_gain(const pgem_linear_t *linear, double lambda);
/* The running solve's options (their on_progress; NULL outside a solve), and the iteration
 * the next factorisation belongs to. */
void pgem_linear_progress(pgem_linear_t *linear, const pgem_solve_options_t *options);
void pgem_linear_progress_iteration(pgem_linear_t *linear, uint32_t iteration);
/* The last analysis's factor nonzeros. */
uint32_t pgem_linear_nonzeros(const pgem_linear_t *linear);
/* The figures of the analysis and factor for the test hook (hooks/factor_hook.h). */
struct pgem_factor_hook_figures;
void pgem_linear_hook_figures(const pgem_linear_t *linear,
                              struct pgem_factor_hook_figures *figures);

/* out = A H^-1 A^T (n x n) for A = [a_from a_to] on poses from and to (n x n blocks,
 * row-major), from the current factor (linalg/query/marginal.c). */
void pgem_linear_marginal(pgem_linear_t *linear, uint32_t from, uint32_t to, const double *a_from,
                          const double *a_to, double *out);
/* H^-1 on the factor's pattern, over the factor (linalg/query/inverse.c); then the marginal of two
 * poses joined by a block of the pattern (PGEM_ERR_INVALID_ARGUMENT if they are not). */
void pgem_linear_invert(pgem_linear_t *linear);
int pgem_linear_marginal_inverse(pgem_linear_t *linear, uint32_t from, uint32_t to,
                                 const double *a_from, const double *a_to, double *out);
/* The same without the cross term: A_f Z_ff A_f^T + A_t Z_tt A_t^T, which is at least half of
 * A H^-1 A^T (for any pair of poses, on the pattern or not). */
void pgem_linear_marginal_diagonal(pgem_linear_t *linear, uint32_t from, uint32_t to,
                                   const double *a_from, const double *a_to, double *out);

/* The covariance calls (pgem/covariance.h) over the factor (linalg/query/covariance.c). What the
 * factor holds for them: nothing current (any assembly, factorisation, inverse or analysis
 * since, or a change of the graph's topology or revision), L of H, or H^-1 on L's pattern. */
#define PGEM_COVARIANCE_NONE 0
#define PGEM_COVARIANCE_FACTOR 1
#define PGEM_COVARIANCE_INVERSE 2
/* The state, PGEM_COVARIANCE_NONE unless the factor is still the store's graph's (its
 * topology and revision); and setting it (after pgem_linear_assemble and pgem_linear_factor
 * at the current estimate). */
int pgem_linear_covariance_state(const pgem_linear_t *linear, const pgem_store_t *store);
void pgem_linear_covariance_mark(pgem_linear_t *linear, const pgem_store_t *store, int state);
/* Pose p's marginal covariance (b x b, row-major) in the system's tangent (additive in 2D,
 * right in 3D): a solve along p's path (FACTOR) or the inverse's diagonal block (INVERSE). */
void pgem_linear_pose_covariance(pgem_linear_t *linear, uint32_t p, double *out);
/* The joint marginal of poses p and q (2b x 2b, row-major, p's rows first); from the
 * INVERSE state it factors again first (H's values are kept; executor and message as
 * pgem_linear_factor's). */
int pgem_linear_joint_covariance(pgem_linear_t *linear, const pgem_store_t *store,
                                 const pgem_executor_t *executor, char *message, uint32_t p,
                                 uint32_t q, double *out);
/* Every pose's marginal (pose_count blocks of b x b, insertion order; zero for held poses)
 * from one sparse inverse over L (FACTOR becomes INVERSE). */
void pgem_linear_all_covariances(pgem_linear_t *linear, const pgem_store_t *store,
                                 double *out);

#endif /* PGEM_LINALG_LAYER_H */
