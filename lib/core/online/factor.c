/* The incremental factor's column storage: appending a column, growing a column's pattern,
 * rank-one updates and downdates along an elimination-tree path, and the triangular solves. */
#include <math.h>
#include <string.h>

#include "online/factor.h"

static double *pgem_online_block(const pgem_online_t *online, int q)
{
    const size_t bb = (size_t)online->block * (size_t)online->block;
    return online->values + (size_t)q * bb;
}

/* Moves column j to the pool's end with room for `room` off-diagonal blocks; 0 if the pool
 * has no such room. */
static int pgem_online_move(pgem_online_t *online, int j, int room)
{
    const uint32_t need = (uint32_t)room + 1u;
    if (online->pool_used > online->pool_blocks || need > online->pool_blocks - online->pool_used) {
        return 0;
    }
    const int to = (int)online->pool_used, from = online->start[j];
    const size_t bb = (size_t)online->block * (size_t)online->block;
    memmove(pgem_online_block(online, to), pgem_online_block(online, from),
            (size_t)(online->count[j] + 1) * bb * sizeof(double));
    memmove(online->rows + to, online->rows + from, (size_t)(online->count[j] + 1) * sizeof(int));
    online->start[j] = to;
    online->capacity[j] = room;
    online->pool_used += need;
    return 1;
}

/* Merges the m block rows in add (ascending, none in column j yet, all after j) into column j
 * as zero blocks. PGEM_OK or PGEM_ERR_FILL_BUDGET (online->full set). */
static int pgem_online_grow(pgem_online_t *online, int j, const int *add, int m)
{
    const int count = online->count[j];
    if (count + m > online->capacity[j]) {
        const int wanted = 2 * (count + m) > 4 ? 2 * (count + m) : 4;
        if (!pgem_online_move(online, j, wanted) && !pgem_online_move(online, j, count + m)) {
            online->full = 1;
            return PGEM_ERR_FILL_BUDGET;
        }
    }
    const size_t bb = (size_t)online->block * (size_t)online->block;
    int *rows = online->rows + online->start[j] + 1;
    int old = count - 1, extra = m - 1;
    for (int write = count + m - 1; extra >= 0; write--) {
        const int q = online->start[j] + 1 + write;
        if (old >= 0 && rows[old] > add[extra]) {
            rows[write] = rows[old];
            memcpy(pgem_online_block(online, q), pgem_online_block(online, online->start[j] + 1 + old),
                   bb * sizeof(double));
            old--;
        } else {
            rows[write] = add[extra];
            memset(pgem_online_block(online, q), 0, bb * sizeof(double));
            extra--;
        }
    }
    online->count[j] = count + m;
    online->live_blocks += (uint32_t)m;
    if (online->parent[j] != rows[0]) {
        pgem_online_set_parent(online, j, rows[0]);
    }
    return PGEM_OK;
}

/* The rows of column j after its parent that its parent lacks, into online->list; returns
 * how many. */
static int pgem_online_missing(const pgem_online_t *online, int j)
{
    const int p = online->parent[j];
    const int *mine = online->rows + online->start[j] + 2;
    const int mine_count = online->count[j] - 1;
    const int *theirs = online->rows + online->start[p] + 1;
    const int their_count = online->count[p];
    int missing = 0, t = 0;
    for (int q = 0; q < mine_count; q++) {
        while (t < their_count && theirs[t] < mine[q]) {
            t++;
        }
        if (t >= their_count || theirs[t] != mine[q]) {
            online->list[missing++] = mine[q];
        }
    }
    return missing;
}

/* Position of block row i in column j (the diagonal block for i == j), or -1. */
int pgem_online_find(const pgem_online_t *online, int j, int i)
{
    if (i == j) {
        return online->start[j];
    }
    const int *rows = online->rows + online->start[j] + 1;
    int low = 0, high = online->count[j] - 1;
    while (low <= high) {
        const int mid = (low + high) / 2;
        if (rows[mid] == i) {
            return online->start[j] + 1 + mid;
        }
        if (rows[mid] < i) {
            low = mid + 1;
        } else {
            high = mid - 1;
        }
    }
    return -1;
}

/* One rotation of a column's update: cosine, sine, sign x sine, 1 / cosine. */
typedef struct pgem_online_rotation {
    double cosine;
    double sine;
    double up;
    double inverse;
} pgem_online_rotation_t;

/* The rotation applied to column c of an off-diagonal block (b rows) and the vector's rows
 * (every rank-th entry of w); inlined with b a constant below, so the compiler unrolls it. */
