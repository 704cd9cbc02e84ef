/* The frames of a team's robots (issue 36, item 2): before EM's first E-step, each part of the
 * graph that its odometry alone leaves without a held pose (a robot whose odometry starts at
 * its own origin) is placed in the frame on which most of the loops that join it to the placed
 * parts agree. Each such loop implies a frame for the part (pose_a * z * pose_b^-1); a frame is
 * voted for by every loop whose error under it passes the consistency test's gate, under a
 * covariance of both loops' measurements and the odometry drift between their ends; the
 * hypothesis with most votes wins, refined over its voters. Parts are placed one at a time,
 * the best-supported first, so a robot joined only to another unplaced robot waits for it.
 * Memory: the factor's shared region (free between solves) and the loops' distances
 * (edge_distance, rewritten by every E-step before it is read); nothing in the block. */
#include <math.h>
#include <string.h>

#include "robust/robust.h"

/* At most this many of a part's loops are tried as its frame (evenly spread over the rest). */
#define PGEM_FRAMES_HYPOTHESES 256u
#define PGEM_FRAMES_UNPLACED 0u
#define PGEM_FRAMES_PLACED 1u
#define PGEM_FRAMES_NONE UINT32_MAX
/* A variance floor (rad^2 and m^2), so a loop or odometry given infinite information is not
 * divided by zero. */
#define PGEM_FRAMES_VARIANCE_MIN 1e-12

typedef struct pgem_frames {
    pgem_store_t *store;
    int tangent;      /* error rows per edge: 3 or 6 */
    size_t pose_size; /* doubles per pose: 3 or 7 */
    uint32_t *part;   /* [max_poses] union-find parent, then each pose's root */
    uint32_t *state;  /* [max_poses] the search's queue; then per root: placed or not */
    int32_t *first;   /* [max_poses] a pose's first odometry end; then per root, its loops' end */
    int32_t *next;    /* [2 max_edges] the next odometry end of the same pose; then the loops
                         that join an unplaced part to the placed ones, grouped by part */
    float *drift;     /* [3 max_poses] along odometry from the part's root: the rotation's
                         variance (rad^2), the translation's (m^2), the path's length (m) */
    float *loop_var;  /* [2 max_edges] a loop's rotation and translation variances */
    double inflation; /* the odometry's variances are multiplied by it (the options') */
    double gate;      /* the consistency test's gate */
} pgem_frames_t;

/* A loop that may place a part: its index, which end is in the unplaced part. */
typedef struct pgem_frames_loop {
    uint32_t k;
    uint32_t placed; /* pose index of the end in a placed part */
    uint32_t moving; /* pose index of the end in the part to place */
    int moving_is_to;
} pgem_frames_loop_t;

static void pgem_frames_compose(int tangent, const double *a, const double *b, double *out)
{
    if (tangent == 3) {
        pgem_se2_compose(a, b, out);
    } else {
        pgem_se3_compose(a, b, out);
    }
}

static void pgem_frames_inverse(int tangent, const double *a, double *out)
{
    if (tangent == 3) {
        pgem_se2_inverse(a, out);
    } else {
        pgem_se3_inverse(a, out);
    }
}

/* Edge k's rotation variance (rad^2: the g2o 3D error is half the angle) and translation
 * variance (m^2, the trace), and the length of its translation. */
static void pgem_frames_edge_variances(const pgem_frames_t *f, uint32_t k, double *rotation,
                                       double *translation, double *length)
{
    const int n = f->tangent;
    double covariance[PGEM_SMALL_MAX * PGEM_SMALL_MAX];
    const double *z = f->store->edge_measurement + (size_t)k * f->pose_size;
    const int dims = n == 3 ? 2 : 3;
    double squared = 0.0;
    for (int i = 0; i < dims; i++) {
        squared += z[i] * z[i];
    }
    *length = sqrt(squared);
    const double *information = f->store->edge_information + (size_t)k * (size_t)(n * n);
    if (!pgem_small_inverse(information, covariance, n)) {
        *rotation = *translation = 1e30; /* no information in some direction */
        return;
    }
    double r = 0.0, t = 0.0;
    for (int i = 0; i < dims; i++) {
        t += covariance[i * n + i];
    }
    for (int i = dims; i < n; i++) {
        r += covariance[i * n + i];
    }
    *rotation = fmax(n == 3 ? r : 4.0 * r, PGEM_FRAMES_VARIANCE_MIN);
    *translation = fmax(t, PGEM_FRAMES_VARIANCE_MIN);
}

