/* Pieces of pgem eval shared by its files: trajectory accuracy and loop-rejection scores. */
#ifndef PGEM_EVAL_H
#define PGEM_EVAL_H

#include <stddef.h>

#include "cli.h"

/* The default rejection threshold (pgem eval --reject-below, pgem plot): the EM prune
 * threshold. */
#define PGEM_EVAL_REJECT_BELOW 0.01

/* Trajectory accuracy of a result against a reference. */
typedef struct eval_trajectory {
    int dimension;               /* 2 or 3 */
    size_t matched;              /* pose ids in both files */
    size_t only_result;          /* pose ids only in the result */
    size_t only_reference;       /* pose ids only in the reference */
    double ate_translation;      /* RMSE of the position error after alignment, metres */
    double ate_rotation_deg;     /* RMS angle of R_ref^T R_aligned, degrees */
    double rpe_translation;      /* RMSE of the relative-motion translation error, metres */
    double rpe_rotation_deg;     /* RMS angle of the relative-motion error, degrees */
    double extent;               /* RMS distance of the matched reference positions from
                                    their centroid, metres */
} eval_trajectory_t;

/* One line of a weights file, with its verdict. */
typedef struct eval_loop {
    pgem_id_t from;
    pgem_id_t to;
    double weight;
    unsigned long line;          /* line of the weights file */
    int pruned;                  /* state 'pruned' */
    int rejected;                /* pruned, or weight below the threshold */
    int is_false;                /* one of the false loops of the outliers file */
} eval_loop_t;

/* Loop-rejection counts and rates (rejected loops are the positives; the inlier rates take
 * the accepted loops as the positives). An empty denominator gives a rate of 1. */
typedef struct eval_scores {
    size_t loops;                /* lines of the weights file */
    size_t outliers;             /* lines of the outliers file */
    size_t rejected;
    size_t true_positives;       /* false loops rejected */
    size_t false_positives;      /* true loops rejected */
    size_t false_negatives;      /* false loops accepted */
    double precision;            /* true_positives / rejected */
    double recall;               /* true_positives / outliers */
    double inlier_precision;     /* true loops accepted / loops accepted */
    double inlier_recall;        /* true loops accepted / true loops */
} eval_scores_t;

/* Reads a graph file for evaluation (quaternions normalised). Prints errors; returns a
 * PGEM_EXIT_* code. */
int pgem_eval_read_graph(const char *path, pgem_io_graph_t *graph);

/* Matches the poses of res to those of ref by id and measures ATE, RPE and the extent.
 * Prints errors (different dimensions, fewer than 2 matches); returns a PGEM_EXIT_* code. */
int pgem_eval_trajectory(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                         eval_trajectory_t *out);

/* Reads the outliers and weights files, marks the false loops and scores the rejection at
 * threshold reject_below. *loops (scores->loops entries, weights-file order) is the
 * caller's to free, also on failure. Prints errors naming FILE:LINE; returns a PGEM_EXIT_*
 * code. */
int pgem_eval_loops(const char *outliers, const char *weights, double reject_below,
                    eval_loop_t **loops, eval_scores_t *scores);

/* Sets rejected on each of loops[0..count): pruned, or a weight below reject_below. */
void pgem_eval_mark_rejected(eval_loop_t *loops, size_t count, double reject_below);

/* Reads a weights file alone ('from to weight state' per line) into *loops (*count entries,
 * file order; is_false and rejected left 0). *loops is the caller's to free, also on
 * failure. Prints errors naming FILE:LINE; returns a PGEM_EXIT_* code. */
int pgem_eval_read_weights(const char *weights, eval_loop_t **loops, size_t *count);

/* Reads an outliers file and sets is_false on the false loops among loops[0..count), matched
 * as pgem_eval_loops matches them; loops_path names where the loops came from in messages.
 * *outlier_count is the number of outliers lines. Prints errors; returns a PGEM_EXIT_* code. */
int pgem_eval_mark_outliers(const char *outliers, const char *loops_path, eval_loop_t *loops,
                            size_t count, size_t *outlier_count);

/* The rigid alignment of the ATE: matches the poses of res (res_ids: its poses sorted by id,
 * from pgem_io_index_poses) to those of ref by id (same dimension) and finds the rotation
 * (unit quaternion [qx qy qz qw], about z in 2D) and centroids with
 * ref_k ~ R (res_k - c_res) + c_ref over the *matched positions (the identity when none
 * match). Prints an error and returns PGEM_EXIT_FAILURE if out of memory. */
int pgem_eval_align(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                    const pgem_io_pose_index_t *res_ids, double rotation[4], double c_ref[3],
                    double c_res[3], size_t *matched);

#endif /* PGEM_EVAL_H */
