/* pgem eval, trajectory accuracy: matches poses by id, aligns the result rigidly to the
 * reference (Horn's closed form) and measures ATE, RPE and the reference's extent. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "eval.h"

#define EVAL_DEGREES 57.29577951308232 /* 180 / pi */

/* A matched pose: its index in the reference and in the result. */
typedef struct eval_match {
    size_t ref;
    size_t res;
} eval_match_t;

/* Normalises every quaternion of a 3D graph; a norm off 1 by more than 1% is an error (as
 * when the core loads a graph). */
static int eval_normalize(pgem_io_graph_t *graph)
{
    for (size_t k = 0; graph->dimension == 3 && k < graph->pose_count; k++) {
        int refused;
        double norm = pgem_cli_quat_check(graph->poses[k].pose + 3, &refused);
        if (refused) {
            fprintf(stderr, "pgem: %s:%lu: pose %llu has a quaternion of norm %g (off 1 by "
                            "more than 1%%)\n", graph->source, graph->poses[k].line,
                    (unsigned long long)graph->poses[k].id, norm);
            return PGEM_EXIT_FAILURE;
        }
    }
    return PGEM_EXIT_OK;
}

int pgem_eval_read_graph(const char *path, pgem_io_graph_t *graph)
{
    int status =
        pgem_cli_read_graph("pgem", path, PGEM_CLI_NEED_POSES | PGEM_CLI_WARN_CHAINED, graph);
    return status == PGEM_EXIT_OK ? eval_normalize(graph) : status;
}

/* The poses in both graphs, in the reference's order, into *matches (caller frees); res_ids
 * are the poses of res sorted by id. */
static int eval_match_poses(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                            const pgem_io_pose_index_t *res_ids, eval_match_t **matches,
                            size_t *count)
{
    *matches = malloc((ref->pose_count > 0 ? ref->pose_count : 1u) * sizeof **matches);
    *count = 0;
    if (*matches == NULL) {
        fprintf(stderr, "pgem: out of memory\n");
        return PGEM_EXIT_FAILURE;
    }
    for (size_t k = 0; k < ref->pose_count; k++) {
        size_t found = pgem_io_find_pose(res_ids, res->pose_count, ref->poses[k].id);
        if (found != PGEM_IO_NO_POSE) {
            (*matches)[(*count)++] = (eval_match_t){k, found};
        }
    }
    return PGEM_EXIT_OK;
}

