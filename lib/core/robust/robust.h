/* The robust layer, private to lib/core: EM's loop-closure weighting and the IRLS kernels over
 * the solver, with what a robust solve keeps (graph->robust): the estimate and edge states to
 * put back if it fails, and each loop's last distance. */
#ifndef PGEM_ROBUST_LAYER_H
#define PGEM_ROBUST_LAYER_H

#include "pgem/robust.h"
#include "solver/solver.h"

/* What a robust solve keeps besides the graph's weights and states. */
typedef struct pgem_robust_state {
    double *pose_initial;      /* [max_poses * pose_size] estimate before a robust solve */
    double *edge_weight_saved; /* [max_edges] weights before a robust solve, and */
    uint8_t *edge_active_saved; /* [max_edges] states: put back if the solve fails */
    double *edge_distance;     /* [max_edges] a loop's distance in the last E-step or test */
    uint8_t *edge_checked;     /* [max_edges] 1 if the map predicted the loop (innovation) */
} pgem_robust_state_t;

/* Carves the robust layer's arrays from the arena (measuring when arena->base is NULL). */
void pgem_robust_carve(pgem_t *graph, pgem_arena_t *arena);

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

#endif /* PGEM_ROBUST_LAYER_H */
