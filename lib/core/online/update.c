/* pgem_update: the incremental solve (the online layer's entry). New poses become block columns at the end of the
 * ordering, new edges, relinearised poses and re-admitted loops become rank-one updates of
 * the factor along elimination-tree paths, one triangular solve gives the step from the
 * linearisation points; a rebuild (order, factorise whole) when the factor has grown. */
#include <math.h>
#include <string.h>

#include "online/factor.h"

/* The seed of a new column's diagonal (taken out again once its edges are in). */
#define PGEM_ONLINE_SEED 1.0

typedef struct pgem_update_settings {
    double threshold;  /* relinearisation threshold (negative: any motion) */
    double growth;     /* rebuild when blocks exceed growth x packed + slack */
    uint32_t slack;
    int recent;        /* newest poses ordered last by a rebuild */
    int robust;        /* gate new loops */
    double pending;    /* loops whose chi2 alone exceeds this many gates wait (0: none) */
    double gate;       /* innovation threshold */
    double inflation;  /* the map's covariance factor in the innovation */
    int rebuild;       /* rebuild now */
    int movers;        /* more poses to relinearise than this: refactor instead (0: by cost) */
    uint32_t skip;     /* relinearise on every skip-th update, or once skip poses arrived */
    double wildfire;   /* back-substitution: a step changing less stops there */
} pgem_update_settings_t;

static int pgem_update_resolve(const pgem_online_parts_t *parts,
                               const pgem_update_options_t *options, pgem_update_settings_t *out)
{
    pgem_update_options_t none;
    memset(&none, 0, sizeof none);
    const pgem_update_options_t *o = options != NULL ? options : &none;
    char *message = parts->message;
    if (pgem_text_option(message, o->relinearize_threshold, "relinearize_threshold") != PGEM_OK ||
        pgem_text_option(message, o->reorder_growth, "reorder_growth") != PGEM_OK ||
        pgem_text_option(message, o->gate, "gate") != PGEM_OK ||
        pgem_text_option(message, o->wildfire_threshold, "wildfire_threshold") != PGEM_OK ||
        pgem_text_option(message, o->odometry_inflation, "odometry_inflation") != PGEM_OK ||
        pgem_text_option(message, o->pending, "pending") != PGEM_OK) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    out->threshold = o->relinearize_threshold != 0.0 ? o->relinearize_threshold : 0.1;
    out->growth = o->reorder_growth > 0.0 ? o->reorder_growth : 1.5;
    const uint32_t scaled = parts->config->max_poses / 1000u * 64u;
    out->slack = o->reorder_slack != 0u ? o->reorder_slack : (scaled > 256u ? scaled : 256u);
    out->recent = o->recent_last != 0u ? (int)(o->recent_last > 1000000u ? 1000000u : o->recent_last) : 8;
    out->robust = o->robust != 0;
    out->pending = o->pending;
    out->gate = o->gate > 0.0 ? o->gate : (parts->tangent == 6 ? 22.458 : 16.266);
    out->inflation = o->odometry_inflation > 0.0 ? o->odometry_inflation : 1.0;
    out->rebuild = o->rebuild != 0;
    out->wildfire = o->wildfire_threshold != 0.0 ? o->wildfire_threshold : 1e-3;
    out->movers = (int)(o->relinearize_limit > 1000000u ? 1000000u : o->relinearize_limit);
    out->skip = o->relinearize_skip != 0u ? o->relinearize_skip : 10u;
    return PGEM_OK;
}