/* Eigenvector of the largest eigenvalue of a symmetric 4x4 matrix (cyclic Jacobi). */
static void eval_top_eigenvector(double a[4][4], double vector[4])
{
    double v[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    for (int sweep = 0; sweep < 64; sweep++) {
        double off = 0.0, total = 0.0;
        for (int p = 0; p < 4; p++) {
            for (int q = 0; q < 4; q++) {
                total += a[p][q] * a[p][q];
                off += p != q ? a[p][q] * a[p][q] : 0.0;
            }
        }
        if (off <= 1e-32 * total || off == 0.0) {
            break;
        }
        for (int p = 0; p < 3; p++) {
            for (int q = p + 1; q < 4; q++) {
                if (a[p][q] == 0.0) {
                    continue;
                }
                /* J = identity but J[p][p] = J[q][q] = c, J[p][q] = s, J[q][p] = -s, with
                 * t = s / c the smaller root of t^2 + 2 theta t - 1 = 0: A' = J^T A J has
                 * A'[p][q] = 0. */
                double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
                double t = (theta >= 0.0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < 4; k++) { /* columns: A J and V J */
                    double akp = a[k][p], akq = a[k][q], vkp = v[k][p], vkq = v[k][q];
                    a[k][p] = c * akp - s * akq;
                    a[k][q] = s * akp + c * akq;
                    v[k][p] = c * vkp - s * vkq;
                    v[k][q] = s * vkp + c * vkq;
                }
                for (int k = 0; k < 4; k++) { /* rows: J^T (A J) */
                    double apk = a[p][k], aqk = a[q][k];
                    a[p][k] = c * apk - s * aqk;
                    a[q][k] = s * apk + c * aqk;
                }
            }
        }
    }
    int best = 0;
    for (int k = 1; k < 4; k++) {
        best = a[k][k] > a[best][best] ? k : best;
    }
    for (int k = 0; k < 4; k++) {
        vector[k] = v[k][best];
    }
}

/* Position k (x, y[, z]) of a graph, 0 for a missing z. */
static void eval_position(const pgem_io_graph_t *graph, size_t k, double out[3])
{
    out[0] = graph->poses[k].pose[0];
    out[1] = graph->poses[k].pose[1];
    out[2] = graph->dimension == 3 ? graph->poses[k].pose[2] : 0.0;
}

/* Centroids of the matched positions of both graphs. */
static void eval_centroids(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                           const eval_match_t *matches, size_t count, double c_ref[3],
                           double c_res[3])
{
    double p[3], q[3];
    memset(c_ref, 0, 3 * sizeof *c_ref);
    memset(c_res, 0, 3 * sizeof *c_res);
    for (size_t k = 0; k < count; k++) {
        eval_position(ref, matches[k].ref, p);
        eval_position(res, matches[k].res, q);
        for (int d = 0; d < 3; d++) {
            c_ref[d] += p[d];
            c_res[d] += q[d];
        }
    }
    for (int d = 0; d < 3; d++) {
        c_ref[d] /= (double)count;
        c_res[d] /= (double)count;
    }
}

/* The rotation (unit quaternion [qx qy qz qw]; in 2D about z) minimising
 * sum |R (res_k - c_res) - (ref_k - c_ref)|^2: Horn's closed form, the eigenvector of the
 * largest eigenvalue of a 4x4 matrix built from the cross-covariance. In 2D that reduces to
 * an atan2 of the cross-covariance. */
static void eval_align_rotation(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                                const eval_match_t *matches, size_t count, const double c_ref[3],
                                const double c_res[3], double rotation[4])
{
    double s[3][3] = {{0.0}}, p[3], q[3];
    for (size_t k = 0; k < count; k++) {
        eval_position(ref, matches[k].ref, p);
        eval_position(res, matches[k].res, q);
        for (int i = 0; i < 3; i++) {
            for (int j = 0; j < 3; j++) {
                s[i][j] += (q[i] - c_res[i]) * (p[j] - c_ref[j]); /* result i, reference j */
            }
        }
    }
    if (ref->dimension == 2) {
        double angle = atan2(s[0][1] - s[1][0], s[0][0] + s[1][1]);
        rotation[0] = rotation[1] = 0.0;
        rotation[2] = sin(0.5 * angle);
        rotation[3] = cos(0.5 * angle);
        return;
    }
    /* Horn (1987), quaternion (w, x, y, z). */
    double n[4][4] = {
        {s[0][0] + s[1][1] + s[2][2], s[1][2] - s[2][1], s[2][0] - s[0][2], s[0][1] - s[1][0]},
        {s[1][2] - s[2][1], s[0][0] - s[1][1] - s[2][2], s[0][1] + s[1][0], s[2][0] + s[0][2]},
        {s[2][0] - s[0][2], s[0][1] + s[1][0], -s[0][0] + s[1][1] - s[2][2], s[1][2] + s[2][1]},
        {s[0][1] - s[1][0], s[2][0] + s[0][2], s[1][2] + s[2][1], -s[0][0] - s[1][1] + s[2][2]}};
    double v[4];
    eval_top_eigenvector(n, v);
    double q_out[4] = {v[1], v[2], v[3], v[0]};
    pgem_quat_normalize(q_out);
    memcpy(rotation, q_out, sizeof q_out);
}

/* The rigid alignment of the matched poses: centroids and rotation. */
static void eval_alignment(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                           const eval_match_t *matches, size_t count, double c_ref[3],
                           double c_res[3], double rotation[4])
{
    eval_centroids(ref, res, matches, count, c_ref, c_res);
    eval_align_rotation(ref, res, matches, count, c_ref, c_res, rotation);
}

/* Angle (radians, >= 0) of the rotation from a to b: 2D headings, or 3D unit quaternions. */
static double eval_angle_between(int dimension, const double *a, const double *b)
{
    if (dimension == 2) {
        return fabs(pgem_wrap_angle(b[2] - a[2]));
    }
    double inverse[4] = {-a[3], -a[4], -a[5], a[6]}, relative[4], phi[3];
    pgem_quat_multiply(inverse, b + 3, relative);
    pgem_so3_log(relative, phi);
    return sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]);
}

/* The result's pose k rotated by the alignment (its position is not used). */
static void eval_rotate_pose(int dimension, const double *pose, const double rotation[4],
                             double out[7])
{
    if (dimension == 2) {
        out[2] = pose[2] + 2.0 * atan2(rotation[2], rotation[3]);
        return;
    }
    pgem_quat_multiply(rotation, pose + 3, out + 3);
}