/* 1 if edge k joins a part: it is not a loop closure, or (with_loops) a loop in the problem. */
static int pgem_frames_joins(const pgem_store_t *store, uint32_t k, int with_loops)
{
    return store->edge_kind[k] != PGEM_EDGE_LOOP ||
           (with_loops && store->edge_active[k] != PGEM_EDGE_PRUNED && store->edge_weight[k] > 0.0);
}

/* The parts over the joining edges (union-find, each pose's root) and their adjacency. */
static void pgem_frames_parts(pgem_frames_t *f, int with_loops)
{
    const pgem_store_t *store = f->store;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        f->part[p] = p;
        f->first[p] = -1;
    }
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (!pgem_frames_joins(store, k, with_loops)) {
            continue;
        }
        (void)pgem_part_join(f->part, store->edge_from[k], store->edge_to[k]);
        f->next[(size_t)2u * k] = f->first[store->edge_from[k]];
        f->first[store->edge_from[k]] = (int32_t)(2u * k);
        f->next[(size_t)2u * k + 1u] = f->first[store->edge_to[k]];
        f->first[store->edge_to[k]] = (int32_t)(2u * k + 1u);
    }
    for (uint32_t p = 0; p < store->pose_count; p++) {
        f->part[p] = pgem_part_root(f->part, p);
    }
}

/* Along the joining edges, from each part's root, the drift each pose carries (breadth
 * first; the state array is the queue). */
static void pgem_frames_drift(pgem_frames_t *f)
{
    const pgem_store_t *store = f->store;
    const uint32_t poses = store->pose_count;
    for (uint32_t p = 0; p < poses; p++) {
        f->drift[(size_t)3u * p + 2u] = -1.0f; /* not reached yet */
    }
    for (uint32_t root = 0; root < poses; root++) {
        if (f->part[root] != root) {
            continue;
        }
        uint32_t head = 0, tail = 0;
        f->state[tail++] = root;
        f->drift[(size_t)3u * root] = f->drift[(size_t)3u * root + 1u] = f->drift[(size_t)3u * root + 2u] = 0.0f;
        while (head < tail) {
            const uint32_t p = f->state[head++];
            for (int32_t end = f->first[p]; end >= 0; end = f->next[end]) {
                const uint32_t k = (uint32_t)end / 2u;
                const uint32_t q = (end & 1) != 0 ? store->edge_from[k] : store->edge_to[k];
                if (f->drift[(size_t)3u * q + 2u] >= 0.0f) {
                    continue;
                }
                double rotation = 0.0, translation = 0.0, length = 0.0;
                pgem_frames_edge_variances(f, k, &rotation, &translation, &length);
                f->drift[(size_t)3u * q] = f->drift[(size_t)3u * p] + (float)(f->inflation * rotation);
                f->drift[(size_t)3u * q + 1u] = f->drift[(size_t)3u * p + 1u] + (float)(f->inflation * translation);
                f->drift[(size_t)3u * q + 2u] = f->drift[(size_t)3u * p + 2u] + (float)length;
                f->state[tail++] = q;
            }
        }
    }
}

/* The drift between poses p and q (component c of drift): along their part, or through both
 * parts' roots. */
static double pgem_frames_between(const pgem_frames_t *f, uint32_t p, uint32_t q, uint32_t c)
{
    const double a = (double)f->drift[(size_t)3u * p + c], b = (double)f->drift[(size_t)3u * q + c];
    return f->part[p] == f->part[q] ? fabs(a - b) : a + b;
}