/* New poses and edges onto the per-pose edge lists; new poses' linearisation points. */
static void pgem_update_link(const pgem_online_parts_t *parts)
{
    const pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    const size_t size = (size_t)parts->pose_size;
    for (uint32_t p = online->poses_linked; p < store->pose_count; p++) {
        online->pose_edge[p] = -1;
        online->pose_column[p] = -1;
        memcpy(online->lin + p * size, store->pose + p * size, size * sizeof(double));
    }
    online->poses_linked = store->pose_count;
    for (uint32_t k = online->edges_linked; k < store->edge_count; k++) {
        const size_t end = 2u * (size_t)k;
        online->edge_next[end] = online->pose_edge[store->edge_from[k]];
        online->pose_edge[store->edge_from[k]] = (int)end;
        online->edge_next[end + 1u] = online->pose_edge[store->edge_to[k]];
        online->pose_edge[store->edge_to[k]] = (int)(end + 1u);
        online->edge_weight_in[k] = 0.0;
    }
    online->edges_linked = store->edge_count;
}

/* A loop weighing less than this stays out of the incremental factor, as EM keeps its
 * dormant loops out of its own (its default dormant threshold, the prune threshold / 100):
 * an adopted pass's false loops at weights of 1e-6 would otherwise enter the factor's pattern
 * and fill it (long-range false loops), for no change in the estimate. */
#define PGEM_UPDATE_WEIGHT_FLOOR 1e-4

/* Pruned loops tested again in one update, at most: each test is a marginal along two
 * elimination-tree paths, and thousands of pruned loops on the poses a relinearisation moved
 * (a map in parts, most of its loops between them waiting for a pass) made one update take
 * minutes. The rest are tested when their poses move again, or by the next pass. */
#define PGEM_UPDATE_RETESTS 256

/* The weight edge k should have in the factor: 0 when pruned, dormant or below the floor. */
static double pgem_update_weight(const pgem_online_parts_t *parts, uint32_t k)
{
    const pgem_store_t *store = parts->store;
    const double w = store->edge_weight[k];
    return store->edge_active[k] == PGEM_EDGE_ACTIVE && w >= PGEM_UPDATE_WEIGHT_FLOOR ? w : 0.0;
}

/* Adds (sign 1) or removes (sign -1) an edge linearised at the poses given: its rows as one
 * rank-b update, their right-hand side carried into forward by the same rotations. */