/* ATE and extent: errors of the rigidly aligned result. */
static void eval_ate(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                     const eval_match_t *matches, size_t count, eval_trajectory_t *out)
{
    double c_ref[3], c_res[3], rotation[4], p[3], q[3], aligned[7];
    eval_alignment(ref, res, matches, count, c_ref, c_res, rotation);
    double translation = 0.0, angle = 0.0, spread = 0.0;
    for (size_t k = 0; k < count; k++) {
        const double *ref_pose = ref->poses[matches[k].ref].pose;
        eval_position(ref, matches[k].ref, p);
        eval_position(res, matches[k].res, q);
        for (int d = 0; d < 3; d++) {
            p[d] -= c_ref[d];
            q[d] -= c_res[d];
            spread += p[d] * p[d];
        }
        pgem_quat_rotate(rotation, q, q);
        for (int d = 0; d < 3; d++) {
            translation += (q[d] - p[d]) * (q[d] - p[d]);
        }
        eval_rotate_pose(ref->dimension, res->poses[matches[k].res].pose, rotation, aligned);
        double e = eval_angle_between(ref->dimension, ref_pose, aligned);
        angle += e * e;
    }
    out->ate_translation = sqrt(translation / (double)count);
    out->ate_rotation_deg = sqrt(angle / (double)count) * EVAL_DEGREES;
    out->extent = sqrt(spread / (double)count);
}

/* RPE over consecutive matched poses (in the reference's order). */
static void eval_rpe(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                     const eval_match_t *matches, size_t count, eval_trajectory_t *out)
{
    double translation = 0.0, angle = 0.0;
    for (size_t k = 0; k + 1u < count; k++) {
        const double *a_ref = ref->poses[matches[k].ref].pose;
        const double *b_ref = ref->poses[matches[k + 1u].ref].pose;
        const double *a_res = res->poses[matches[k].res].pose;
        const double *b_res = res->poses[matches[k + 1u].res].pose;
        double delta_ref[7], delta_res[7], error[7], identity[7] = {0, 0, 0, 0, 0, 0, 1};
        if (ref->dimension == 2) {
            pgem_se2_between(a_ref, b_ref, delta_ref);
            pgem_se2_between(a_res, b_res, delta_res);
            pgem_se2_between(delta_ref, delta_res, error);
        } else {
            pgem_se3_between(a_ref, b_ref, delta_ref);
            pgem_se3_between(a_res, b_res, delta_res);
            pgem_se3_between(delta_ref, delta_res, error);
        }
        double squared = error[0] * error[0] + error[1] * error[1];
        squared += ref->dimension == 3 ? error[2] * error[2] : 0.0;
        double e = eval_angle_between(ref->dimension, identity, error);
        translation += squared;
        angle += e * e;
    }
    out->rpe_translation = sqrt(translation / (double)(count - 1u));
    out->rpe_rotation_deg = sqrt(angle / (double)(count - 1u)) * EVAL_DEGREES;
}

int pgem_eval_trajectory(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                         eval_trajectory_t *out)
{
    memset(out, 0, sizeof *out);
    if (ref->dimension != res->dimension) {
        fprintf(stderr, "pgem: dimensions differ: %s is %dD, %s is %dD\n", res->source,
                res->dimension, ref->source, ref->dimension);
        return PGEM_EXIT_FAILURE;
    }
    eval_match_t *matches = NULL;
    size_t count = 0;
    pgem_io_pose_index_t *res_ids = pgem_io_index_poses(res);
    int status = PGEM_EXIT_FAILURE;
    if (res_ids == NULL) {
        fprintf(stderr, "pgem: out of memory\n");
    } else {
        status = eval_match_poses(ref, res, res_ids, &matches, &count);
    }
    free(res_ids);
    if (status == PGEM_EXIT_OK && count < 2u) {
        fprintf(stderr, "pgem: %zu pose id(s) in both %s and %s; at least 2 must match\n",
                count, res->source, ref->source);
        status = PGEM_EXIT_FAILURE;
    }
    if (status == PGEM_EXIT_OK) {
        out->dimension = ref->dimension;
        out->matched = count;
        out->only_result = res->pose_count - count;
        out->only_reference = ref->pose_count - count;
        eval_ate(ref, res, matches, count, out);
        eval_rpe(ref, res, matches, count, out);
    }
    free(matches);
    return status;
}

int pgem_eval_align(const pgem_io_graph_t *ref, const pgem_io_graph_t *res,
                    const pgem_io_pose_index_t *res_ids, double rotation[4], double c_ref[3],
                    double c_res[3], size_t *matched)
{
    eval_match_t *matches = NULL;
    static const double identity[4] = {0.0, 0.0, 0.0, 1.0};
    memcpy(rotation, identity, sizeof identity);
    memset(c_ref, 0, 3 * sizeof *c_ref);
    memset(c_res, 0, 3 * sizeof *c_res);
    int status = eval_match_poses(ref, res, res_ids, &matches, matched);
    if (status == PGEM_EXIT_OK && *matched > 0) {
        eval_alignment(ref, res, matches, *matched, c_ref, c_res, rotation);
    }
    free(matches);
    return status;
}