/* Loop k as a candidate: the root of the unplaced part it joins to a placed one, or NONE. */
static uint32_t pgem_frames_side(const pgem_frames_t *f, uint32_t k, pgem_frames_loop_t *loop)
{
    const pgem_store_t *store = f->store;
    const uint32_t from = store->edge_from[k], to = store->edge_to[k];
    const uint32_t a = f->part[from], b = f->part[to];
    loop->k = k;
    loop->moving_is_to = 0;
    loop->placed = from;
    loop->moving = to;
    if (a == b || (f->state[a] == PGEM_FRAMES_PLACED) == (f->state[b] == PGEM_FRAMES_PLACED)) {
        return PGEM_FRAMES_NONE;
    }
    loop->moving_is_to = f->state[a] == PGEM_FRAMES_PLACED;
    loop->placed = loop->moving_is_to ? from : to;
    loop->moving = loop->moving_is_to ? to : from;
    return loop->moving_is_to ? b : a;
}

/* The frame loop implies for its unplaced part (applied on the left of that part's poses) and
 * the pose it wants for its moving end. */
static void pgem_frames_implied(const pgem_frames_t *f, const pgem_frames_loop_t *loop,
                                double frame[7], double target[7])
{
    const pgem_store_t *store = f->store;
    const size_t size = f->pose_size;
    const double *z = store->edge_measurement + (size_t)loop->k * size;
    double inverse[7];
    if (loop->moving_is_to) { /* z = placed^-1 moving */
        pgem_frames_compose(f->tangent, store->pose + loop->placed * size, z, target);
    } else { /* z = moving^-1 placed */
        pgem_frames_inverse(f->tangent, z, inverse);
        pgem_frames_compose(f->tangent, store->pose + loop->placed * size, inverse, target);
    }
    pgem_frames_inverse(f->tangent, store->pose + loop->moving * size, inverse);
    pgem_frames_compose(f->tangent, target, inverse, frame);
}

/* Loop l's error with its part placed by `frame` (implied by loop h), squared and divided by
 * a variance made of both loops' measurements and the odometry drift between their ends: the
 * rotation's and the translation's, summed. */
static double pgem_frames_distance(const pgem_frames_t *f, const pgem_frames_loop_t *h,
                                   const pgem_frames_loop_t *l, const double frame[7])
{
    const size_t size = f->pose_size;
    const pgem_store_t *store = f->store;
    const double *z = store->edge_measurement + (size_t)l->k * size;
    double moved[7], e[6];
    pgem_frames_compose(f->tangent, frame, store->pose + l->moving * size, moved);
    const double *xi = l->moving_is_to ? store->pose + l->placed * size : moved;
    const double *xj = l->moving_is_to ? moved : store->pose + l->placed * size;
    double angle2 = 0.0, shift2 = 0.0;
    if (f->tangent == 3) {
        pgem_se2_error(xi, xj, z, e, NULL, NULL);
        shift2 = e[0] * e[0] + e[1] * e[1];
        angle2 = e[2] * e[2];
    } else {
        pgem_se3_error(xi, xj, z, e, NULL, NULL);
        shift2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
        const double half = asin(fmin(1.0, sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])));
        angle2 = 4.0 * half * half;
    }
    const double rotation_a = pgem_frames_between(f, h->placed, l->placed, 0u);
    const double rotation_b = pgem_frames_between(f, h->moving, l->moving, 0u);
    const double path_a = pgem_frames_between(f, h->placed, l->placed, 2u);
    const double path_b = pgem_frames_between(f, h->moving, l->moving, 2u);
    const double rotation = (double)f->loop_var[(size_t)2u * h->k] + (double)f->loop_var[(size_t)2u * l->k] +
                            rotation_a + rotation_b;
    /* a heading error grows a position error along the path: about its variance times the
     * path's length squared over 3 for a walk of even steps */
    const double translation = (double)f->loop_var[(size_t)2u * h->k + 1u] + (double)f->loop_var[(size_t)2u * l->k + 1u] +
                               pgem_frames_between(f, h->placed, l->placed, 1u) +
                               pgem_frames_between(f, h->moving, l->moving, 1u) +
                               (rotation_a * path_a * path_a + rotation_b * path_b * path_b) / 3.0;
    return angle2 / rotation + shift2 / translation;
}

