/* The solver layer, private to lib/core: Gauss-Newton and Levenberg-Marquardt over the linalg
 * layer's calls, with the estimate copies they keep (graph->solver) and the solve options'
 * check. */
#ifndef PGEM_SOLVER_LAYER_H
#define PGEM_SOLVER_LAYER_H

#include "linalg/linalg.h"

/* The solver's estimate copies. */
typedef struct pgem_solver_state {
    double *pose_saved;        /* [max_poses * pose_size] estimate before a solve */
    double *pose_accepted;     /* [max_poses * pose_size] last accepted LM estimate */
} pgem_solver_state_t;

/* Carves the solver's arrays from the arena (measuring when arena->base is NULL). */
void pgem_solver_carve(pgem_t *graph, pgem_arena_t *arena);

/* The method and every double of solve options (NULL: fine), as pgem_optimize checks them. */
int pgem_check_solve_options(pgem_t *graph, const pgem_solve_options_t *options);

/* The covariance calls' pieces the online layer's shares (solver/covariance.c): pose p's
 * index for id, or UNKNOWN_ID with its message; in 2D, rows and columns [offset, offset + 2)
 * of the n x n matrix (the translation of pose p) from the world frame into p's: R^T C R on
 * that block, R^T on its rows elsewhere. */
int pgem_covariance_pose(pgem_t *graph, pgem_id_t id, uint32_t *p);
void pgem_covariance_to_body(const pgem_t *graph, uint32_t p, int n, int offset, double *matrix);

/* Solver pieces shared by Gauss-Newton and Levenberg-Marquardt. */
/* Applies a step (permuted order, pgem_linear_step) to every free pose. */
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

#endif /* PGEM_SOLVER_LAYER_H */
