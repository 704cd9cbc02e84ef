/** @file
 * pgem solver: Gauss-Newton and Levenberg-Marquardt over the fixed-memory sparse Cholesky. */
#ifndef PGEM_SOLVER_H
#define PGEM_SOLVER_H

#include <stdint.h>

#include "pgem/core.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum pgem_method {
    PGEM_GAUSS_NEWTON = 0,
    PGEM_LEVENBERG_MARQUARDT = 1
} pgem_method_t;

/** Why a solve stopped. */
typedef enum pgem_termination {
    PGEM_TERM_NONE = 0,              /**< no iteration ran */
    PGEM_TERM_CHI2_CONVERGED = 1,    /**< relative chi2 decrease below relative_chi2_tolerance */
    PGEM_TERM_STEP_CONVERGED = 2,    /**< step norm below step_tolerance */
    PGEM_TERM_MAX_ITERATIONS = 3,    /**< max_iterations reached */
    PGEM_TERM_STOPPED = 4,           /**< the iteration callback asked to stop */
    PGEM_TERM_NO_PROGRESS = 5,       /**< LM: damping grew past its limit without a better step */
    PGEM_TERM_NOT_POSITIVE_DEFINITE = 6, /**< failed: normal equations singular */
    PGEM_TERM_NUMERIC = 7,           /**< failed: NaN or Inf in the step or the chi2 */
    PGEM_TERM_FILL_BUDGET = 8        /**< failed: factor larger than config.fill_budget */
} pgem_termination_t;

/** What the callback sees after each iteration. */
typedef struct pgem_iteration {
    uint32_t iteration;   /**< 1, 2, ... */
    double chi2;          /**< weighted chi2 after the iteration (before it, if rejected) */
    double step_norm;     /**< Euclidean norm of the tangent step */
    double lambda;        /**< LM damping used (0 for Gauss-Newton) */
    int accepted;         /**< 1 if the step was kept */
} pgem_iteration_t;

/** Called after every iteration; return non-zero to stop (PGEM_TERM_STOPPED). */
typedef int (*pgem_iteration_fn)(const pgem_iteration_t *iteration, void *user);

/** What the progress callback sees during a long factorisation. */
typedef struct pgem_progress {
    uint32_t iteration;    /**< the iteration under way: 1, 2, ... */
    double done;           /**< fraction of its factorisation done, 0 .. 1, by multiply-adds
                                (an estimate while several workers share it) */
    double multiply_adds;  /**< multiply-adds of one factorisation */
} pgem_progress_t;

/** Called from the solving thread about every 1/64 of a factorisation of at least 1e8
 * multiply-adds (some 10 ms and up), so a host can show progress; the core reads no clock. */
typedef void (*pgem_progress_fn)(const pgem_progress_t *progress, void *user);

/** Solver options; a zeroed struct means the documented defaults. */
typedef struct pgem_solve_options {
    pgem_method_t method;            /**< default Gauss-Newton */
    uint32_t max_iterations;         /**< 0 means 100 */
    double relative_chi2_tolerance;  /**< stop when (chi2_old - chi2_new) / chi2_old is below;
                                        0 means 1e-9; negative disables */
    double step_tolerance;           /**< stop when the step norm is below; 0 means 1e-10;
                                        negative disables */
    double initial_lambda;           /**< LM: first damping (relative to the largest diagonal
                                        entry of H); 0 means 1e-5 */
    pgem_iteration_fn on_iteration;  /**< may be NULL */
    void *user;                      /**< passed to on_iteration and on_progress */
    pgem_progress_fn on_progress;    /**< may be NULL */
} pgem_solve_options_t;

/** What a solve did. */
typedef struct pgem_summary {
    double initial_chi2;             /**< weighted chi2 before the first iteration */
    double final_chi2;               /**< weighted chi2 of the estimate left in the graph */
    uint32_t iterations;             /**< iterations run (accepted or not) */
    uint32_t factorizations;         /**< numeric Cholesky factorisations */
    pgem_termination_t termination;  /**< why it stopped */
    int estimate_changed;            /**< 1 if the poses differ from before the call */
    int usable;                      /**< 1 if the estimate is the result of a successful solve */
    uint32_t factor_nonzeros;        /**< scalar nonzeros of L */
    uint32_t variables;              /**< scalar unknowns (free poses x tangent size) */
} pgem_summary_t;

/** Optimises the graph's poses from their current estimate. Loop closures enter with their
 * robust weight (1 unless the robust layer set it); pruned loops are left out.
 * On failure (NOT_POSITIVE_DEFINITE, NUMERIC, FILL_BUDGET, EMPTY, OUT_OF_MEMORY) the poses are
 * restored to what they were before the call, summary->usable is 0 and the message says why.
 * A solve that would leave a pose beyond PGEM_TRANSLATION_LIMIT has diverged: NUMERIC, so an
 * instance never holds a pose it would refuse as input. options and summary may be NULL. */
int pgem_optimize(pgem_t *graph, const pgem_solve_options_t *options, pgem_summary_t *summary);

/** Runs the symbolic analysis for the current topology now (otherwise the next pgem_optimize
 * does). Useful to move CSparse's symbolic allocation out of a time-critical loop. */
int pgem_analyze(pgem_t *graph);

/** The factor nonzeros the graph needs as it is (its loops' current states): the symbolic
 * analysis without the budget check, so it succeeds where pgem_analyze fails with
 * PGEM_ERR_FILL_BUDGET, and *nonzeros is the fill_budget a solve of this graph needs. The
 * ordering is kept: pgem_copy into an instance of that budget hands it over, so the solve there
 * does not order again. Within the budget the instance is also analysed, ready to solve.
 * Errors: INVALID_ARGUMENT (NULL), EMPTY (no edge, or every pose fixed), OUT_OF_MEMORY
 * (CSparse's workspace); *nonzeros is not written then. */
int pgem_fill_needed(pgem_t *graph, uint32_t *nonzeros);

/** The checks pgem_optimize makes before its first iteration, without solving: an edge and a
 * free pose to solve (EMPTY), the factor within the fill budget (FILL_BUDGET), every part of
 * the graph held by a fixed pose or the first pose (NOT_POSITIVE_DEFINITE, naming a pose of
 * the part), and a finite chi2 at the current estimate (NUMERIC). PGEM_OK means the solve
 * will start; the message says why not otherwise. Runs the symbolic analysis as pgem_analyze
 * does (its allocation, with the system CSparse); the estimate and weights are not touched.
 * A file checker (`pgem stats`) uses it to refuse what `pgem optimize` would refuse. */
int pgem_check_solvable(pgem_t *graph);

/** Name of a termination reason ("chi2-converged", ...); never NULL. */
const char *pgem_termination_name(pgem_termination_t termination);

/** Name of a method ("gauss-newton" or "levenberg-marquardt"); never NULL. */
const char *pgem_method_name(pgem_method_t method);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_SOLVER_H */