/* The candidates of one part (loops[first .. end) of next): the hypothesis with most votes
 * (the fewest summed distances among equals); its votes, 0 if none is finite. */
static uint32_t pgem_frames_vote(const pgem_frames_t *f, uint32_t first, uint32_t end, uint32_t *best)
{
    const uint32_t count = end - first;
    const uint32_t stride = count > PGEM_FRAMES_HYPOTHESES ? (count + PGEM_FRAMES_HYPOTHESES - 1u) / PGEM_FRAMES_HYPOTHESES : 1u;
    uint32_t best_votes = 0;
    double best_cost = (double)INFINITY;
    for (uint32_t i = first; i < end; i += stride) {
        pgem_frames_loop_t h, l;
        (void)pgem_frames_side(f, (uint32_t)f->next[i], &h);
        double frame[7], target[7];
        pgem_frames_implied(f, &h, frame, target);
        uint32_t votes = 0;
        double cost = 0.0;
        for (uint32_t j = first; j < end; j++) {
            (void)pgem_frames_side(f, (uint32_t)f->next[j], &l);
            const double d = pgem_frames_distance(f, &h, &l, frame);
            if (d <= f->gate) { /* NaN never votes */
                votes++;
                cost += d;
            }
        }
        if (votes > best_votes || (votes == best_votes && votes > 0u && cost < best_cost)) {
            best_votes = votes;
            best_cost = cost;
            *best = i;
        }
    }
    return best_votes;
}

/* The frame of the winning hypothesis refined over its voters: the rotation their frames'
 * mean (about the winner's), then the translation that puts the moving ends, rotated, where
 * the loops want them on average (least squares). */
static void pgem_frames_refine(const pgem_frames_t *f, uint32_t first, uint32_t end, uint32_t best,
                               double out[7])
{
    const size_t size = f->pose_size;
    pgem_frames_loop_t h, l;
    double frame[7], target[7], other[7], mean[3] = {0.0, 0.0, 0.0};
    (void)pgem_frames_side(f, (uint32_t)f->next[best], &h);
    pgem_frames_implied(f, &h, frame, target);
    uint32_t voters = 0;
    for (uint32_t j = first; j < end; j++) {
        (void)pgem_frames_side(f, (uint32_t)f->next[j], &l);
        if (!(pgem_frames_distance(f, &h, &l, frame) <= f->gate)) {
            continue;
        }
        pgem_frames_implied(f, &l, other, target);
        if (f->tangent == 3) {
            mean[0] += pgem_wrap_angle(other[2] - frame[2]);
        } else {
            double conjugate[4] = {-frame[3], -frame[4], -frame[5], frame[6]}, relative[4], phi[3];
            pgem_quat_multiply(conjugate, other + 3, relative);
            pgem_so3_log(relative, phi);
            for (int c = 0; c < 3; c++) {
                mean[c] += phi[c];
            }
        }
        voters++;
    }
    memcpy(out, frame, size * sizeof(double));
    if (f->tangent == 3) {
        out[2] = pgem_wrap_angle(frame[2] + mean[0] / (double)voters);
    } else {
        double phi[3] = {mean[0] / (double)voters, mean[1] / (double)voters, mean[2] / (double)voters}, step[4];
        pgem_so3_exp(phi, step);
        pgem_quat_multiply(frame + 3, step, out + 3);
        (void)pgem_quat_normalize(out + 3);
    }
    /* translation: the mean of target - R moving over the voters */
    const int dims = f->tangent == 3 ? 2 : 3;
    double shift[3] = {0.0, 0.0, 0.0};
    for (uint32_t j = first; j < end; j++) {
        (void)pgem_frames_side(f, (uint32_t)f->next[j], &l);
        if (!(pgem_frames_distance(f, &h, &l, frame) <= f->gate)) {
            continue;
        }
        pgem_frames_implied(f, &l, other, target);
        const double *moving = f->store->pose + l.moving * size;
        double rotated[3];
        if (f->tangent == 3) {
            const double c = cos(out[2]), s = sin(out[2]);
            rotated[0] = c * moving[0] - s * moving[1];
            rotated[1] = s * moving[0] + c * moving[1];
        } else {
            pgem_quat_rotate(out + 3, moving, rotated);
        }
        for (int c = 0; c < dims; c++) {
            shift[c] += target[c] - rotated[c];
        }
    }
    for (int c = 0; c < dims; c++) {
        out[c] = shift[c] / (double)voters;
    }
}

