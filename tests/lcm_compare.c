/* Test helper for the LCM end-to-end tests: do two results agree?
 *
 *   lcm_compare A.g2o B.g2o TOLERANCE [WEIGHTS_A WEIGHTS_B]
 *
 * Poses are matched by id: both files must hold the same ids. B is first moved rigidly so that
 * its pose with the smallest id coincides with A's (the gauge: a graph's solution is defined up
 * to the pose held fixed, and a bridge fed out of order may hold a pose it had to place
 * itself); the size of that move is printed. Then every pose component must agree within
 * TOLERANCE (angles and quaternions compared as rotations: the wrapped angle
 * difference in 2D, |q_a - q_b| up to sign in 3D). With weights files ("from to weight state"
 * lines, any order), the multisets of (from, to, state) must be equal. Prints the largest
 * difference and the first disagreement; exit 0 when they agree, 1 when not, 2 on bad input. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pgem/io.h"
#include "pgem/pgem.h"

static int compare_ids(const void *a, const void *b)
{
    const pgem_io_pose_t *x = a;
    const pgem_io_pose_t *y = b;
    return x->id < y->id ? -1 : x->id > y->id ? 1 : 0;
}

static double pose_difference(int dimension, const double *a, const double *b)
{
    double worst = 0.0;
    if (dimension == 2) {
        worst = fmax(fabs(a[0] - b[0]), fabs(a[1] - b[1]));
        return fmax(worst, fabs(pgem_wrap_angle(a[2] - b[2])));
    }
    for (int i = 0; i < 3; ++i) {
        worst = fmax(worst, fabs(a[i] - b[i]));
    }
    double same = 0.0;
    double flipped = 0.0;
    for (int i = 3; i < 7; ++i) {
        same = fmax(same, fabs(a[i] - b[i]));
        flipped = fmax(flipped, fabs(a[i] + b[i]));
    }
    return fmax(worst, fmin(same, flipped));
}

/* Moves every pose of b by T = reference * b0^-1, so b's first (smallest-id) pose lands on
 * reference; prints the size of T. */
static void align(int dimension, const double *reference, pgem_io_graph_t *b)
{
    double inverse[7];
    double move[7];
    double moved[7];
    if (dimension == 2) {
        pgem_se2_inverse(b->poses[0].pose, inverse);
        pgem_se2_compose(reference, inverse, move);
    } else {
        pgem_se3_inverse(b->poses[0].pose, inverse);
        pgem_se3_compose(reference, inverse, move);
    }
    double size = dimension == 2 ? fmax(hypot(move[0], move[1]), fabs(move[2]))
                                 : fmax(sqrt(move[0] * move[0] + move[1] * move[1] +
                                             move[2] * move[2]),
                                        sqrt(move[3] * move[3] + move[4] * move[4] +
                                             move[5] * move[5]));
    printf("gauge: B moved by %.3g to put its pose %llu on A's\n", size,
           (unsigned long long)b->poses[0].id);
    for (size_t i = 0; i < b->pose_count; ++i) {
        if (dimension == 2) {
            pgem_se2_compose(move, b->poses[i].pose, moved);
        } else {
            pgem_se3_compose(move, b->poses[i].pose, moved);
        }
        memcpy(b->poses[i].pose, moved, sizeof(double) * (dimension == 2 ? 3 : 7));
    }
}

static int read_graph(const char *path, pgem_io_graph_t *graph)
{
    char message[512];
    if (pgem_io_read(path, PGEM_FORMAT_AUTO, graph, message, sizeof message) != PGEM_OK) {
        fprintf(stderr, "lcm_compare: %s\n", message);
        return -1;
    }
    qsort(graph->poses, graph->pose_count, sizeof *graph->poses, compare_ids);
    return 0;
}

static int compare_poses(const char *path_a, const char *path_b, double tolerance)
{
    pgem_io_graph_t a;
    pgem_io_graph_t b;
    if (read_graph(path_a, &a) != 0 || read_graph(path_b, &b) != 0) {
        return 2;
    }
    int verdict = 0;
    if (a.pose_count != b.pose_count || a.dimension != b.dimension) {
        printf("poses: %zu (%dD) in %s, %zu (%dD) in %s\n", a.pose_count, a.dimension, path_a,
               b.pose_count, b.dimension, path_b);
        verdict = 1;
    }
    double worst = 0.0;
    size_t worst_index = 0;
    if (verdict == 0 && a.pose_count > 0) {
        align(a.dimension, a.poses[0].pose, &b);
    }
    for (size_t i = 0; verdict == 0 && i < a.pose_count; ++i) {
        if (a.poses[i].id != b.poses[i].id) {
            printf("pose ids differ: %llu in %s, %llu in %s\n",
                   (unsigned long long)a.poses[i].id, path_a,
                   (unsigned long long)b.poses[i].id, path_b);
            verdict = 1;
            break;
        }
        double difference = pose_difference(a.dimension, a.poses[i].pose, b.poses[i].pose);
        if (!(difference <= worst)) {
            worst = difference;
            worst_index = i;
        }
    }
    if (verdict == 0) {
        printf("poses: %zu matched, largest difference %.3g (pose %llu), tolerance %.3g\n",
               a.pose_count, worst, (unsigned long long)a.poses[worst_index].id, tolerance);
        verdict = worst <= tolerance ? 0 : 1;
    }
    pgem_io_graph_free(&a);
    pgem_io_graph_free(&b);
    return verdict;
}

