/* The robust layer, private to lib/core: EM's loop-closure weighting and the IRLS kernels over
 * the solver, with what a robust solve keeps (pgem_robust_state_t): the estimate and edge
 * states to put back if it fails, and each loop's last distance. */
#ifndef PGEM_ROBUST_LAYER_H
#define PGEM_ROBUST_LAYER_H

#include "pgem/robust.h"
#include "solver/solver.h"

/* The share of rejected loop closures above which the outcome is PGEM_ROBUST_MOST_REJECTED
 * (robust/solve.c) and EM tries its rescue (robust/rescue.c). */
#define PGEM_MOST_REJECTED 0.9

/* What a robust solve keeps besides the graph's weights and states. */
typedef struct pgem_robust_state {
    double *pose_initial;      /* [max_poses * pose_size] estimate before a robust solve */
    double *edge_weight_saved; /* [max_edges] weights before a robust solve, and */
    uint8_t *edge_active_saved; /* [max_edges] states: put back if the solve fails */
    double *edge_distance;     /* [max_edges] a loop's distance in the last E-step or test */
    uint8_t *edge_checked;     /* [max_edges] 1 if the map predicted the loop (innovation) */
} pgem_robust_state_t;

/* What a robust solve works on, lent for one call: the parts a solve works on (the store, the
 * solver's state, the linear system, the config, the executor, the message buffer), the robust
 * state and the error rows per edge (3 or 6). The public calls build it from the instance
 * (pgem_robust_parts in instance.h, instance/robust.c); the layer never sees struct pgem. */
typedef struct pgem_robust_parts {
    pgem_solve_parts_t solve;
    pgem_robust_state_t *state;
    int tangent;
} pgem_robust_parts_t;

/* A robust solve (robust/solve.c; pgem_robust_optimize over the instance's parts): the
 * summary (NULL: none) zeroed with first_non_finite UINT32_MAX, options checked, loops whose
 * chi2 is not finite pruned, the method run, a failure undone, the summary filled and the
 * message cleared on success. */
int pgem_robust_solve(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                      const pgem_solve_options_t *solve, pgem_robust_summary_t *summary);

/* Carves the robust layer's arrays for config's capacities and the doubles per pose from the
 * arena (measuring when arena->base is NULL). */
void pgem_robust_carve(pgem_robust_state_t *robust, const pgem_config_t *config, int pose_size,
                       pgem_arena_t *arena);

/* A loop's innovation (robust/innovation.c): its distance with the odometry allowance, the
 * same without it (inflation 1), and the predicted rotation's standard deviation (radians). */
typedef struct pgem_innovation {
    double distance;     /* d^2 under Omega^-1 + inflation J Sigma_-k J^T */
    double plain;        /* d^2 under Omega^-1 + J Sigma_-k J^T */
    double rotation_sd;  /* sqrt of the rotation block's trace of J Sigma_-k J^T */
} pgem_innovation_t;
/* The innovation test of one loop over whichever factor the caller has: its whitened error
 * r = U (e + J step) (`predicted`; step 0 when the estimate is the factor's solution), U
 * (U^T U = Omega) and the marginal M = A H^-1 A^T (destroyed) of its whitened Jacobian
 * A = U J under a factor that holds the loop at `weight` (0: not in it); the odometry
 * allowance `inflation` graded with the map's variance (robust/innovation.c). */
void pgem_innovation_test(int n, const double *upper, const double *predicted, double *marginal,
                          double weight, double inflation, pgem_innovation_t *out);
/* Loop k's error e (n = tangent rows), the upper root U of its information (U^T U =
 * information) and its whitened Jacobians A_from = U J_from, A_to = U J_to. */
void pgem_loop_whiten(const pgem_store_t *store, int n, uint32_t k, double *e, double *upper,
                      double *a_from, double *a_to);
/* Loop k's innovation under the current factor, in which it has weight `weight` (0 when
 * pruned); its marginal from the sparse inverse (from_inverse) or by a solve with L. */
void pgem_loop_innovation(pgem_linear_t *linear, const pgem_store_t *store, int n, uint32_t k,
                          double weight, double inflation, int from_inverse,
                          pgem_innovation_t *out);
/* For a pruned loop, after pgem_linear_invert: 1 if it passes `gate` however the map predicts
 * it (its chi2 and its predicted error are below it), -1 if it fails it however (its chi2 and
 * a lower bound of its innovation are above it), 0 if only the innovation can tell;
 * *distance is the measure that decided (robust/innovation.c). */