/* The loops that join an unplaced part to a placed one into next, grouped by the part (its
 * group ends at first[root], groups in the order of their roots); how many. */
static uint32_t pgem_frames_gather(pgem_frames_t *f)
{
    const pgem_store_t *store = f->store;
    pgem_frames_loop_t loop;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        f->first[p] = 0;
    }
    uint32_t count = 0;
    for (uint32_t k = 0; k < store->edge_count; k++) {
        const uint32_t root = store->edge_kind[k] == PGEM_EDGE_LOOP ? pgem_frames_side(f, k, &loop) : PGEM_FRAMES_NONE;
        if (root != PGEM_FRAMES_NONE) {
            f->first[root]++;
            count++;
        }
    }
    int32_t end = 0;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        end += f->first[p];
        f->first[p] = end;
    }
    for (uint32_t k = store->edge_count; k-- > 0u;) {
        const uint32_t root = store->edge_kind[k] == PGEM_EDGE_LOOP ? pgem_frames_side(f, k, &loop) : PGEM_FRAMES_NONE;
        if (root != PGEM_FRAMES_NONE) {
            f->next[--f->first[root]] = (int32_t)k;
        }
    }
    /* first[root] is now the group's start; make it the end (the next group's start) */
    int32_t start = (int32_t)count;
    for (uint32_t p = store->pose_count; p-- > 0u;) {
        if (f->part[p] == p && f->state[p] == PGEM_FRAMES_UNPLACED) {
            const int32_t own = f->first[p];
            f->first[p] = start;
            start = own;
        }
    }
    return count;
}

/* One part placed: the best-supported unplaced part (most votes; a part joined by a single
 * loop counts, one whose loops all disagree does not) moved into its frame. 1 if one was. */
static int pgem_frames_place_one(pgem_frames_t *f)
{
    pgem_store_t *store = f->store;
    if (pgem_frames_gather(f) == 0u) {
        return 0;
    }
    uint32_t chosen = PGEM_FRAMES_NONE, chosen_votes = 0, chosen_best = 0, chosen_first = 0, start = 0;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (f->part[p] != p || f->state[p] != PGEM_FRAMES_UNPLACED) {
            continue;
        }
        const uint32_t first = start, end = (uint32_t)f->first[p];
        start = end;
        uint32_t best = first;
        const uint32_t votes = end > first ? pgem_frames_vote(f, first, end, &best) : 0u;
        if ((votes >= 2u || end - first == 1u) && votes > chosen_votes) {
            chosen = p;
            chosen_votes = votes;
            chosen_best = best;
            chosen_first = first;
        }
    }
    if (chosen == PGEM_FRAMES_NONE) {
        return 0;
    }
    /* a part that already stands where as many of its loops say stays */
    const double identity[7] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0}; /* 2D: the first three */
    pgem_frames_loop_t h, l;
    (void)pgem_frames_side(f, (uint32_t)f->next[chosen_best], &h);
    uint32_t staying = 0;
    for (uint32_t j = chosen_first; j < (uint32_t)f->first[chosen]; j++) {
        (void)pgem_frames_side(f, (uint32_t)f->next[j], &l);
        staying += (uint32_t)(pgem_frames_distance(f, &h, &l, identity) <= f->gate);
    }
    if (staying >= chosen_votes) {
        f->state[chosen] = PGEM_FRAMES_PLACED;
        return 1;
    }
    double frame[7];
    pgem_frames_refine(f, chosen_first, (uint32_t)f->first[chosen], chosen_best, frame);
    for (size_t c = 0; c < f->pose_size; c++) {
        if (!isfinite(frame[c])) {
            f->state[chosen] = PGEM_FRAMES_PLACED; /* left where it is */
            return 1;
        }
    }
    const size_t size = f->pose_size;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (f->part[p] == chosen) {
            pgem_frames_compose(f->tangent, frame, store->pose + p * size, store->pose + p * size);
        }
    }
    f->state[chosen] = PGEM_FRAMES_PLACED;
    return 2;
}