static inline void pgem_online_rotate_block(double *block, double *w, size_t rank,
                                            const pgem_online_rotation_t *g, int b)
{
    for (int r = 0; r < b; r++) {
        double *wr = w + (size_t)r * rank;
        const double value = (block[r] + g->up * *wr) * g->inverse;
        *wr = g->cosine * *wr - g->sine * value;
        block[r] = value;
    }
}

/* The same, dispatched on the block size: 3 (2D) and 6 (3D) as constants, the same operations
 * in the same order, so the factor is bit for bit the generic loop's. */
static void pgem_online_rotate_rows(double *block, double *w, size_t rank,
                                    const pgem_online_rotation_t *g, int b)
{
    if (b == 3) {
        pgem_online_rotate_block(block, w, rank, g, 3);
    } else if (b == 6) {
        pgem_online_rotate_block(block, w, rank, g, 6);
    } else {
        pgem_online_rotate_block(block, w, rank, g, b);
    }
}

/* The rotations of column j with the `rank` vectors (online->vector, interleaved: entry
 * (scalar s, vector k) at s rank + k): for each scalar column, vector after vector, which is
 * the same as one full rank-one update after the other. */
static int pgem_online_rotate(pgem_online_t *online, int j, double sign, int rank)
{
    const int b = online->block, count = online->count[j];
    const size_t stride = (size_t)b * (size_t)rank;
    double *diagonal = pgem_online_block(online, online->start[j]);
    double *x = online->vector + (size_t)j * stride;
    double *y = online->forward + (size_t)j * (size_t)b;
    if (sign < 0.0 && pgem_fault_downdate()) {
        return PGEM_ERR_NOT_POSITIVE_DEFINITE; /* a test's broken downdate (common/common.h) */
    }
    for (int c = 0; c < b; c++) {
        for (int k = 0; k < rank; k++) {
            const double xc = x[c * rank + k];
            if (xc == 0.0) {
                continue;
            }
            const double pivot = diagonal[c * b + c];
            const double squared = pivot * pivot + sign * xc * xc;
            if (!(squared > 0.0) || !isfinite(squared)) {
                return PGEM_ERR_NOT_POSITIVE_DEFINITE;
            }
            const double root = sqrt(squared);
            const double cosine = root / pivot, sine = xc / pivot, up = sign * sine;
            const double inverse = 1.0 / cosine;
            diagonal[c * b + c] = root;
            const double rhs = (y[c] + up * online->beta[k]) * inverse;
            online->beta[k] = cosine * online->beta[k] - sine * rhs;
            y[c] = rhs;
            for (int r = c + 1; r < b; r++) {
                const double value = (diagonal[c * b + r] + up * x[r * rank + k]) * inverse;
                x[r * rank + k] = cosine * x[r * rank + k] - sine * value;
                diagonal[c * b + r] = value;
            }
            const pgem_online_rotation_t g = {cosine, sine, up, inverse};
            for (int q = 1; q <= count; q++) {
                pgem_online_rotate_rows(pgem_online_block(online, online->start[j] + q) + (size_t)c * (size_t)b,
                                        online->vector + (size_t)online->rows[online->start[j] + q] * stride + k,
                                        (size_t)rank, &g, b);
            }
            x[c * rank + k] = 0.0;
        }
    }
    return PGEM_OK;
}

/* Zeroes the vectors from column j up to the root (after a failure part way). */
static void pgem_online_clear_path(pgem_online_t *online, int j, int rank)
{
    const size_t stride = (size_t)online->block * (size_t)rank;
    for (; j >= 0; j = online->parent[j]) {
        memset(online->vector + (size_t)j * stride, 0, stride * sizeof(double));
        for (int q = 1; q <= online->count[j]; q++) {
            memset(online->vector + (size_t)online->rows[online->start[j] + q] * stride, 0,
                   stride * sizeof(double));
        }
    }
}

/* The message of an update that found the incremental factor's room used up: what ran out,
 * how much there is and what to raise. Returns PGEM_ERR_FILL_BUDGET. */
static int pgem_online_out_of_room(const pgem_online_parts_t *parts, const char *what)
{
    const pgem_online_t *online = parts->online;
    parts->message[0] = '\0';
    pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, "the incremental factor is out of room (");
    pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, what);
    pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, "): its ");
    pgem_text_u64(parts->message, PGEM_MESSAGE_SIZE, online->pool_blocks);
    pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, " blocks of ");
    pgem_text_u64(parts->message, PGEM_MESSAGE_SIZE,
                  (uint64_t)online->block * (uint64_t)online->block);
    pgem_text_append(parts->message, PGEM_MESSAGE_SIZE,
                     " nonzeros are used up, config.online_fill is ");
    pgem_text_u64(parts->message, PGEM_MESSAGE_SIZE, parts->config->online_fill);
    pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, " nonzeros: raise config.online_fill");
    return PGEM_ERR_FILL_BUDGET;
}

