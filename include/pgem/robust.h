/* pgem robust layer: EM loop-closure weighting and pruning (Lee, Fraundorfer & Pollefeys,
 * IROS 2013) and other robust kernels behind the same interface (rho and its derivative, the
 * weight), a user's own kernel among them.
 *
 * One chi2 convention throughout this header and pgem_summary_t: "chi2" is the weighted chi2,
 * the sum of w_k e_k^T Omega_k e_k over the edges in the problem (not pruned), at the weights
 * current at that moment (1 for odometry, and for every loop closure of a fresh graph). The
 * one exception says so in its name: final_chi2_all (every edge, pruned ones included, at
 * weight 1). */
#ifndef PGEM_ROBUST_H
#define PGEM_ROBUST_H

#include <stdint.h>

#include "pgem/core.h"
#include "pgem/graph.h"
#include "pgem/solver.h"

#ifdef __cplusplus
extern "C" {
#endif

/** How loop closures are weighted. Odometry edges always keep weight 1. EM is 0, so a zeroed
 * pgem_robust_options_t means EM with its defaults, in the core, the bridge and the C++
 * wrapper alike (pgem optimize without --robust asks for PGEM_KERNEL_NONE itself). */
typedef enum pgem_kernel {
    PGEM_KERNEL_EM = 0,      /**< default. EM: Cauchy E-step, weighted GN M-step, pruning
                                rounds */
    PGEM_KERNEL_NONE = 1,    /**< plain least squares: every loop back to weight 1 and active
                                (pruning by an earlier robust solve is undone, as
                                pgem_robust_reset does), then one solve */
    PGEM_KERNEL_CAUCHY = 2,  /**< Cauchy IRLS, no pruning: w = 1 / (1 + chi2 / c^2) */
    PGEM_KERNEL_HUBER = 3,   /**< Huber IRLS: w = 1 if sqrt(chi2) <= k, else k / sqrt(chi2) */
    PGEM_KERNEL_DCS = 4,     /**< dynamic covariance scaling: s = min(1, 2 phi / (phi + chi2)),
                                w = s^2 */
    PGEM_KERNEL_USER = 5     /**< IRLS with the options' kernel_function (no pruning) */
} pgem_kernel_t;

/** A kernel at one loop closure's squared Mahalanobis error s = e^T Omega e: rho(s), the cost
 * that replaces s, and its derivative rho'(s), the loop's IRLS weight. */
typedef struct pgem_kernel_value {
    double rho;     /**< rho(s); rho(s) = s for a loop at full weight */
    double weight;  /**< rho'(s), in [0, 1] (a solve refuses anything else) */
} pgem_kernel_value_t;

/** A user's kernel: rho and rho' at s = chi2 for the options' scale (and user pointer). It must
 * not fail or keep state between calls that changes its answers: a solve calls it for every
 * loop closure in every E-step, and a weight outside [0, 1] (NaN included) fails the solve. */
typedef pgem_kernel_value_t (*pgem_kernel_fn)(double chi2, double scale, void *user);

/** A built-in kernel at chi2 (EM: its Cauchy E-step; NONE: rho = s, weight 1; USER: the
 * built-in has no formula, rho = s, weight 1). Formulas, with c, k, phi the scale:
 *   Cauchy  rho = c^2 log(1 + s / c^2),                 w = 1 / (1 + s / c^2)
 *   Huber   rho = s if r <= k else 2 k r - k^2 (r = sqrt s), w = 1 if r <= k else k / r
 *   DCS     rho = s if s <= phi else phi (3 s - phi) / (phi + s),
 *                                                      w = min(1, 2 phi / (phi + s))^2 */
pgem_kernel_value_t pgem_kernel_evaluate(pgem_kernel_t kernel, double chi2, double scale);

/** The weight one kernel gives a loop closure of Mahalanobis error chi2 = e^T Omega e
 * (pgem_kernel_evaluate's weight). */
double pgem_kernel_weight(pgem_kernel_t kernel, double chi2, double scale);

/** What EM measures a loop closure by, in its E-step and its consistency test. */
typedef enum pgem_loop_distance {
    PGEM_DISTANCE_INNOVATION = 0,  /**< default: the loop against what the rest of the graph
                                      predicts for it (leave-one-out innovation, the map's
                                      covariance included), where the map predicts it well
                                      enough; the point chi2 elsewhere
                                      (docs/design/innovation.md) */
    PGEM_DISTANCE_POINT = 1        /**< the paper: e^T Omega e under the current estimate */
} pgem_loop_distance_t;

/** How a successful robust solve ended for the loop closures. */
typedef enum pgem_robust_outcome {
    PGEM_ROBUST_LOOPS_ACCEPTED = 0, /**< loop closures accepted, fewer than 90% rejected */
    PGEM_ROBUST_NO_LOOPS = 1,       /**< the graph has no loop closure */
    PGEM_ROBUST_MOST_REJECTED = 2,  /**< more than 90% of the loop closures rejected: check the
                                       front-end's loop detector and loop information */
    PGEM_ROBUST_ALL_REJECTED = 3    /**< every loop closure rejected: the estimate is the
                                       odometry's alone */
} pgem_robust_outcome_t;

/** State of a loop closure after a robust solve. */
typedef enum pgem_loop_state {
    PGEM_LOOP_ACCEPTED = 0,  /**< in the solution with its weight */
    PGEM_LOOP_PRUNED = 1,    /**< removed: weight fell below the prune threshold */
    PGEM_LOOP_DORMANT = 2    /**< in the solution with its (small) weight, but given no place
                                in the factor (EM's dormant_threshold; seen from a round
                                callback: a finished solve wakes every dormant loop) */
} pgem_loop_state_t;

/** The robust weight of edge `index` (0 .. pgem_edge_count-1) and its state: odometry edges
 * and loop closures no robust solve touched are accepted at weight 1. Errors:
 * INVALID_ARGUMENT (NULL, or index out of range); nothing is written then. */
int pgem_loop_weight(const pgem_t *graph, uint32_t index, double *weight);
int pgem_loop_state(const pgem_t *graph, uint32_t index, pgem_loop_state_t *state);

/** What the round callback sees (EM: after each round; IRLS kernels: after each iteration). */
typedef struct pgem_robust_progress {
    uint32_t round;              /**< 1, 2, ... */
    uint32_t active_loops;       /**< loop closures still in the problem */
    uint32_t pruned_loops;       /**< loop closures pruned so far */
    double chi2;                 /**< weighted chi2 of the current estimate */
    double largest_change;       /**< largest weight change in the last E-step */
} pgem_robust_progress_t;

typedef int (*pgem_robust_fn)(const pgem_robust_progress_t *progress, void *user);

/** Options; a zeroed struct means the documented defaults: EM, the product's method. */
typedef struct pgem_robust_options {
    pgem_kernel_t kernel;            /**< default PGEM_KERNEL_EM (0) */
    double scale;                    /**< c for EM/Cauchy, k for Huber, phi for DCS; 0 means 1 */
    double prune_threshold;          /**< EM: prune loops with weight below; 0 means 0.01 */
    double weight_tolerance;         /**< stop E/M iterations when no weight moves more;
                                        0 means 1e-3 */
    uint32_t m_step_iterations;      /**< Gauss-Newton iterations per M-step; 0 means 1 */
    uint32_t max_em_iterations;      /**< E/M iterations per round; 0 means 5 (literal: 100) */
    uint32_t max_rounds;             /**< EM pruning rounds; 0 means 20 */
    int restart;                     /**< EM: after pruning, restart from the initial estimate
                                        (1) or continue from the current one (0, default) */
    int literal;                     /**< EM: 1 = the paper's method as published (rounds of
                                        E/M to convergence, pruning). 0 (default) adds:
                                        rounds capped at max_em_iterations (5), then "polish"
                                        (accepted loops at weight 1, Gauss-Newton to
                                        convergence) and a consistency test under the
                                        polished estimate (pruned loops whose distance is
                                        below the gate come back, accepted ones above it are
                                        pruned), repeated while it changes anything, with
                                        the innovation distance after the first rounds. An
                                        outlier-free graph reaches exactly the plain
                                        optimum. */
    double gate;                     /**< EM consistency test (not literal): distance threshold;
                                        0 means the 99.9% chi-square quantile for the edge's
                                        degrees of freedom (16.27 in 2D, 22.46 in 3D) */
    double dormant_threshold;        /**< EM (not literal): a loop whose weight is below it is
                                        dormant: the block coupling its two poses is kept out
                                        of the factor's structure (unless it already has a
                                        place there), so false loops do not make the factor
                                        dense, and the Newton step adds it back by conjugate
                                        gradients preconditioned with the factor: the step is
                                        the exact one, only the time changes. 0 means
                                        prune_threshold / 100; negative: never */
    pgem_loop_distance_t distance;   /**< EM (not literal): the loops' distance; default
                                        PGEM_DISTANCE_INNOVATION (0) */
    double odometry_inflation;       /**< innovation: the map's covariance is multiplied by it
                                        in a loop's innovation, an allowance for odometry
                                        covariances that are too optimistic; 0 means 4 (the
                                        odometry's standard deviations understated twice) */
    double predictable_rotation;     /**< innovation: the map predicts a loop well enough when
                                        the standard deviation of its predicted rotation is
                                        at most this (radians); 0 means 0.1 */
    int frames;                      /**< EM: 0 (default) places each part of the graph that its
                                        odometry alone leaves without a held pose (a team's
                                        robot, its frame unknown) in the frame on which most of
                                        the loops joining it to the placed parts agree, before
                                        the first E-step (pgem_robust_summary_t.frames_placed);
                                        a graph of one part is not touched. Negative: never */
    pgem_robust_fn on_round;         /**< may be NULL; return non-zero to stop */
    void *user;                      /**< passed to on_round */
    pgem_kernel_fn kernel_function;  /**< PGEM_KERNEL_USER: the kernel (required then; NULL
                                        with that kernel is refused) */
    void *kernel_user;               /**< passed to kernel_function */
} pgem_robust_options_t;

/** Why a robust solve stopped. */
typedef enum pgem_robust_termination {
    PGEM_ROBUST_CONVERGED = 0,        /**< EM: a round pruned nothing and the consistency test
                                         changed no loop; IRLS: the weights settled; NONE: its
                                         solve succeeded */
    PGEM_ROBUST_ROUND_LIMIT = 1,      /**< EM: max_rounds rounds (or test passes) and loops were
                                         still changing state */
    PGEM_ROBUST_ITERATION_LIMIT = 2,  /**< IRLS: max_em_iterations before the weights settled */
    PGEM_ROBUST_STOPPED = 3,          /**< on_round, or the solve options' on_iteration in
                                         any of the method's Gauss-Newton solves, asked to
                                         stop: the solve returned at once, its estimate
                                         mid-solve (pgem_update_restore can undo it) */
    PGEM_ROBUST_FAILED = 4,           /**< the solve failed (usable is 0; see the error) */
    PGEM_ROBUST_OSCILLATED = 5        /**< EM: the passes of consistency test and rounds came
                                         back to a set of accepted loops they had left (a
                                         cycle, e.g. two sets in turn); the solve ended at the
                                         set of the cycle whose polished estimate has the
                                         lowest robust cost (odometry chi2 plus every loop's
                                         Cauchy rho, pruned loops included), polished. Usable,
                                         but not settled: the decisions on the loops that
                                         change state around the cycle are not firm */
} pgem_robust_termination_t;

/** What a robust solve did. */
typedef struct pgem_robust_summary {
    uint32_t rounds;                 /**< EM pruning rounds (1 for IRLS kernels) */
    uint32_t em_iterations;          /**< E-step / M-step pairs */
    uint32_t gn_iterations;          /**< Gauss-Newton iterations over all M-steps */
    uint32_t loops;                  /**< loop closures in the graph */
    uint32_t pruned;                 /**< of them pruned */
    uint32_t readmitted;             /**< pruned loops re-admitted by the consistency test or the
                                        rescue (a run of loops tried alone) */
    uint32_t gated;                  /**< accepted loops pruned by the consistency test */
    uint32_t rejected;               /**< loops rejected: pruned, or for the kernels that never
                                        prune (Cauchy, Huber, DCS) weighing below
                                        prune_threshold */
    uint32_t non_finite;             /**< loops pruned at the start: their chi2 was not finite */
    uint32_t first_non_finite;       /**< edge index of the first of them, UINT32_MAX if none */
    double initial_chi2;             /**< chi2 before (weighted, at the weights the call found:
                                        all 1 on a fresh graph) */
    double final_chi2;               /**< chi2 after (weighted, pruned loops excluded) */
    double final_chi2_all;           /**< chi2 after with every edge at weight 1, the pruned
                                        loops included */
    pgem_robust_outcome_t outcome;   /**< after a successful solve: loops accepted, none in the
                                        graph, most or all of them rejected */
    pgem_robust_termination_t termination; /**< why the solve stopped */
    int estimate_changed;            /**< 1 if the solve moved any pose */
    int usable;                      /**< 1 if the estimate is the result of a successful solve */
    uint32_t parts_held;             /**< parts of the graph that pruned loop closures left
                                        with no held pose, each held at its own gauge where
                                        the solve left it (pgem_robust_held_parts names them) */
    uint32_t frames_placed;          /**< parts moved into the frame their agreeing loops imply
                                        before the first E-step (options.frames) */
} pgem_robust_summary_t;

/** Robust solve from the current estimate. Weights and prune states are left on the edges
 * (pgem_edge_at: weight, active). Pruned loops are never lost: they stay in the graph, and
 * pgem_robust_reset() brings them back. A call starts from the loops' current states, so a
 * second call (say, after new edges arrived) continues from the first one's pruning; the
 * consistency test of the default method re-admits a pruned loop that fits again. Pruned
 * loops leave H's structure (one symbolic re-analysis when the pruned set changes). On failure
 * the estimate and every loop's weight and state are restored to what they were before the
 * call (the next solve then re-analyses). A part that pruning leaves without a held pose does
 * not fail the solve (pgem_robust_held_parts); a part that no held pose holds even with every
 * edge does (NOT_POSITIVE_DEFINITE, naming a pose of it), as pgem_optimize.
 * options may be NULL (a zeroed struct: EM with its defaults); solve may be NULL (Gauss-Newton
 * defaults; max_iterations is ignored for EM M-steps). */
int pgem_robust_optimize(pgem_t *graph, const pgem_robust_options_t *options,
                         const pgem_solve_options_t *solve, pgem_robust_summary_t *summary);

/** Every loop weight back to 1 and every pruned loop active again (and the parts a robust
 * solve held released). */
void pgem_robust_reset(pgem_t *graph);

/** The parts of the graph that a robust solve's pruning left without a held pose: the ids of
 * the poses that hold them, in insertion order, into ids (at most capacity of them; ids may be
 * NULL when capacity is 0); returns how many parts are held (summary.parts_held after the
 * solve; 0 for NULL graph). One pass over the poses; allocates nothing. A robust solve
 * (kernels that prune: EM) does not fail for such a part: it holds the part at its own gauge,
 * its pose with the smallest id, as pgem_hold_gauge does (the pose stays free, its block is
 * damped), so the part stays where the solve left it, and its loop closures stay in the
 * consistency test, measured against the estimate; one that passes joins the part back. The
 * holds last until the next robust solve (which makes them anew) or pgem_robust_reset. */
uint32_t pgem_robust_held_parts(const pgem_t *graph, pgem_id_t *ids, uint32_t capacity);

/** Name of a kernel ("em", "cauchy", "huber", "dcs", "none"); never NULL. */
const char *pgem_kernel_name(pgem_kernel_t kernel);

/** Name of an outcome ("loops_accepted", "no_loops", "most_rejected", "all_rejected"). */
const char *pgem_robust_outcome_name(pgem_robust_outcome_t outcome);

/** Name of a termination ("converged", "round_limit", "iteration_limit", "stopped", "failed",
 * "oscillated"). */
const char *pgem_robust_termination_name(pgem_robust_termination_t termination);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_ROBUST_H */