static int pgem_update_edge(const pgem_online_parts_t *parts, uint32_t k, const double *from,
                            const double *to, double weight, double sign)
{
    const pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    const int b = online->block;
    double a[2][PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {{0.0}};
    double r[PGEM_TANGENT_SIZE_MAX] = {0.0};
    pgem_online_edge(store, parts->tangent, k, from, to, weight, a[0], a[1], r);
    const int ends[2] = {online->pose_column[store->edge_from[k]],
                         online->pose_column[store->edge_to[k]]};
    int columns[2] = {-1, -1}, count = 0, side[2] = {0, 0};
    for (int s = 0; s < 2; s++) {
        if (ends[s] >= 0) {
            columns[count] = ends[s];
            side[count++] = s;
        }
    }
    if (count == 2 && columns[0] > columns[1]) {
        columns[0] = ends[1];
        columns[1] = ends[0];
        side[0] = 1;
        side[1] = 0;
    }
    for (int row = 0; row < b; row++) { /* the vectors' right-hand side: -sqrt(w) U e */
        online->beta[row] = -r[row];
    }
    for (int t = 0; t < count; t++) { /* the rows of A as b vectors, interleaved */
        double *x = online->vector + (size_t)columns[t] * (size_t)b * (size_t)b;
        for (int c = 0; c < b; c++) {
            for (int row = 0; row < b; row++) {
                x[c * b + row] = a[side[t]][row * b + c];
            }
        }
    }
    return count > 0 ? pgem_online_rank_update(parts, columns, count, sign, b) : PGEM_OK;
}

static const double *pgem_update_lin(const pgem_online_parts_t *parts, uint32_t p)
{
    return parts->online->lin + (size_t)p * (size_t)parts->pose_size;
}

/* Puts edge k into the factor with weight w (> 0), appending columns for its free poses
 * that have none (seeded; their index into seeded[], *seeded_count grows). */
static int pgem_update_insert(const pgem_online_parts_t *parts, uint32_t k, double w,
                              int *seeded, int *seeded_count)
{
    const pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    const uint32_t ends[2] = {store->edge_from[k], store->edge_to[k]};
    for (int s = 0; s < 2; s++) {
        const uint32_t p = ends[s];
        const int held = PGEM_POSE_HELD(store, p);
        if (!held && online->pose_column[p] < 0) {
            memcpy(online->lin + (size_t)p * (size_t)parts->pose_size,
                   store->pose + (size_t)p * (size_t)parts->pose_size,
                   (size_t)parts->pose_size * sizeof(double));
            /* the seed goes once the column's edges are in; a gauge's damping stays */
            const double damping =
                PGEM_POSE_DAMPED(store->pose_fixed[p]) ? PGEM_GAUGE_DAMPING : 0.0;
            const int status = pgem_online_append(parts, p, PGEM_ONLINE_SEED + damping);
            if (status != PGEM_OK) {
                return status;
            }
            seeded[(*seeded_count)++] = online->pose_column[p];
            online->last.poses_added++;
        }
    }
    online->edge_weight_in[k] = w;
    online->last.edges_added++;
    return pgem_update_edge(parts, k, pgem_update_lin(parts, ends[0]),
                            pgem_update_lin(parts, ends[1]), w, 1.0);
}

/* Takes the seeds of the columns listed out again. */
static int pgem_update_unseed(const pgem_online_parts_t *parts, const int *seeded, int count)
{
    pgem_online_t *online = parts->online;
    const int b = online->block;
    for (int s = 0; s < count; s++) {
        double *x = online->vector + (size_t)seeded[s] * (size_t)b * (size_t)b;
        for (int c = 0; c < b; c++) {
            x[c * b + c] = sqrt(PGEM_ONLINE_SEED);
            online->beta[c] = 0.0;
        }
        const int status = pgem_online_rank_update(parts, seeded + s, 1, -1.0, b);
        if (status != PGEM_OK) {
            return status;
        }
    }
    return PGEM_OK;
}

/* 1 if column j's step exceeds the threshold (negative: is not zero). */
static int pgem_update_exceeds(const pgem_online_t *online, int j, double threshold)
{
    const double *d = online->delta + (size_t)j * (size_t)online->block;
    double largest = 0.0;
    for (int c = 0; c < online->block; c++) {
        largest = fabs(d[c]) > largest ? fabs(d[c]) : largest;
    }
    return threshold < 0.0 ? largest > 0.0 : largest > threshold;
}

/* The poses whose step exceeds the threshold: into online->head, flagged in online->mark;
 * returns how many. Every column is looked at: on the updates that skip relinearising, steps
 * may have grown past the threshold that the last back-substitution did not recompute. */
static int pgem_update_due(const pgem_online_parts_t *parts, double threshold)
{
    pgem_online_t *online = parts->online;
    int count = 0;
    for (int j = 0; j < online->columns; j++) {
        const int p = online->column_pose[j];
        online->mark[p] = pgem_update_exceeds(online, j, threshold);
        if (online->mark[p]) {
            online->head[count++] = p;
        }
    }
    return count;
}

/* The work of relinearising the `count` poses due by rank updates: each of their edges is an
 * update and a downdate along the path from its column, some (blocks on the path) x b^3
 * flops each; counted until it passes `bound`. */
static double pgem_update_cost(const pgem_online_parts_t *parts, int count, double bound)
{
    const pgem_online_t *online = parts->online;
    double work = 0.0;
    for (int m = 0; m < count && work <= bound; m++) {
        const int p = online->head[m];
        int edges = 0;
        for (int end = online->pose_edge[p]; end >= 0; end = online->edge_next[end]) {
            edges++;
        }
        double path = 0.0;
        for (int i = online->pose_column[p]; i >= 0 && path * edges <= bound; i = online->parent[i]) {
            path += (double)online->count[i] + 1.0;
        }
        work += 2.0 * path * (double)edges;
    }
    return work;
}

/* Relinearises the `count` poses due by rank updates: each of their edges is added at the
 * new point and removed at the old one (the points move afterwards, pgem_update_move). */
static int pgem_update_relinearise(const pgem_online_parts_t *parts, int count)
{
    const pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    const int b = online->block;
    const size_t size = (size_t)parts->pose_size;
    double moved_from[PGEM_POSE_SIZE_MAX], moved_to[PGEM_POSE_SIZE_MAX];
    for (int m = 0; m < count; m++) {
        const uint32_t p = (uint32_t)online->head[m];
        for (int end = online->pose_edge[p]; end >= 0; end = online->edge_next[end]) {
            const uint32_t k = (uint32_t)end / 2u;
            const uint32_t from = store->edge_from[k], to = store->edge_to[k];
            const uint32_t other = from == p ? to : from;
            const int other_marked = online->pose_column[other] >= 0 && online->mark[other];
            if (!(online->edge_weight_in[k] > 0.0) || (other_marked && other < p)) {
                continue;
            }
            const uint32_t ends[2] = {from, to};
            double *points[2] = {moved_from, moved_to};
            for (int s = 0; s < 2; s++) {
                const int j = online->pose_column[ends[s]];
                if (j >= 0 && online->mark[ends[s]]) {
                    const double *d = online->delta + (size_t)j * (size_t)b;
                    if (b == 6) {
                        pgem_se3_boxplus(pgem_update_lin(parts, ends[s]), d, points[s]);
                    } else {
                        pgem_se2_boxplus(pgem_update_lin(parts, ends[s]), d, points[s]);
                    }
                } else {
                    memcpy(points[s], pgem_update_lin(parts, ends[s]), size * sizeof(double));
                }
            }
            const double w = online->edge_weight_in[k];
            int status = pgem_update_edge(parts, k, moved_from, moved_to, w, 1.0);
            if (status == PGEM_OK) {
                status = pgem_update_edge(parts, k, pgem_update_lin(parts, from),
                                          pgem_update_lin(parts, to), w, -1.0);
            }
            if (status != PGEM_OK) {
                return status;
            }
        }
    }
    return PGEM_OK;
}

/* The linearisation points of the `count` poses due move by their steps. */
static void pgem_update_move(const pgem_online_parts_t *parts, int count)
{
    pgem_online_t *online = parts->online;
    const int b = online->block;
    for (int m = 0; m < count; m++) {
        const uint32_t p = (uint32_t)online->head[m];
        const double *d = online->delta + (size_t)online->pose_column[p] * (size_t)b;
        double *point = online->lin + (size_t)p * (size_t)parts->pose_size;
        if (b == 6) {
            pgem_se3_boxplus(point, d, point);
        } else {
            pgem_se2_boxplus(point, d, point);
        }
    }
    online->last.relinearized = (uint32_t)count;
}

/* Relinearises the poses due, by rank updates or, when those would cost more (or more poses
 * are due than `limit`, if not 0), by refactoring in place the columns they change. The two
 * estimates are in the same unit (blocks updated, x b^3 flops) but a rank update's flop is
 * slower than a refactor's (vector against block kernels): measured on M3500 and City10000,
 * 2 cost units of rank update take the time of 1 of refactoring. Returns the poses moved in
 * online->head (count in *moved). */
static int pgem_update_relinearise_due(const pgem_online_parts_t *parts, double threshold,
                                       int limit, int *moved)
{
    pgem_online_t *online = parts->online;
    const int count = pgem_update_due(parts, threshold);
    *moved = count;
    if (count == 0) {
        return PGEM_OK;
    }
    double refactor = 0.0;
    const int touched = pgem_online_affected(parts, online->head, count, &refactor);
    const int many = limit > 0 && count > limit;
    if (many || 2.0 * pgem_update_cost(parts, count, 0.5 * refactor) > refactor) {
        pgem_update_move(parts, count);
        return pgem_online_refactor(parts, touched);
    }
    pgem_online_unaffected(parts, touched);
    const int status = pgem_update_relinearise(parts, count);
    if (status == PGEM_OK) {
        pgem_update_move(parts, count);
    }
    return status;
}

/* Loop k's innovation distance under the online factor and the current estimate (the
 * factor's solution: no step), by the robust layer's test, as EM's consistency test measures
 * it (the loop in no factor; the allowance graded with the map's variance, none at the
 * default inflation 1: then e^T (Omega^-1 + J H^-1 J^T)^-1 e); *plain gets e^T Omega e, its
 * chi2 with the map taken as certain. The marginal of the loop's whitened Jacobian is a
 * forward solve along the two poses' paths. */
static double pgem_update_innovation(const pgem_online_parts_t *parts, uint32_t k,
                                     double inflation, double *plain)
{
    const pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    const int n = parts->tangent;
    double e[PGEM_TANGENT_SIZE_MAX], r[PGEM_TANGENT_SIZE_MAX];
    double upper[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double a_from[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double a_to[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double m[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0.0};
    pgem_loop_whiten(store, n, k, e, upper, a_from, a_to);
    pgem_online_marginal(parts, online->pose_column[store->edge_from[k]],
                         online->pose_column[store->edge_to[k]], a_from, a_to, n, m);
    pgem_small_apply(upper, 0, e, r, n);
    pgem_innovation_t innovation;
    pgem_innovation_test(n, upper, r, m, 0.0, inflation, &innovation);
    /* The map cannot tell one end's rotation from the other's within a half turn (just under
     * pi in 2D): the linearised prediction means nothing there, which is where only a gauge's
     * damping holds two parts together. The loop is not tested; it waits for a whole-graph
     * pass, which sees it beside the other loops joining the same parts. Odometry's drift stays
     * well below that (City10000: 1 to 1.9 rad on loops over 100 steps and more, which the test
     * predicts), so such loops are tested as any other. In 3D (the error's rotation part is
     * half the angle) the limit stays 0.5: at 1.5 Sphere2500's bridge stream took every loop in
     * between passes, and an update after a pass's adoption could find its factor singular
     * (docs/design/online.md). */
    if (!(innovation.rotation_sd <= (n == 3 ? 3.0 : 0.5))) {
        *plain = (double)INFINITY;
        return (double)INFINITY;
    }
    const double *o = store->edge_information + (size_t)k * (size_t)(n * n);
    *plain = 0.0; /* e^T Omega e: the loop's chi2 with the map taken as certain */
    for (int row = 0; row < n; row++) {
        for (int c = 0; c < n; c++) {
            *plain += e[row] * o[row * n + c] * e[c];
        }
    }
    return innovation.distance;
}

/* The gate on loop k: in with weight 1 if its innovation passes, else pruned. Returns 1 if
 * it went in. */
static int pgem_update_gate(const pgem_online_entry_t *entry, uint32_t k,
                            const pgem_update_settings_t *settings, int *seeded, int *seeded_count,
                            int *status)
{
    const pgem_online_parts_t *parts = &entry->factor;
    pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    const uint32_t ends[2] = {store->edge_from[k], store->edge_to[k]};
    for (int s = 0; s < 2; s++) {
        const int held = PGEM_POSE_HELD(store, ends[s]);
        if (!held && online->pose_column[ends[s]] < 0) {
            store->edge_active[k] = PGEM_EDGE_PRUNED; /* nothing predicts it yet */
            return 0;
        }
    }
    double plain = 0.0;
    const double distance = pgem_update_innovation(parts, k, settings->inflation, &plain);
    entry->robust.state->edge_distance[k] = distance;
    /* pending: a loop that passes only because the map is uncertain (its error alone is
     * `pending` gates or more) waits for the whole-graph pass rather than bend the map */
    if (!(distance <= settings->gate) || (settings->pending > 0.0 && !(plain <= settings->pending * settings->gate))) {
        store->edge_active[k] = PGEM_EDGE_PRUNED;
        return 0;
    }
    store->edge_active[k] = PGEM_EDGE_ACTIVE;
    store->edge_weight[k] = 1.0;
    *status = pgem_update_insert(parts, k, 1.0, seeded, seeded_count);
    return 1;
}

/* New edges into the factor (loops through the gate when robust), then the pruned loops of
 * the relinearised poses tested again. */
static int pgem_update_edges(const pgem_online_entry_t *entry,
                             const pgem_update_settings_t *settings, int moved)
{
    const pgem_online_parts_t *parts = &entry->factor;
    const pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    int *seeded = online->next, seeded_count = 0, status = PGEM_OK;
    for (uint32_t k = online->edges_seen; k < store->edge_count && status == PGEM_OK; k++) {
        const double w = pgem_update_weight(parts, k);
        const int gated = settings->robust && store->edge_kind[k] == PGEM_EDGE_LOOP;
        if (!gated && w > 0.0 && !(online->edge_weight_in[k] > 0.0)) {
            status = pgem_update_insert(parts, k, w, seeded, &seeded_count);
        }
    }
    if (status == PGEM_OK) {
        status = pgem_update_unseed(parts, seeded, seeded_count);
    }
    seeded_count = 0;
    for (uint32_t k = online->edges_seen; k < store->edge_count && status == PGEM_OK; k++) {
        if (settings->robust && store->edge_kind[k] == PGEM_EDGE_LOOP &&
            store->edge_active[k] != PGEM_EDGE_PRUNED && !(online->edge_weight_in[k] > 0.0)) {
            const int in = pgem_update_gate(entry, k, settings, seeded, &seeded_count, &status);
            online->last.loops_accepted += (uint32_t)in;
            online->last.loops_rejected += (uint32_t)!in;
        }
    }
    int retests = 0;
    for (int m = 0; settings->robust && m < moved && status == PGEM_OK && retests < PGEM_UPDATE_RETESTS; m++) {
        const uint32_t p = (uint32_t)online->head[m];
        for (int end = online->pose_edge[p]; end >= 0 && status == PGEM_OK && retests < PGEM_UPDATE_RETESTS;
             end = online->edge_next[end]) {
            const uint32_t k = (uint32_t)end / 2u;
            if (k < online->edges_seen && store->edge_kind[k] == PGEM_EDGE_LOOP &&
                store->edge_active[k] == PGEM_EDGE_PRUNED) {
                retests++;
                online->last.loops_readmitted +=
                    (uint32_t)pgem_update_gate(entry, k, settings, seeded, &seeded_count, &status);
            }
        }
    }
    if (status == PGEM_OK) {
        status = pgem_update_unseed(parts, seeded, seeded_count);
    }
    return status;
}

/* Orders and factorises everything at the current estimate. New loop closures are left for
 * the gate when robust. */
static int pgem_update_rebuild(const pgem_online_parts_t *parts,
                               const pgem_update_settings_t *settings)
{
    const pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    memcpy(online->lin, store->pose,
           (size_t)store->pose_count * (size_t)parts->pose_size * sizeof(double));
    for (uint32_t k = 0; k < store->edge_count; k++) {
        const int fresh = k >= online->edges_seen;
        const int gated = settings->robust && store->edge_kind[k] == PGEM_EDGE_LOOP &&
                          fresh && store->edge_active[k] != PGEM_EDGE_PRUNED;
        online->edge_weight_in[k] = gated ? 0.0 : pgem_update_weight(parts, k);
    }
    const int status = pgem_online_rebuild(parts, settings->recent);
    online->last.rebuilt = 1;
    online->updates = 0;
    return status;
}

/* The estimate: every pose whose step was recomputed at its linearisation point plus it. */
static void pgem_update_apply(const pgem_online_parts_t *parts)
{
    const pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    const size_t size = (size_t)parts->pose_size, b = (size_t)online->block;
    for (int q = 0; q < online->recomputed_count; q++) {
        const int j = online->recomputed[q];
        const size_t p = (size_t)online->column_pose[j];
        if (b == 6u) {
            pgem_se3_boxplus(online->lin + p * size, online->delta + (size_t)j * b,
                             store->pose + p * size);
        } else {
            pgem_se2_boxplus(online->lin + p * size, online->delta + (size_t)j * b,
                             store->pose + p * size);
        }
    }
}

/* The loop closures and how many of them are pruned, into online->last: counted over every
 * edge when `first` is 0 (after a rebuild, which visits every edge anyway, or a failure), else
 * carried from the last update with the edges from `first` on (those this update saw first)
 * and less the pruned loops it re-admitted (no other loop changes state in an update): O(new
 * edges). The outcome follows by the robust summary's rule. */
static void pgem_update_count_loops(const pgem_online_parts_t *parts, uint32_t first)
{
    const pgem_store_t *store = parts->store;
    pgem_update_summary_t *last = &parts->online->last;
    if (first == 0u) {
        last->loops = 0u;
        last->loops_pruned = 0u;
    } else {
        last->loops_pruned -= last->loops_readmitted;
    }
    for (uint32_t k = first; k < store->edge_count; k++) {
        if (store->edge_kind[k] == PGEM_EDGE_LOOP) {
            last->loops++;
            last->loops_pruned += store->edge_active[k] == PGEM_EDGE_PRUNED;
        }
    }
    last->outcome = pgem_loops_outcome(last->loops_pruned, last->loops);
}

static int pgem_update_run(const pgem_online_entry_t *entry, const pgem_update_settings_t *settings)
{
    const pgem_online_parts_t *parts = &entry->factor;
    const pgem_store_t *store = parts->store;
    pgem_online_t *online = parts->online;
    pgem_update_link(parts);
    const double bound = settings->growth * (double)online->packed_blocks + (double)settings->slack;
    const int rebuild = !online->ready || settings->rebuild || online->full ||
                        (double)online->live_blocks > bound;
    int moved = 0;
    const uint32_t added = store->pose_count - online->poses_seen;
    const int due = online->skipped + 1u >= settings->skip || added >= settings->skip - online->skipped_poses;
    if (rebuild || due) {
        online->skipped = 0;
        online->skipped_poses = 0;
    } else {
        online->skipped++;
        online->skipped_poses += added;
    }
    int status = rebuild ? pgem_update_rebuild(parts, settings)
                 : due   ? pgem_update_relinearise_due(parts, settings->threshold,
                                                       settings->movers, &moved)
                         : PGEM_OK;
    if (status == PGEM_OK) {
        status = pgem_update_edges(entry, settings, moved);
    }
    /* Out of room: pack and go on. Or a rank update or refactor lost positive definiteness:
     * a downdate (an edge taken out at its old point when a pose relinearises) is the one step
     * of the factor that rounding can break, most often in 3D with many loops; a factorisation
     * afresh at the current points is the same system without that history, so the update
     * goes on from it rather than failing (and a host restarting a whole-graph solve). */
    const int broken = status == PGEM_ERR_NOT_POSITIVE_DEFINITE || (status == PGEM_OK && online->full);
    if (broken && !online->last.rebuilt) {
        parts->message[0] = '\0';
        status = pgem_update_rebuild(parts, settings);
        if (status == PGEM_OK) {
            status = pgem_update_edges(entry, settings, 0);
        }
    }
    if (status != PGEM_OK) {
        online->ready = 0;
        return status;
    }
    pgem_online_back(parts, online->last.rebuilt ? -1.0 : settings->wildfire);
    for (int q = 0; q < online->recomputed_count; q++) {
        const double *d = online->delta + (size_t)online->recomputed[q] * (size_t)online->block;
        if (!isfinite(pgem_norm(d, online->block))) {
            online->ready = 0;
            return pgem_text_fail(parts->message, PGEM_ERR_NUMERIC,
                                  "the online step is not finite");
        }
    }
    pgem_update_apply(parts);
    pgem_update_count_loops(parts, online->last.rebuilt ? 0u : online->edges_seen);
    online->poses_seen = store->pose_count;
    online->edges_seen = store->edge_count;
    online->topology_after = store->topology;
    online->revision_after = store->revision;
    online->updates++;
    return PGEM_OK;
}

/* 1 if pose p is in the factor: it has a column, or an edge in the factor holds it (a held
 * pose: the edge was linearised at its value). */
static int pgem_update_in_factor(const pgem_online_parts_t *parts, uint32_t p)
{
    const pgem_online_t *online = parts->online;
    if (online->pose_column[p] >= 0) {
        return 1;
    }
    for (int end = online->pose_edge[p]; end >= 0; end = online->edge_next[end]) {
        if (online->edge_weight_in[(uint32_t)end / 2u] > 0.0) {
            return 1;
        }
    }
    return 0;
}

int pgem_online_update(const pgem_online_entry_t *entry, const pgem_update_options_t *options,
                       pgem_update_summary_t *summary)
{
    const pgem_online_parts_t *parts = &entry->factor;
    pgem_store_t *store = parts->store;
    pgem_online_sync(parts);
    pgem_online_t *online = parts->online;
    if (online->pool_blocks == 0u) {
        return pgem_text_fail(parts->message, PGEM_ERR_CONFIG,
                              "pgem_update needs config.online_fill (the incremental factor's "
                              "room)");
    }
    pgem_update_settings_t settings;
    int status = pgem_update_resolve(parts, options, &settings);
    if (status != PGEM_OK) {
        return status;
    }
    if (store->edited_low != UINT32_MAX) { /* a pose set or held outside pgem_update */
        /* rebuild when a pose at or after the lowest edited one is in the factor (conservative:
         * only some of them may have been edited); the others enter with what they hold */
        for (uint32_t p = store->edited_low; p < online->poses_linked && online->ready; p++) {
            online->ready = !pgem_update_in_factor(parts, p);
        }
        store->edited_low = UINT32_MAX;
    }
    store->revision++; /* the estimate moves: the covariance calls' factor is old */
    const uint32_t loops = online->last.loops, pruned = online->last.loops_pruned;
    memset(&online->last, 0, sizeof online->last);
    online->last.loops = loops; /* the running counts go on */
    online->last.loops_pruned = pruned;
    online->stamp++;
    if (online->stamp <= 0) { /* wrapped: restart the stamps */
        memset(online->touched, 0, (size_t)parts->config->max_poses * sizeof(int));
        online->stamp = 1;
    }
    parts->message[0] = '\0';
    status = pgem_update_run(entry, &settings);
    if (status != PGEM_OK && parts->message[0] == '\0') { /* every failure says what it was */
        pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, "the incremental update failed: ");
        pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, pgem_error_description(status));
    }
    if (status != PGEM_OK) {
        pgem_update_count_loops(parts, 0u); /* the states as the failure left them */
    }
    online->last.columns = (uint32_t)online->columns;
    online->last.factor_blocks = online->pool_used;
    if (summary != NULL) {
        *summary = online->last;
    }
    return status;
}

int pgem_online_settle(const pgem_online_entry_t *entry, const pgem_robust_options_t *robust,
                       pgem_robust_summary_t *summary)
{
    const pgem_online_parts_t *parts = &entry->factor;
    if (summary != NULL) {
        memset(summary, 0, sizeof *summary);
    }
    if (robust != NULL) { /* every loop back in: EM decides them all again (the factor, which
                             holds the old weights, rebuilds at the next update) */
        pgem_robust_reset_loops(parts->linear, parts->store);
    }
    const int status = robust != NULL ? pgem_robust_solve(&entry->robust, robust, NULL, summary)
                                      : pgem_solver_optimize(&entry->robust.solve, NULL, NULL);
    parts->online->ready = 0;
    return status;
}