int pgem_online_rank_update(const pgem_online_parts_t *parts, const int *columns, int column_count,
                            double sign, int rank)
{
    pgem_online_t *online = parts->online;
    int j = columns[0];
    int changed = 0, status = PGEM_OK;
    for (int k = 1; k < column_count && status == PGEM_OK; k++) {
        if (pgem_online_find(online, j, columns[k]) < 0) {
            status = pgem_online_grow(online, j, columns + k, 1);
            changed = 1;
        }
    }
    while (status == PGEM_OK && j >= 0) {
        status = pgem_online_rotate(online, j, sign, rank);
        if (online->touched[j] != online->stamp) {
            online->touched[j] = online->stamp;
            online->last.columns_touched++;
        }
        const int p = online->parent[j];
        if (status == PGEM_OK && changed && p >= 0) {
            const int missing = pgem_online_missing(online, j);
            changed = missing > 0;
            if (changed) {
                status = pgem_online_grow(online, p, online->list, missing);
            }
        }
        if (status == PGEM_OK) {
            j = p;
        }
    }
    online->last.rank_updates += (uint32_t)rank;
    if (status != PGEM_OK) {
        pgem_online_clear_path(online, j, rank);
    }
    if (status == PGEM_ERR_FILL_BUDGET) {
        return pgem_online_out_of_room(parts, "a column grew");
    }
    if (status == PGEM_ERR_NOT_POSITIVE_DEFINITE) {
        parts->message[0] = '\0';
        pgem_text_append(parts->message, PGEM_MESSAGE_SIZE,
                         sign < 0.0 ? "removing an edge from" : "adding an edge to");
        pgem_text_append(parts->message, PGEM_MESSAGE_SIZE,
                         " the incremental factor lost positive definiteness at pose "
                         "index ");
        pgem_text_u64(parts->message, PGEM_MESSAGE_SIZE, (uint64_t)online->column_pose[j]);
        pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, " (the next update rebuilds it)");
    }
    return status;
}

int pgem_online_append(const pgem_online_parts_t *parts, uint32_t p, double seed)
{
    pgem_online_t *online = parts->online;
    const int b = online->block, j = online->columns;
    const int room = 4;
    if (online->pool_used > online->pool_blocks ||
        (uint32_t)room + 1u > online->pool_blocks - online->pool_used) {
        online->full = 1;
        return pgem_online_out_of_room(parts, "a new pose's column");
    }
    online->start[j] = (int)online->pool_used;
    online->pool_used += (uint32_t)room + 1u;
    online->count[j] = 0;
    online->live_blocks += 1u;
    online->capacity[j] = room;
    online->parent[j] = -2; /* not linked yet */
    online->child[j] = -1;
    pgem_online_set_parent(online, j, -1);
    online->rows[online->start[j]] = j;
    double *diagonal = pgem_online_block(online, online->start[j]);
    memset(diagonal, 0, (size_t)b * (size_t)b * sizeof(double));
    for (int c = 0; c < b; c++) {
        diagonal[c * b + c] = sqrt(seed);
    }
    memset(online->delta + (size_t)j * (size_t)b, 0, (size_t)b * sizeof(double));
    memset(online->forward + (size_t)j * (size_t)b, 0, (size_t)b * sizeof(double));
    online->changed[j] = 0;
    online->pose_column[p] = j;
    online->column_pose[j] = (int)p;
    online->columns++;
    return PGEM_OK;
}

/* Recomputes column j's step; returns its largest change. */
static double pgem_online_back_column(pgem_online_t *online, int j)
{
    const int b = online->block;
    double x[PGEM_TANGENT_SIZE_MAX];
    memcpy(x, online->forward + (size_t)j * (size_t)b, (size_t)b * sizeof(double));
    for (int q = 1; q <= online->count[j]; q++) {
        const double *block = pgem_online_block(online, online->start[j] + q);
        const double *source = online->delta + (size_t)online->rows[online->start[j] + q] * (size_t)b;
        for (int c = 0; c < b; c++) {
            double sum = 0.0;
            for (int r = 0; r < b; r++) {
                sum += block[c * b + r] * source[r];
            }
            x[c] -= sum;
        }
    }
    pgem_small_upper_solve(pgem_online_block(online, online->start[j]), x, b); /* D^-T x */
    double largest = 0.0;
    double *d = online->delta + (size_t)j * (size_t)b;
    for (int c = 0; c < b; c++) {
        const double change = fabs(x[c] - d[c]);
        largest = change > largest ? change : largest;
        d[c] = x[c];
    }
    return largest;
}