typedef struct loop_line {
    unsigned long long from;
    unsigned long long to;
    int pruned;
} loop_line_t;

static int compare_loops(const void *a, const void *b)
{
    const loop_line_t *x = a;
    const loop_line_t *y = b;
    if (x->from != y->from) {
        return x->from < y->from ? -1 : 1;
    }
    if (x->to != y->to) {
        return x->to < y->to ? -1 : 1;
    }
    return x->pruned - y->pruned;
}

static loop_line_t *read_weights(const char *path, size_t *count, size_t *pruned)
{
    FILE *file = fopen(path, "r");
    if (file == NULL) {
        fprintf(stderr, "lcm_compare: cannot open %s\n", path);
        return NULL;
    }
    size_t capacity = 1024;
    loop_line_t *lines = malloc(capacity * sizeof *lines);
    char text[512];
    *count = 0;
    *pruned = 0;
    while (lines != NULL && fgets(text, sizeof text, file) != NULL) {
        loop_line_t line;
        double weight = 0.0;
        char state[32];
        if (text[0] == '#' || sscanf(text, "%llu %llu %lf %31s", &line.from, &line.to, &weight,
                                     state) != 4) {
            continue;
        }
        line.pruned = strcmp(state, "pruned") == 0;
        *pruned += (size_t)line.pruned;
        if (*count == capacity) {
            capacity *= 2;
            loop_line_t *grown = realloc(lines, capacity * sizeof *lines);
            if (grown == NULL) {
                free(lines);
                lines = NULL;
                break;
            }
            lines = grown;
        }
        lines[(*count)++] = line;
    }
    fclose(file);
    if (lines != NULL) {
        qsort(lines, *count, sizeof *lines, compare_loops);
    }
    return lines;
}

static int compare_weights(const char *path_a, const char *path_b)
{
    size_t count_a = 0;
    size_t count_b = 0;
    size_t pruned_a = 0;
    size_t pruned_b = 0;
    loop_line_t *a = read_weights(path_a, &count_a, &pruned_a);
    loop_line_t *b = read_weights(path_b, &count_b, &pruned_b);
    int verdict = a == NULL || b == NULL ? 2 : 0;
    if (verdict == 0) {
        printf("loops: %zu (%zu pruned) in %s, %zu (%zu pruned) in %s\n", count_a, pruned_a,
               path_a, count_b, pruned_b, path_b);
        verdict = count_a == count_b ? 0 : 1;
    }
    for (size_t i = 0; verdict == 0 && i < count_a; ++i) {
        if (compare_loops(&a[i], &b[i]) != 0) {
            printf("first difference: %llu %llu %s in %s, %llu %llu %s in %s\n", a[i].from,
                   a[i].to, a[i].pruned ? "pruned" : "accepted", path_a, b[i].from, b[i].to,
                   b[i].pruned ? "pruned" : "accepted", path_b);
            verdict = 1;
        }
    }
    free(a);
    free(b);
    return verdict;
}

int main(int argc, char **argv)
{
    if (argc != 4 && argc != 6) {
        fprintf(stderr, "usage: lcm_compare A.g2o B.g2o TOLERANCE [WEIGHTS_A WEIGHTS_B]\n");
        return 2;
    }
    char *end = NULL;
    double tolerance = strtod(argv[3], &end);
    if (end == argv[3] || *end != '\0' || !(tolerance >= 0.0)) {
        fprintf(stderr, "lcm_compare: bad tolerance '%s'\n", argv[3]);
        return 2;
    }
    int verdict = compare_poses(argv[1], argv[2], tolerance);
    if (argc == 6) {
        int loops = compare_weights(argv[4], argv[5]);
        verdict = verdict > loops ? verdict : loops;
    }
    printf("%s\n", verdict == 0 ? "agree" : "DISAGREE");
    return verdict;
}
