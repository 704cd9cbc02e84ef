/* The solver layer, private to lib/core: Gauss-Newton and Levenberg-Marquardt over the linalg
 * layer's calls, with the estimate copies they keep (its state) and the solve options' check.
 * It works on the parts of an instance it is handed (pgem_solve_parts_t), never on pgem_t: the
 * public calls are wrappers in instance/solver.c. */
#ifndef PGEM_SOLVER_LAYER_H
#define PGEM_SOLVER_LAYER_H

#include "linalg/linalg.h"

/* The solver's estimate copies. */
typedef struct pgem_solver_state {
    double *pose_saved;        /* [max_poses * pose_size] estimate before a solve */
    double *pose_accepted;     /* [max_poses * pose_size] last accepted LM estimate */
} pgem_solver_state_t;

/* What a solve works on, lent for one call: the store whose estimate it moves, the solver's
 * state, the linear system, the resolved config (the dimension; the fill budget and capacities
 * for the analysis), the executor of the factorisations and the message buffer
 * (PGEM_MESSAGE_SIZE bytes). */
typedef struct pgem_solve_parts {
    pgem_store_t *store;
    pgem_solver_state_t *state;
    pgem_linear_t *linear;
    const pgem_config_t *config;
    const pgem_executor_t *executor;
    char *message;
} pgem_solve_parts_t;

/* Bytes of the whole estimate (every pose), for copies between the estimate buffers. */
static inline size_t pgem_solve_pose_bytes(const pgem_solve_parts_t *parts)
{
    return (size_t)parts->store->pose_count * (size_t)PGEM_POSE_SIZE(parts->config->dimension) *
           sizeof(double);
}

/* Carves the solver's arrays from the arena (measuring when arena->base is NULL). */
void pgem_solver_carve(pgem_solver_state_t *state, const pgem_config_t *config, int pose_size,
                       pgem_arena_t *arena);

/* The method and every double of solve options (NULL: fine), as pgem_optimize checks them. */
int pgem_check_solve_options(char *message, const pgem_solve_options_t *options);

/* The public calls' bodies (solver/optimize.c, solver/covariance.c; the wrappers with their
 * argument checks are instance/solver.c). */
int pgem_solver_analyze(const pgem_solve_parts_t *parts);
int pgem_solver_fill_needed(const pgem_solve_parts_t *parts, uint32_t *nonzeros);
int pgem_solver_check_solvable(const pgem_solve_parts_t *parts);
int pgem_solver_optimize(const pgem_solve_parts_t *parts, const pgem_solve_options_t *options,
                         pgem_summary_t *summary);
int pgem_solver_covariance_prepare(const pgem_solve_parts_t *parts);
int pgem_solver_covariance(const pgem_solve_parts_t *parts, pgem_id_t id, double *covariance);
int pgem_solver_joint_covariance(const pgem_solve_parts_t *parts, pgem_id_t a, pgem_id_t b,
                                 double *covariance);
int pgem_solver_covariances(const pgem_solve_parts_t *parts, double *covariances);

/* The covariance calls' pieces the online layer's shares (solver/covariance.c): pose p's
 * index for id, or UNKNOWN_ID with its message; in 2D, rows and columns [offset, offset + 2)
 * of the n x n matrix (the translation of pose p) from the world frame into p's: R^T C R on
 * that block, R^T on its rows elsewhere. */
int pgem_covariance_pose(const pgem_store_t *store, char *message, pgem_id_t id, uint32_t *p);
void pgem_covariance_to_body(const pgem_store_t *store, uint32_t p, int n, int offset,
                             double *matrix);

/* Solver pieces shared by Gauss-Newton and Levenberg-Marquardt. */
/* Applies a step (permuted order, pgem_linear_step) to every free pose. */
void pgem_apply_step(const pgem_solve_parts_t *parts, const double *step);
/* Euclidean norm of a vector; NaN/Inf propagate. */
double pgem_norm(const double *values, int count);
/* Reports an iteration to the callback; returns non-zero if it asks to stop. */
int pgem_report(const pgem_solve_options_t *options, uint32_t iteration, double chi2,
                double step_norm, double lambda, int accepted);
/* Relative chi2 decrease below tolerance (negative tolerance: never; zero chi2: always). */
int pgem_chi2_converged(double before, double after, double tolerance);
/* Sets the message for a non-finite chi2 or step and returns PGEM_ERR_NUMERIC. */
int pgem_fail_numeric(char *message, const char *what, uint32_t iteration);

int pgem_gauss_newton(const pgem_solve_parts_t *parts, const pgem_solve_options_t *options,
                      pgem_summary_t *summary);
int pgem_levenberg_marquardt(const pgem_solve_parts_t *parts, const pgem_solve_options_t *options,
                             pgem_summary_t *summary);

#endif /* PGEM_SOLVER_LAYER_H */