/* 1 if column j must be recomputed: touched by this update, or a row's step changed. */
static int pgem_online_stale(const pgem_online_t *online, int j)
{
    if (online->touched[j] == online->stamp) {
        return 1;
    }
    for (int q = 1; q <= online->count[j]; q++) {
        if (online->changed[online->rows[online->start[j] + q]]) {
            return 1;
        }
    }
    return 0;
}

void pgem_online_back(const pgem_online_parts_t *parts, double tolerance)
{
    pgem_online_t *online = parts->online;
    int *stack = online->list, top = 0;
    online->recomputed_count = 0;
    for (int r = online->root; r >= 0; r = online->sibling[r]) {
        stack[top++] = r;
    }
    /* a column is pushed only after its parent was recomputed (its children are on the stack
     * above it only when it was), so each column is visited at most once */
    while (top > 0) {
        const int j = stack[--top];
        if (tolerance >= 0.0 && !pgem_online_stale(online, j)) {
            online->changed[j] = 0;
            continue;
        }
        const double change = pgem_online_back_column(online, j);
        online->changed[j] = tolerance < 0.0 || change > tolerance;
        online->recomputed[online->recomputed_count++] = j;
        for (int c = online->child[j]; c >= 0; c = online->sibling[c]) {
            stack[top++] = c;
        }
    }
    for (int k = 0; k < online->recomputed_count; k++) {
        online->changed[online->recomputed[k]] = 0;
    }
}

void pgem_online_set_parent(pgem_online_t *online, int j, int p)
{
    const int old = online->parent[j];
    if (old != -2) { /* unlink */
        if (online->previous[j] >= 0) {
            online->sibling[online->previous[j]] = online->sibling[j];
        } else if (old >= 0) {
            online->child[old] = online->sibling[j];
        } else {
            online->root = online->sibling[j];
        }
        if (online->sibling[j] >= 0) {
            online->previous[online->sibling[j]] = online->previous[j];
        }
    }
    int *head = p >= 0 ? &online->child[p] : &online->root;
    online->previous[j] = -1;
    online->sibling[j] = *head;
    if (*head >= 0) {
        online->previous[*head] = j;
    }
    *head = j;
    online->parent[j] = p;
}

void pgem_online_link_tree(pgem_online_t *online)
{
    online->root = -1;
    for (int j = 0; j < online->columns; j++) {
        online->child[j] = -1;
        online->changed[j] = 0;
    }
    for (int j = online->columns - 1; j >= 0; j--) {
        const int p = online->parent[j];
        online->parent[j] = -2;
        pgem_online_set_parent(online, j, p);
    }
}

/* The forward solve of n right-hand sides (online->vector holds them interleaved: entry
 * (scalar s, side k) at s n + k) on column j, accumulating Y_j^T Y_j into out. */
static void pgem_online_forward_column(pgem_online_t *online, int j, int n, double *out)
{
    const int b = online->block;
    const double *diagonal = pgem_online_block(online, online->start[j]);
    double *x = online->vector + (size_t)j * (size_t)b * (size_t)n;
    for (int k = 0; k < n; k++) {
        for (int c = 0; c < b; c++) {
            double value = x[c * n + k] / diagonal[c * b + c];
            x[c * n + k] = value;
            for (int r = c + 1; r < b; r++) {
                x[r * n + k] -= diagonal[c * b + r] * value;
            }
        }
    }
    for (int q = 1; q <= online->count[j]; q++) {
        const double *block = pgem_online_block(online, online->start[j] + q);
        double *target = online->vector +
                         (size_t)online->rows[online->start[j] + q] * (size_t)b * (size_t)n;
        for (int c = 0; c < b; c++) {
            for (int r = 0; r < b; r++) {
                const double l = block[c * b + r];
                for (int k = 0; k < n; k++) {
                    target[r * n + k] -= l * x[c * n + k];
                }
            }
        }
    }
    for (int k = 0; k < n; k++) {
        for (int m = 0; m < n; m++) {
            double sum = 0.0;
            for (int c = 0; c < b; c++) {
                sum += x[c * n + k] * x[c * n + m];
            }
            out[k * n + m] += sum;
        }
    }
    memset(x, 0, (size_t)b * (size_t)n * sizeof(double));
}