int pgem_loop_screen(pgem_linear_t *linear, const pgem_store_t *store, int n, uint32_t k,
                     double inflation, double gate, double *distance);
/* The consistency test's distances (robust/estep.c): every loop's, pruned ones included,
 * under the options' distance; `gate` lets bounds decide pruned loops off the factor's
 * pattern without a solve. The innovation of a loop the map does not predict is divided by
 * `scale` (in (0, 1]: the variance factor with its margin, robust/gate.c). */
void pgem_em_distances(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                       double gate, double scale);
/* Stated covariances are not equally loose everywhere: a test scaled by the variance factor
 * (the chi2 per redundant row, at most 1) scales by this many times it (at most 1). On
 * Intel's SE-Sync version a true group's fall is 3.3 times its quantile scaled by the variance
 * factor alone, where the false groups measured are 6 to 65 times theirs (robust/groups.c);
 * on Sphere2500 true single loops the map does not predict reach 1.3 times the gate
 * (robust/gate.c). */
#define PGEM_VARIANCE_MARGIN 5.0
/* EM's E-step (robust/estep.c): each unpruned loop's point chi2, then its weight, and the
 * largest weight change; fails only on a user kernel's weight outside [0, 1]. */
int pgem_em_e_step(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                   double *largest_change);
/* Loop k's weight from its distance (edge_distance) under the options' kernel (robust/kernel.c):
 * PGEM_ERR_NUMERIC, naming the loop, if a user kernel's weight is not in [0, 1]. */
int pgem_loop_kernel_weight(const pgem_robust_state_t *robust, const pgem_store_t *store,
                            const pgem_robust_options_t *options, uint32_t k, double *weight,
                            char *message);

/* Options (robust/options.c): checked, naming a wrong one in message (PGEM_MESSAGE_SIZE
 * bytes); resolved to the defaults. */
int pgem_check_robust_options(const pgem_robust_options_t *options, char *message);
pgem_robust_options_t pgem_robust_resolve(const pgem_robust_options_t *options);

/* The loops around a solve (robust/loops.c): dormant ones back to active (the structure
 * reviewed), counted into the summary, and the estimate, weights and states saved at the start
 * and put back after a failure. */
void pgem_wake_dormant(pgem_linear_t *linear, pgem_store_t *store);
void pgem_count_loops(const pgem_store_t *store, pgem_robust_summary_t *summary);
void pgem_save_loops(pgem_robust_state_t *robust, const pgem_store_t *store);
void pgem_restore_loops(const pgem_robust_state_t *robust, pgem_store_t *store,
                        pgem_linear_t *linear);
void pgem_restore_initial(const pgem_robust_state_t *robust, pgem_store_t *store, int pose_size);

/* Parts that pruning leaves without a held pose (robust/parts.c): before each solve of the
 * method, every part that pruning left alone is held at its own gauge, unless a part has no
 * held pose even with every edge (the caller's graph, not pruning, leaves it floating: nothing
 * is held and the solve fails, PGEM_ERR_NOT_POSITIVE_DEFINITE naming a pose, as before); at
 * the end, the holds are those of the final loop states (counted into summary->parts_held),
 * or, after a failure, the ones from before the call. */
void pgem_robust_hold_parts(pgem_linear_t *linear, pgem_store_t *store);
void pgem_robust_parts_settled(pgem_linear_t *linear, pgem_store_t *store, int succeeded,
                               pgem_robust_summary_t *summary);
/* pgem_robust_reset and pgem_robust_held_parts on the store (robust/loops.c, parts.c; the
 * public calls are these over the instance's parts, instance/robust.c). */
void pgem_robust_reset_loops(pgem_linear_t *linear, pgem_store_t *store);
uint32_t pgem_robust_list_parts(const pgem_store_t *store, pgem_id_t *ids, uint32_t capacity);
/* The frames of a team's robots (robust/frames.c): each part of the graph without a held pose
 * (over the edges that are not loop closures, before EM's first E-step; with_loops: over them
 * and the loops in the problem, after a round's pruning left a part joined only by pruned
 * loops) is moved into the frame on which most of the loops joining it to the placed parts
 * agree, unless as many agree where it stands; returns how many parts were moved. */
uint32_t pgem_robust_frames(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                            int with_loops);