uint32_t pgem_robust_frames(const pgem_robust_parts_t *parts, const pgem_robust_options_t *options,
                            int with_loops)
{
    const pgem_store_t *store = parts->solve.store;
    const pgem_config_t *config = parts->solve.config;
    const size_t max_poses = config->max_poses, max_edges = config->max_edges;
    size_t bytes = 0;
    unsigned char *region = pgem_linear_shared_region(parts->solve.linear, &bytes);
    if (store->pose_count < 2u || bytes < 4u * (6u * max_poses + 2u * max_edges)) {
        return 0;
    }
    pgem_frames_t f;
    f.store = parts->solve.store;
    f.tangent = parts->tangent;
    f.pose_size = (size_t)PGEM_POSE_SIZE(config->dimension);
    f.drift = (float *)(void *)region;
    f.part = (uint32_t *)(void *)(f.drift + 3u * max_poses);
    f.state = f.part + max_poses;
    f.first = (int32_t *)(void *)(f.state + max_poses);
    f.next = f.first + max_poses;
    f.loop_var = (float *)(void *)parts->state->edge_distance;
    f.inflation = options->odometry_inflation;
    f.gate = pgem_em_gate_value(parts->tangent, options);
    pgem_frames_parts(&f, with_loops);
    /* the parts that hold a fixed pose (or the first pose, when none is fixed) are placed; the
     * others are to place, those held at a damped gauge too (pgem_hold_gauge: loop closures
     * may place them; the bridge holds its robots so) */
    uint32_t placed = 0, unplaced = 0;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        f.state[p] = PGEM_FRAMES_UNPLACED;
    }
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (PGEM_POSE_HELD(store, p)) {
            f.state[f.part[p]] = PGEM_FRAMES_PLACED;
        }
    }
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (f.part[p] == p) {
            placed += (uint32_t)(f.state[p] == PGEM_FRAMES_PLACED);
            unplaced += (uint32_t)(f.state[p] == PGEM_FRAMES_UNPLACED);
        }
    }
    if (placed == 0u || unplaced == 0u) {
        return 0;
    }
    pgem_frames_drift(&f); /* (its queue is the state array: the states again after it) */
    for (uint32_t p = 0; p < store->pose_count; p++) {
        f.state[p] = PGEM_FRAMES_UNPLACED;
    }
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (PGEM_POSE_HELD(store, p)) {
            f.state[f.part[p]] = PGEM_FRAMES_PLACED;
        }
    }
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_kind[k] == PGEM_EDGE_LOOP) {
            double rotation = 0.0, translation = 0.0, length = 0.0;
            pgem_frames_edge_variances(&f, k, &rotation, &translation, &length);
            f.loop_var[(size_t)2u * k] = (float)rotation;
            f.loop_var[(size_t)2u * k + 1u] = (float)(translation + rotation * length * length);
        }
    }
    uint32_t moved = 0;
    for (int step = pgem_frames_place_one(&f); step != 0; step = pgem_frames_place_one(&f)) {
        moved += (uint32_t)(step == 2);
    }
    return moved;
}