void pgem_online_marginal(const pgem_online_parts_t *parts, int ca, int cb, const double *a_a,
                          const double *a_b, int n, double *out)
{
    pgem_online_t *online = parts->online;
    const int b = online->block;
    memset(out, 0, (size_t)n * (size_t)n * sizeof(double));
    const int ends[2] = {ca, cb};
    const double *sides[2] = {a_a, a_b};
    for (int side = 0; side < 2; side++) {
        if (ends[side] < 0) {
            continue;
        }
        double *x = online->vector + (size_t)ends[side] * (size_t)b * (size_t)n;
        for (int c = 0; c < b; c++) {
            for (int k = 0; k < n; k++) {
                x[c * n + k] += sides[side][k * b + c];
            }
        }
    }
    /* the union of the two paths, in ascending order */
    int x = ca, y = cb;
    while (x >= 0 || y >= 0) {
        int j;
        if (x >= 0 && (y < 0 || x < y)) {
            j = x;
            x = online->parent[x];
        } else if (y >= 0 && (x < 0 || y < x)) {
            j = y;
            y = online->parent[y];
        } else {
            j = x;
            x = online->parent[x];
            y = online->parent[y];
        }
        pgem_online_forward_column(online, j, n, out);
    }
}

int pgem_online_covariance(const pgem_online_parts_t *parts, uint32_t p, double *out)
{
    pgem_online_t *online = parts->online;
    const int b = online->block;
    if (p >= online->poses_linked || online->pose_column[p] < 0) {
        return 0;
    }
    double identity[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0.0};
    for (int k = 0; k < b; k++) {
        identity[k * b + k] = 1.0;
    }
    pgem_online_marginal(parts, online->pose_column[p], -1, identity, identity, b, out);
    return 1;
}

pgem_online_t *pgem_online_carve_state(pgem_arena_t *arena)
{
    pgem_online_t *state = pgem_arena_take_struct(arena, sizeof(pgem_online_t));
    if (state != NULL) {
        memset(state, 0, sizeof *state);
    }
    return state;
}

void pgem_online_carve(pgem_online_t *state, const pgem_config_t *config, int tangent,
                       pgem_arena_t *arena)
{
    pgem_online_t probe; /* what a measuring pass (or a failed carve) fills instead */
    memset(&probe, 0, sizeof probe);
    pgem_online_t *online = state != NULL ? state : &probe;
    const size_t poses = config->max_poses, edges = config->max_edges;
    const size_t b = (size_t)tangent;
    online->block = (int)b;
    online->pool_blocks = config->online_fill / (uint32_t)(b * b);
    if (online->pool_blocks == 0u) {
        return;
    }
    int **ints[] = {&online->pose_column, &online->column_pose, &online->parent, &online->start,
                    &online->count, &online->capacity, &online->pose_edge, &online->mark,
                    &online->list, &online->head, &online->next, &online->position,
                    &online->touched, &online->child, &online->sibling, &online->previous,
                    &online->changed, &online->recomputed};
    for (size_t k = 0; k < sizeof ints / sizeof ints[0]; k++) {
        *ints[k] = pgem_arena_take(arena, poses, sizeof(int));
    }
    online->adjacent_start = pgem_arena_take(arena, poses + 1u, sizeof(int));
    online->adjacent = pgem_arena_take(arena, 2u * edges, sizeof(int));
    online->edge_next = pgem_arena_take(arena, 2u * edges, sizeof(int));
    online->edge_weight_in = pgem_arena_take(arena, edges, sizeof(double));
    online->rows = pgem_arena_take(arena, online->pool_blocks, sizeof(int));
    online->values = pgem_arena_take(arena, (size_t)online->pool_blocks * b * b, sizeof(double));
    online->lin = pgem_arena_take(arena, poses * pgem_pose_doubles(tangent), sizeof(double));
    online->delta = pgem_arena_take(arena, poses * b, sizeof(double));
    online->forward = pgem_arena_take(arena, poses * b, sizeof(double));
    online->vector = pgem_arena_take(arena, poses * b * b, sizeof(double));
    if (online->vector != NULL && online->touched != NULL) { /* both start clean */
        memset(online->vector, 0, poses * b * b * sizeof(double));
        memset(online->touched, 0, poses * sizeof(int));
    }
}