/* The summary's termination, unless an earlier stop by on_round already set it. */
static inline void pgem_robust_ended(pgem_robust_summary_t *summary,
                                     pgem_robust_termination_t termination)
{
    if (summary->termination != PGEM_ROBUST_STOPPED) {
        summary->termination = termination;
    }
}

/* 1 once the solve was asked to stop (on_round, or the solve options' on_iteration during any
 * of its Gauss-Newton solves): every method returns at once, the estimate mid-solve. */
static inline int pgem_robust_stopped(const pgem_robust_summary_t *summary)
{
    return summary->termination == PGEM_ROBUST_STOPPED;
}

/* A Gauss-Newton solve of the method whose iteration callback asked to stop stops the method. */
static inline void pgem_robust_note_stop(pgem_robust_summary_t *summary, const pgem_summary_t *result)
{
    if (result->termination == PGEM_TERM_STOPPED) {
        summary->termination = PGEM_ROBUST_STOPPED;
    }
}

/* The round callback (if any) told of the round just done (progress->largest_change set by
 * the caller); returns 1, the termination PGEM_ROBUST_STOPPED, if it asks to stop. */
int pgem_report_round(const pgem_store_t *store, int tangent, const pgem_robust_options_t *options,
                      pgem_robust_summary_t *summary, pgem_robust_progress_t *progress);

/* E/M iterations (robust/iterate.c); weights_current skips the first E-step. */
int pgem_em_iterate(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                    const pgem_solve_options_t *solve, pgem_robust_summary_t *summary,
                    int weights_current, double *largest_change);
/* EM (robust/em.c): rounds with pruning (the literal method); the polish (robust/polish.c:
 * accepted loops at weight 1, Gauss-Newton to convergence); rounds, polish and consistency test
 * (the default). */
int pgem_em_rounds(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                   const pgem_solve_options_t *solve, pgem_robust_summary_t *summary);
int pgem_em_polish(const pgem_robust_parts_t *parts, const pgem_solve_options_t *solve,
                   pgem_robust_summary_t *summary);
int pgem_em_with_gate(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                      const pgem_solve_options_t *solve, pgem_robust_summary_t *summary);
/* A run of loops (robust/runs.c): loops from poses a, a+1, ... to b, b+s, ... Runs shorter
 * than PGEM_RUN_MIN are not tested as runs: one or two loops are what the consistency test
 * examines one by one. */
#define PGEM_RUN_MIN 3u
typedef struct pgem_loop_run {
    uint32_t first;  /* edge index of the run's first loop */
    int direction;   /* s: the second pose moves by s (+1 or -1) as the first moves by 1 */
    uint32_t length; /* loops in the run */
} pgem_loop_run_t;
/* Which loops may be members of a run. */
typedef enum pgem_run_members { PGEM_RUN_ANY, PGEM_RUN_ACCEPTED, PGEM_RUN_PRUNED } pgem_run_members_t;
/* The loop after loop k in a run of `direction` among `members` (UINT32_MAX if none; the first
 * in edge order); the length of the run starting at loop k (0 if k is not a member or a member
 * precedes it; a loop without a successor counts 1, whatever precedes it). */
uint32_t pgem_run_next(const pgem_store_t *store, uint32_t k, int direction,
                       pgem_run_members_t members);
uint32_t pgem_run_length(const pgem_store_t *store, uint32_t k, int direction,
                         pgem_run_members_t members);
/* Every loop of run (walked among `members`) at weight, and at state (a pgem_edge_state_t) unless
 * state is PGEM_RUN_KEEP_STATE. */
#define PGEM_RUN_KEEP_STATE (-1)
void pgem_run_set(pgem_store_t *store, const pgem_loop_run_t *run, pgem_run_members_t members,
                  double weight, int state);
/* 1 if more than PGEM_MOST_REJECTED of `loops` loop closures (and at least one) are rejected:
 * the degenerate outcome the summary reports and EM's rescue and leave-run-out test act on. */
static inline int pgem_share_most_rejected(uint32_t rejected, uint32_t loops)
{
    return loops > 0u && (double)rejected > PGEM_MOST_REJECTED * (double)loops;
}
/* 1 if more than PGEM_MOST_REJECTED of the loops (and at least one) are pruned. */
int pgem_most_rejected(const pgem_store_t *store);
/* The outcome a summary reports for `rejected` of `loops` loop closures (robust/solve.c): the
 * robust solve's, and pgem_update's from its running counts. */
