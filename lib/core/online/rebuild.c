/* The incremental factor from scratch: CSparse's AMD on the system's block graph with the
 * newest poses put last, the column patterns from the elimination tree, and a left-looking
 * block factorisation into the packed pool; and an edge's square-root linearisation. */
#include <math.h>
#include <string.h>

#include "online/factor.h"

void pgem_online_edge(const pgem_store_t *store, int tangent, uint32_t k, const double *from,
                      const double *to, double weight, double *a_from, double *a_to,
                      double *residual)
{
    const int n = tangent;
    double e[PGEM_TANGENT_SIZE_MAX], jf[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double jt[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double u[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    const double *measurement = store->edge_measurement + (size_t)k * pgem_pose_doubles(n);
    if (n == 6) {
        pgem_se3_error(from, to, measurement, e, jf, jt);
    } else {
        pgem_se2_error(from, to, measurement, e, jf, jt);
    }
    /* Omega = U^T U: Omega's Cholesky factor stored by column is U stored by row (Omega was
     * checked positive definite when the edge was added); rows of sqrt(w) U J, sqrt(w) U e */
    const double *o = store->edge_information + (size_t)k * (size_t)(n * n);
    memcpy(u, o, (size_t)(n * n) * sizeof(double));
    (void)pgem_small_cholesky(u, n, 0.0, 1);
    const double root = sqrt(weight);
    for (int r = 0; r < n; r++) {
        double er = 0.0;
        for (int c = 0; c < n; c++) {
            double f = 0.0, t = 0.0;
            for (int m = r; m < n; m++) {
                f += u[r * n + m] * jf[m * n + c];
                t += u[r * n + m] * jt[m * n + c];
            }
            a_from[r * n + c] = root * f;
            a_to[r * n + c] = root * t;
        }
        for (int m = r; m < n; m++) {
            er += u[r * n + m] * e[m];
        }
        residual[r] = root * er;
    }
}

/* Shell sort of a few hundred ints at most, ascending. */
static void pgem_online_sort(int *values, int count)
{
    static const int gaps[] = {701, 301, 132, 57, 23, 10, 4, 1};
    for (size_t g = 0; g < sizeof gaps / sizeof gaps[0]; g++) {
        const int gap = gaps[g];
        for (int i = gap; i < count; i++) {
            const int value = values[i];
            int k = i;
            for (; k >= gap && values[k - gap] > value; k -= gap) {
                values[k] = values[k - gap];
            }
            values[k] = value;
        }
    }
}

/* 1 if pose p is solved for: free (held poses and, with none held, the first pose are not). */
static int pgem_online_free(const pgem_online_parts_t *parts, uint32_t p)
{
    return !PGEM_POSE_HELD(parts->store, p);
}

/* The other pose of edge end `end` (2 k + side). */
static uint32_t pgem_online_other(const pgem_online_parts_t *parts, int end)
{
    const uint32_t k = (uint32_t)end / 2u;
    return (end & 1) ? parts->store->edge_from[k] : parts->store->edge_to[k];
}

/* Columns numbered by arrival for every free pose with an edge in the system; returns how
 * many. */
static int pgem_online_number(const pgem_online_parts_t *parts)
{
    pgem_online_t *online = parts->online;
    int columns = 0;
    for (uint32_t p = 0; p < parts->store->pose_count; p++) {
        online->pose_column[p] = -1;
        if (!pgem_online_free(parts, p)) {
            continue;
        }
        for (int end = online->pose_edge[p]; end >= 0; end = online->edge_next[end]) {
            if (online->edge_weight_in[end / 2] > 0.0) {
                online->pose_column[p] = columns++;
                break;
            }
        }
    }
    return columns;
}

/* AMD's order of the columns (online->list: k-th column's arrival number), the newest
 * `recent` of them moved last in arrival order. */
static int pgem_online_order(const pgem_online_parts_t *parts, int columns, int recent)
{
    pgem_online_t *online = parts->online;
    int *colptr = online->adjacent_start, *rows = online->adjacent;
    for (int j = 0; j <= columns; j++) {
        colptr[j] = 0;
    }
    for (uint32_t p = 0; p < parts->store->pose_count; p++) {
        const int j = online->pose_column[p];
        for (int end = j >= 0 ? online->pose_edge[p] : -1; end >= 0; end = online->edge_next[end]) {
            const int i = online->pose_column[pgem_online_other(parts, end)];
            if (i > j && online->edge_weight_in[end / 2] > 0.0) {
                colptr[j + 1]++; /* counted first, placed below; one triangle (AMD adds A^T) */
            }
        }
    }
    /* the counts sit at colptr[j + 1]; turn them into starts and place the rows */
    for (int j = 0; j < columns; j++) {
        colptr[j + 1] += colptr[j];
    }
    for (int j = columns; j > 0; j--) {
        colptr[j] = colptr[j - 1];
    }
    colptr[0] = 0;
    for (uint32_t p = 0; p < parts->store->pose_count; p++) {
        const int j = online->pose_column[p];
        for (int end = j >= 0 ? online->pose_edge[p] : -1; end >= 0; end = online->edge_next[end]) {
            const int i = online->pose_column[pgem_online_other(parts, end)];
            if (i > j && online->edge_weight_in[end / 2] > 0.0) {
                rows[colptr[j + 1]++] = i;
            }
        }
    }
    int *order = online->mark; /* free until the columns are mapped back to their poses */
    if (pgem_linear_amd(parts->linear, columns, colptr, rows, order) != PGEM_OK) {
        return pgem_text_fail(parts->message, PGEM_ERR_OUT_OF_MEMORY,
                              "the online factor's ordering (CSparse's AMD) could not get "
                              "workspace");
    }
    const int first_recent = columns - recent;
    int k = 0;
    for (int q = 0; q < columns; q++) {
        if (order[q] < first_recent) {
            online->list[k++] = order[q];
        }
    }
    for (int j = first_recent > 0 ? first_recent : 0; j < columns; j++) {
        online->list[k++] = j;
    }
    return PGEM_OK;
}

/* Every column's pattern from its edges and its children's patterns, packed into the pool
 * with some room to grow; PGEM_ERR_FILL_BUDGET with the blocks needed if it does not fit. */
static int pgem_online_symbolic(const pgem_online_parts_t *parts, int columns)
{
    pgem_online_t *online = parts->online;
    int *children = online->head, *sibling = online->next, *gather = online->position;
    uint64_t used = 0, live = 0;
    int short_of_room = 0; /* a column did not fit (used may still be within the pool: the
                              columns after it were counted without their room) */
    for (int j = 0; j < columns; j++) {
        children[j] = -1;
        online->mark[j] = -1;
    }
    for (int j = 0; j < columns; j++) {
        const uint32_t p = (uint32_t)online->column_pose[j];
        int count = 0;
        online->mark[j] = j;
        for (int end = online->pose_edge[p]; end >= 0; end = online->edge_next[end]) {
            const int i = online->pose_column[pgem_online_other(parts, end)];
            if (i > j && online->edge_weight_in[end / 2] > 0.0 && online->mark[i] != j) {
                online->mark[i] = j;
                gather[count++] = i;
            }
        }
        for (int c = children[j]; c >= 0; c = sibling[c]) {
            for (int q = 2; q <= online->count[c]; q++) { /* rows after the parent j */
                const int i = online->rows[online->start[c] + q];
                if (online->mark[i] != j) {
                    online->mark[i] = j;
                    gather[count++] = i;
                }
            }
        }
        pgem_online_sort(gather, count);
        const int room = count + count / 4 + 2;
        if (used + (uint64_t)room + 1u > online->pool_blocks) {
            used += (uint64_t)count + 1u; /* count on without room, for the message */
            short_of_room = 1;
            online->count[j] = 0;
            online->start[j] = 0;
            online->parent[j] = -1;
            continue;
        }
        online->start[j] = (int)used;
        online->count[j] = count;
        online->capacity[j] = room;
        live += (uint64_t)count + 1u;
        online->rows[used] = j;
        memcpy(online->rows + used + 1u, gather, (size_t)count * sizeof(int));
        used += (uint64_t)room + 1u;
        online->parent[j] = count > 0 ? gather[0] : -1;
        if (count > 0) {
            sibling[j] = children[gather[0]];
            children[gather[0]] = j;
        }
    }
    if (short_of_room) {
        parts->message[0] = '\0';
        pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, "the online factor needs at least ");
        pgem_text_u64(parts->message, PGEM_MESSAGE_SIZE,
                      used * (uint64_t)online->block * (uint64_t)online->block);
        pgem_text_append(parts->message, PGEM_MESSAGE_SIZE,
                         " nonzeros with its room to grow, config.online_fill is ");
        pgem_text_u64(parts->message, PGEM_MESSAGE_SIZE, parts->config->online_fill);
        pgem_text_append(parts->message, PGEM_MESSAGE_SIZE, ": raise config.online_fill");
        return PGEM_ERR_FILL_BUDGET;
    }
    online->pool_used = (uint32_t)used;
    online->live_blocks = (uint32_t)live;
    return PGEM_OK;
}

/* 1 if column j is refactored: every column (partial 0), else those this update touched. */
static int pgem_online_in(const pgem_online_t *online, int j, int partial)
{
    return j >= 0 && (!partial || online->touched[j] == online->stamp);
}

/* Adds edge k at lin to the columns being refactored: H's blocks into their pool blocks, the
 * gradient, negated, into forward. */
static void pgem_online_add_edge(const pgem_online_parts_t *parts, uint32_t k, int partial)
{
    pgem_online_t *online = parts->online;
    const int b = online->block;
    const size_t bb = (size_t)b * (size_t)b, size = (size_t)parts->pose_size;
    const double w = online->edge_weight_in[k];
    const int ends[2] = {online->pose_column[parts->store->edge_from[k]],
                         online->pose_column[parts->store->edge_to[k]]};
    if (!(w > 0.0) || (!pgem_online_in(online, ends[0], partial) &&
                       !pgem_online_in(online, ends[1], partial))) {
        return;
    }
    double a[2][PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {{0.0}};
    double r[PGEM_TANGENT_SIZE_MAX] = {0.0};
    pgem_online_edge(parts->store, parts->tangent, k,
                     online->lin + parts->store->edge_from[k] * size,
                     online->lin + parts->store->edge_to[k] * size, w, a[0], a[1], r);
    for (int s = 0; s < 2; s++) {
        if (!pgem_online_in(online, ends[s], partial)) {
            continue; /* the blocks of column ends[s] */
        }
        for (int t = 0; t < 2; t++) {
            if (ends[t] < ends[s]) {
                continue;
            }
            /* block (row ends[t], column ends[s]) += A_t^T A_s */
            const int q = ends[s] == ends[t] ? online->start[ends[s]]
                                             : pgem_online_find(online, ends[s], ends[t]);
            double *block = online->values + (size_t)q * bb;
            for (int c = 0; c < b; c++) {
                for (int row = (s == t ? c : 0); row < b; row++) {
                    double sum = 0.0;
                    for (int m = 0; m < b; m++) {
                        sum += a[t][m * b + row] * a[s][m * b + c];
                    }
                    block[c * b + row] += sum;
                }
            }
        }
        double *g = online->forward + (size_t)ends[s] * (size_t)b;
        for (int c = 0; c < b; c++) {
            for (int m = 0; m < b; m++) {
                g[c] -= a[s][m * b + c] * r[m];
            }
        }
    }
}

/* Column j's gauge damping (pgem_hold_gauge) onto its diagonal block. */
static void pgem_online_damp(const pgem_online_parts_t *parts, int j)
{
    pgem_online_t *online = parts->online;
    const int b = online->block;
    if (!PGEM_POSE_DAMPED(parts->store->pose_fixed[online->column_pose[j]])) {
        return;
    }
    double *diagonal = online->values + (size_t)online->start[j] * (size_t)b * (size_t)b;
    for (int c = 0; c < b; c++) {
        diagonal[c * b + c] += PGEM_GAUGE_DAMPING;
    }
}

/* Every edge of the system into the zeroed factor, and the gauges' damping. */
static void pgem_online_assemble(const pgem_online_parts_t *parts, int columns)
{
    pgem_online_t *online = parts->online;
    const size_t bb = (size_t)online->block * (size_t)online->block;
    memset(online->values, 0, (size_t)online->pool_used * bb * sizeof(double));
    memset(online->forward, 0, (size_t)columns * (size_t)online->block * sizeof(double));
    for (uint32_t k = 0; k < parts->store->edge_count; k++) {
        pgem_online_add_edge(parts, k, 0);
    }
    for (int j = 0; j < columns; j++) {
        pgem_online_damp(parts, j);
    }
}

/* The edges of the touched columns (the `count` listed) into those columns, zeroed first;
 * an edge with both ends touched is added once, from its lower column. */
static void pgem_online_assemble_touched(const pgem_online_parts_t *parts, const int *touched,
                                         int count)
{
    pgem_online_t *online = parts->online;
    const int b = online->block;
    const size_t bb = (size_t)b * (size_t)b;
    for (int t = 0; t < count; t++) {
        const int j = touched[t];
        memset(online->values + (size_t)online->start[j] * bb, 0,
               (size_t)(online->count[j] + 1) * bb * sizeof(double));
        memset(online->forward + (size_t)j * (size_t)b, 0, (size_t)b * sizeof(double));
        pgem_online_damp(parts, j);
    }
    for (int t = 0; t < count; t++) {
        const int j = touched[t];
        for (int end = online->pose_edge[online->column_pose[j]]; end >= 0;
             end = online->edge_next[end]) {
            const int other = online->pose_column[pgem_online_other(parts, end)];
            if (!pgem_online_in(online, other, 1) || j < other) {
                pgem_online_add_edge(parts, (uint32_t)end / 2u, 1);
            }
        }
    }
}

/* target -= L_id L_jd^T for b x b blocks (column-major), the lower triangle only on the
 * diagonal block; inlined with b a constant below, so the compiler unrolls it. */
static inline void pgem_online_subtract_block(double *target, const double *lid,
                                              const double *ljd, int b, int diagonal)
{
    for (int c = 0; c < b; c++) {
        for (int r = (diagonal ? c : 0); r < b; r++) {
            double sum = 0.0;
            for (int m = 0; m < b; m++) {
                sum += lid[m * b + r] * ljd[m * b + c];
            }
            target[c * b + r] -= sum;
        }
    }
}

/* The same, dispatched on the block size: 3 (2D) and 6 (3D) as constants, the same operations
 * in the same order, so the factor is bit for bit the generic loop's. */
static void pgem_online_subtract(double *target, const double *lid, const double *ljd, int b,
                                 int diagonal)
{
    if (b == 3) {
        pgem_online_subtract_block(target, lid, ljd, 3, diagonal);
    } else if (b == 6) {
        pgem_online_subtract_block(target, lid, ljd, 6, diagonal);
    } else {
        pgem_online_subtract_block(target, lid, ljd, b, diagonal);
    }
}

/* forward's rows of column j's blocks from block q on -= L(rows, j) forward_j. */
static void pgem_online_propagate(pgem_online_t *online, int j, int q)
{
    const int b = online->block;
    const size_t bb = (size_t)b * (size_t)b;
    const double *x = online->forward + (size_t)j * (size_t)b;
    for (const int end = online->start[j] + online->count[j]; q <= end; q++) {
        const double *block = online->values + (size_t)q * bb;
        double *target = online->forward + (size_t)online->rows[q] * (size_t)b;
        for (int c = 0; c < b; c++) {
            for (int r = 0; r < b; r++) {
                target[r] -= block[c * b + r] * x[c];
            }
        }
    }
}

/* Left-looking block factorisation of the assembled columns (partial: only the touched
 * ones, from the present values of the others), with the forward solve L y = forward over
 * the same columns. Column d waits in the list of the next row it updates (head, next,
 * position); the rows of an untouched column that are touched are the last ones (they are
 * its ancestors, and the touched columns are closed towards the root). */
static int pgem_online_numeric(const pgem_online_parts_t *parts, int columns, int partial)
{
    pgem_online_t *online = parts->online;
    const int b = online->block;
    const size_t bb = (size_t)b * (size_t)b;
    int *head = online->adjacent_start, *next = online->next, *position = online->position;
    int *map = online->list;
    for (int j = 0; j < columns; j++) {
        head[j] = -1;
    }
    for (int j = 0; j < columns; j++) {
        const int first = online->start[j];
        if (!pgem_online_in(online, j, partial)) {
            int q = first + online->count[j] + 1;
            while (q > first + 1 && pgem_online_in(online, online->rows[q - 1], partial)) {
                q--;
            }
            if (q <= first + online->count[j]) { /* its factor stays; it updates rows q.. */
                position[j] = q;
                next[j] = head[online->rows[q]];
                head[online->rows[q]] = j;
                pgem_online_propagate(online, j, q);
            }
            continue;
        }
        for (int q = 0; q <= online->count[j]; q++) {
            map[online->rows[first + q]] = first + q;
        }
        int d = head[j];
        head[j] = -1;
        while (d >= 0) {
            const int after = next[d];
            const int end = online->start[d] + online->count[d];
            const double *ljd = online->values + (size_t)position[d] * bb;
            for (int q = position[d]; q <= end; q++) {
                const int i = online->rows[q];
                pgem_online_subtract(online->values + (size_t)map[i] * bb,
                                     online->values + (size_t)q * bb, ljd, b, i == j);
            }
            if (++position[d] <= end) {
                const int row = online->rows[position[d]];
                next[d] = head[row];
                head[row] = d;
            }
            d = after;
        }
        double *diagonal = online->values + (size_t)first * bb;
        if (pgem_small_cholesky(diagonal, b, 0.0, 1) >= 0) {
            parts->message[0] = '\0';
            pgem_text_append(parts->message, PGEM_MESSAGE_SIZE,
                             "the online factor is not positive definite at pose index ");
            pgem_text_u64(parts->message, PGEM_MESSAGE_SIZE, (uint64_t)online->column_pose[j]);
            pgem_text_append(parts->message, PGEM_MESSAGE_SIZE,
                             " (a part of the graph with no held pose?)");
            return PGEM_ERR_NOT_POSITIVE_DEFINITE;
        }
        for (int q = 1; q <= online->count[j]; q++) {
            double *block = online->values + (size_t)(first + q) * bb;
            for (int r = 0; r < b; r++) { /* row r of block: solve x D^T = row */
                for (int c = 0; c < b; c++) {
                    double sum = block[c * b + r];
                    for (int m = 0; m < c; m++) {
                        sum -= block[m * b + r] * diagonal[m * b + c];
                    }
                    block[c * b + r] = sum / diagonal[c * b + c];
                }
            }
        }
        if (online->count[j] > 0) {
            position[j] = first + 1;
            const int row = online->rows[first + 1];
            next[j] = head[row];
            head[row] = j;
        }
        double *x = online->forward + (size_t)j * (size_t)b; /* x = D^-1 x */
        for (int c = 0; c < b; c++) {
            x[c] /= diagonal[c * b + c];
            for (int r = c + 1; r < b; r++) {
                x[r] -= diagonal[c * b + r] * x[c];
            }
        }
        pgem_online_propagate(online, j, first + 1);
    }
    return PGEM_OK;
}

int pgem_online_rebuild(const pgem_online_parts_t *parts, int recent)
{
    pgem_online_t *online = parts->online;
    online->ready = 0;
    online->full = 0;
    const int columns = pgem_online_number(parts);
    int status = pgem_online_order(parts, columns, recent < columns ? recent : columns);
    if (status != PGEM_OK) {
        return status;
    }
    for (uint32_t p = 0; p < parts->store->pose_count; p++) {
        online->pose_column[p] = -1;
    }
    /* list[k] holds the arrival number of the k-th column: map it back to its pose */
    int arrival = 0;
    for (uint32_t p = 0; p < parts->store->pose_count && arrival < columns; p++) {
        if (!pgem_online_free(parts, p)) {
            continue;
        }
        int in = 0;
        for (int end = online->pose_edge[p]; end >= 0 && !in; end = online->edge_next[end]) {
            in = online->edge_weight_in[end / 2] > 0.0;
        }
        if (in) {
            online->mark[arrival++] = (int)p;
        }
    }
    for (int k = 0; k < columns; k++) {
        const int p = online->mark[online->list[k]];
        online->column_pose[k] = p;
        online->pose_column[p] = k;
    }
    online->columns = columns;
    status = pgem_online_symbolic(parts, columns);
    if (status != PGEM_OK) {
        online->columns = 0;
        return status;
    }
    online->packed_blocks = online->live_blocks;
    pgem_online_link_tree(online);
    memset(online->delta, 0, (size_t)columns * (size_t)online->block * sizeof(double));
    pgem_online_assemble(parts, columns);
    status = pgem_online_numeric(parts, columns, 0);
    if (status != PGEM_OK) {
        online->columns = 0;
        return status;
    }
    online->last.columns_touched += (uint32_t)columns;
    online->ready = 1;
    return PGEM_OK;
}

/* Marks column j and its ancestors touched, listing the new ones; returns how many. */
static int pgem_online_touch_path(pgem_online_t *online, int j, int *list, int count)
{
    for (; j >= 0 && online->touched[j] != online->stamp; j = online->parent[j]) {
        online->touched[j] = online->stamp;
        list[count++] = j;
    }
    return count;
}

int pgem_online_affected(const pgem_online_parts_t *parts, const int *poses, int count,
                         double *work)
{
    pgem_online_t *online = parts->online;
    int *list = online->adjacent, marked = 0;
    for (int m = 0; m < count; m++) {
        const uint32_t p = (uint32_t)poses[m];
        marked = pgem_online_touch_path(online, online->pose_column[p], list, marked);
        for (int end = online->pose_edge[p]; end >= 0; end = online->edge_next[end]) {
            if (online->edge_weight_in[end / 2] > 0.0) {
                marked = pgem_online_touch_path(
                    online, online->pose_column[pgem_online_other(parts, end)], list, marked);
            }
        }
    }
    double sum = 0.0;
    for (int j = 0; j < online->columns && marked > 0; j++) {
        const int first = online->start[j];
        int q = first + online->count[j] + 1;
        if (online->touched[j] == online->stamp) {
            q = first;
        }
        while (q > first + 1 && online->touched[online->rows[q - 1]] == online->stamp) {
            q--;
        }
        const double blocks = (double)(first + online->count[j] + 1 - q);
        sum += blocks * blocks;
    }
    *work = sum;
    return marked;
}

void pgem_online_unaffected(const pgem_online_parts_t *parts, int count)
{
    pgem_online_t *online = parts->online;
    for (int t = 0; t < count; t++) {
        online->touched[online->adjacent[t]] = 0; /* stamps start at 1 */
    }
}

int pgem_online_refactor(const pgem_online_parts_t *parts, int count)
{
    pgem_online_t *online = parts->online;
    pgem_online_assemble_touched(parts, online->adjacent, count);
    const int status = pgem_online_numeric(parts, online->columns, 1);
    if (status != PGEM_OK) {
        online->ready = 0;
        return status;
    }
    online->last.columns_touched += (uint32_t)count;
    return PGEM_OK;
}