pgem_robust_outcome_t pgem_loops_outcome(uint32_t rejected, uint32_t loops);
/* The adjustment's redundancy: rows of the edges not pruned (weight 0 included) less the
 * unknowns. */
double pgem_redundancy(const pgem_store_t *store, const pgem_linear_t *linear, int tangent);
/* The 99.9% quantile of the chi-square distribution with dof degrees of freedom
 * (Wilson-Hilferty). */
double pgem_chi2_quantile(double dof);
/* The 0.1% quantile (Wilson-Hilferty; 0 where the approximation goes below 0). */
double pgem_chi2_lower_quantile(double dof);
/* When every loop was rejected (robust/rescue.c): the longest runs of loops along a revisit,
 * tried alone from the initial estimate; *rescued = 1 and the run active, polished, if one
 * passes the adjustment's global chi-square test, else every loop pruned and polished again. */
int pgem_em_rescue(const pgem_robust_parts_t *parts, const pgem_solve_options_t *solve,
                   pgem_robust_summary_t *summary, int *rescued);
/* The leave-run-out test (robust/leave_run.c), after a consistency test that changed nothing
 * on a degenerate outcome (pgem_most_rejected): the first run of accepted loops whose leaving
 * would make the chi2 fall by more than the 99.9% quantile for its rows is pruned at weight
 * 0; returns 1 if one was (0 if none: the estimate is not moved). */
uint32_t pgem_em_leave_run_out(const pgem_robust_parts_t *parts, pgem_robust_summary_t *summary,
                               int *status);
/* The minimum of the Gauss-Newton model of the adjustment at the current estimate and weights
 * (robust/leave_run.c): its chi2 less the decrease a step would bring, exact for a linear
 * problem; the estimate is not moved (one factorisation). *status set if the factor fails. */
double pgem_model_minimum(const pgem_robust_parts_t *parts, int *status);
/* The leave-group-out test (robust/groups.c), after a consistency test that changed nothing on
 * any other outcome: a run of loops (any state) is a group, tested through its accepted
 * members; the group that fails its test by the largest factor is pruned at weight 0; returns
 * 1 if one was (0 if none: the estimate is not moved). A factorisation that fails decides
 * nothing (*status stays PGEM_OK). */
uint32_t pgem_em_leave_group_out(const pgem_robust_parts_t *parts, pgem_robust_summary_t *summary,
                                 int *status);
/* The consistency test (robust/gate.c): the gate, then the loops it re-admits or prunes under
 * the current (polished) estimate; returns how many changed state. */
double pgem_em_gate_value(int tangent, const pgem_robust_options_t *options);
uint32_t pgem_em_gate(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                      double gate, pgem_robust_summary_t *summary);
/* Oscillation between EM's passes (robust/settle.c). A pass's mark: a fingerprint of its
 * loops' states (accepted, pruned, left out with a run), how many are accepted, and the
 * robust cost of its polished estimate (odometry chi2 plus every loop's Cauchy rho at
 * `scale`). The last PGEM_PASS_MARKS marks are kept (on the stack: no storage in the block). */
#define PGEM_PASS_MARKS 8u
typedef struct pgem_pass_mark {
    uint64_t set;      /* FNV-1a of every loop's index and state */
    uint32_t accepted; /* loops accepted */
    double cost;       /* robust cost at the polished estimate */
} pgem_pass_mark_t;
typedef struct pgem_settle {
    pgem_pass_mark_t marks[PGEM_PASS_MARKS]; /* the last passes' marks, a ring */
    uint32_t count;                          /* passes marked */
    int cycling;                             /* 1 once a cycle was found */
    pgem_pass_mark_t target;                 /* then: its cheapest set */
    uint32_t remaining;                      /* passes left to reach it */
} pgem_settle_t;
void pgem_pass_mark(const pgem_store_t *store, int tangent, double scale, pgem_pass_mark_t *mark);
/* After a pass's polish: 1 if the passes should end here, oscillating (this pass came back to
 * the set of an earlier one and is the cheapest of the cycle, or reached the cheapest after
 * one was found, or strayed from the cycle for as many passes as it had); 0 to go on. A
 * settle starts zeroed. */
int pgem_settle_pass(pgem_settle_t *settle, const pgem_pass_mark_t *mark);
/* IRLS for the kernels that never prune (robust/irls.c). */
int pgem_irls(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
              const pgem_solve_options_t *solve, pgem_robust_summary_t *summary);

#endif /* PGEM_ROBUST_LAYER_H */
