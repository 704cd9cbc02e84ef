/* Numeric supernodal Cholesky H = L L^T, left-looking: each supernode gathers its columns of
 * H, subtracts the update of every descendant with rows in it (in an order fixed by the
 * structure alone), then factorises its trapezoid densely (linalg/factor/dense_kernel.h). Whole
 * subtrees of the schedule (linalg/factor/schedule.c) are independent tasks; the supernodes above
 * them follow one by one. No allocation: the workspace is carved at init. */
#include <string.h>

#include "linalg/linear.h"

/* Block positions of supernode s's rows in the worker's map: its own block columns first,
 * then its rows below. */
static void pgem_numeric_map(const pgem_factor_t *factor, int s, int *map)
{
    const int first = factor->super_first[s];
    const int width = factor->super_first[s + 1] - first;
    for (int j = 0; j < width; j++) {
        map[first + j] = j;
    }
    const int *rows = factor->rows + factor->row_start[s];
    const int count = factor->row_start[s + 1] - factor->row_start[s];
    for (int q = 0; q < count; q++) {
        map[rows[q]] = width + q;
    }
}

/* Supernode s's values zeroed, then its columns of H (lower CSC, see linalg/analysis/analyze.c)
 * scattered in. */
static void pgem_numeric_gather(const pgem_linear_t *linear, int s, const int *map)
{
    const pgem_factor_t *factor = &linear->factor;
    const int b = linear->block, first = factor->super_first[s];
    const int height = pgem_factor_height(factor, s);
    double *values = factor->values + factor->value_start[s];
    memset(values, 0, (size_t)(factor->value_start[s + 1] - factor->value_start[s]) * sizeof(double));
    for (int block = first; block < factor->super_first[s + 1]; block++) {
        const int *rows = linear->block_rows + linear->block_colptr[block];
        const int count = linear->block_colptr[block + 1] - linear->block_colptr[block];
        for (int c = 0; c < b; c++) {
            const int local = (block - first) * b + c;
            double *column = values + pgem_factor_column(height, local) - local; /* [row] */
            const double *h = linear->lower_values + pgem_lower_column(linear, block, c);
            for (int r = c; r < b; r++) {
                column[local - c + r] = h[r - c];
            }
            h += b - c;
            for (int q = 0; q < count; q++) {
                double *target = column + (ptrdiff_t)map[rows[q]] * b;
                for (int r = 0; r < b; r++) {
                    target[r] = h[r];
                }
                h += b;
            }
        }
    }
}

/* Subtracts descendant d's update from supernode s (d's rows from position[d] on, the first
 * of them in s); returns the index of d's first row past s. */
static int pgem_numeric_update(pgem_factor_t *factor, const pgem_dense_ops_t *ops, int d, int s,
                               const pgem_factor_worker_t *worker)
{
    const int b = factor->block;
    const int first = factor->position[d], end = factor->row_start[d + 1];
    const int last = factor->super_first[s + 1] - 1;
    int past = first;
    while (past < end && factor->rows[past] <= last) {
        past++;
    }
    const int width = (factor->super_first[d + 1] - factor->super_first[d]) * b;
    if (width == b) {
        pgem_block_update(factor, d, s, past - first, worker->map);
        return past;
    }
    const int height = pgem_factor_height(factor, d);
    pgem_dense_update_t update;
    update.source = factor->values + factor->value_start[d] + width +
                    (ptrdiff_t)(first - factor->row_start[d]) * b; /* column 0 */
    update.step = height - 1;
    update.m = (end - first) * b;
    update.n = (past - first) * b;
    update.k = width;
    update.target = factor->values + factor->value_start[s];
    update.target_height = pgem_factor_height(factor, s);
    update.row0 = 0;
    update.rows = factor->rows + first;
    update.map = worker->map;
    update.block = b;
    ops->update(&update, worker->work, worker->work_doubles);
    return past;
}

/* Puts supernode d, whose next row is at position[d], on the list of the supernode that row
 * belongs to, if that is at most `limit` (inside the running task); else d waits. */
static void pgem_numeric_link(pgem_factor_t *factor, int d, int limit)
{
    if (factor->position[d] >= factor->row_start[d + 1]) {
        return; /* d updates nothing more */
    }
    const int target = factor->block_super[factor->rows[factor->position[d]]];
    if (target <= limit) {
        factor->next[d] = factor->head[target];
        factor->head[target] = d;
    }
}

/* Worker 0 finished supernode s: its share of the flops counted, the solve's progress
 * callback called at each further 1/64 of a long factorisation. */
static void pgem_numeric_progress(pgem_linear_t *linear, int s)
{
    pgem_factor_t *factor = &linear->factor;
    const pgem_solve_options_t *options = linear->progress;
    if (options == NULL || options->on_progress == NULL || factor->flops < PGEM_PROGRESS_FLOPS) {
        return;
    }
    factor->progress_done += pgem_factor_supernode_flops(factor, s) * factor->progress_share;
    if (factor->progress_done >= factor->progress_next) {
        pgem_progress_t progress;
        progress.iteration = linear->progress_iteration;
        progress.done = factor->progress_done < factor->flops ? factor->progress_done / factor->flops : 1.0;
        progress.multiply_adds = factor->flops;
        options->on_progress(&progress, options->user);
        while (factor->progress_next <= factor->progress_done) {
            factor->progress_next += factor->flops / 64.0;
        }
    }
}

/* Supernode s: gather, updates, dense factorisation, then its own link. Returns PGEM_OK, or
 * PGEM_ERR_NOT_POSITIVE_DEFINITE with *failed (the scalar column) set. */
static int pgem_numeric_supernode(pgem_linear_t *linear, int s, int limit,
                                  const pgem_factor_worker_t *worker, int *failed)
{
    pgem_factor_t *factor = &linear->factor;
    const pgem_dense_ops_t *ops = linear->dense;
    pgem_numeric_map(factor, s, worker->map);
    pgem_numeric_gather(linear, s, worker->map);
    int d = factor->head[s];
    factor->head[s] = -1;
    while (d >= 0) {
        const int following = factor->next[d];
        factor->position[d] = pgem_numeric_update(factor, ops, d, s, worker);
        pgem_numeric_link(factor, d, limit);
        d = following;
    }
    const int height = pgem_factor_height(factor, s);
    const int width = (factor->super_first[s + 1] - factor->super_first[s]) * factor->block;
    double *values = factor->values + factor->value_start[s];
    const int bad = width == factor->block
                        ? pgem_block_factor(values, height, width)
                        : ops->factor(values, height, width, worker->work, worker->work_doubles);
    if (bad >= 0) {
        *failed = factor->super_first[s] * factor->block + bad;
        return PGEM_ERR_NOT_POSITIVE_DEFINITE;
    }
    factor->position[s] = factor->row_start[s];
    pgem_numeric_link(factor, s, limit);
    if (worker == &factor->workers[0]) {
        pgem_numeric_progress(linear, s);
    }
    return PGEM_OK;
}

int pgem_numeric_task(pgem_linear_t *linear, int task, const pgem_factor_worker_t *worker,
                      int *failed)
{
    pgem_factor_t *factor = &linear->factor;
    const int begin = factor->task_first[task], end = factor->task_first[task + 1];
    const int root = factor->order[end - 1];
    for (int k = begin; k < end; k++) {
        const int status = pgem_numeric_supernode(linear, factor->order[k], root, worker, failed);
        if (status != PGEM_OK) {
            return status;
        }
    }
    return PGEM_OK;
}

void pgem_numeric_begin(pgem_linear_t *linear)
{
    pgem_factor_t *factor = &linear->factor;
    for (int s = 0; s < factor->super_count; s++) {
        factor->head[s] = -1;
    }
    factor->progress_done = 0.0;
    factor->progress_next = factor->flops / 64.0;
    factor->progress_share = 1.0;
}

/* After the tasks: every supernode of a task that still has rows waits for a supernode above
 * the tasks; they join those lists in increasing order, then the rest runs one by one. */
int pgem_numeric_top(pgem_linear_t *linear, const pgem_factor_worker_t *worker, int *failed)
{
    pgem_factor_t *factor = &linear->factor;
    const int tasks_end = factor->task_first[factor->task_count];
    for (int k = 0; k < tasks_end; k++) {
        pgem_numeric_link(factor, factor->order[k], factor->super_count);
    }
    for (int k = tasks_end; k < factor->super_count; k++) {
        const int status = pgem_numeric_supernode(linear, factor->order[k], factor->super_count,
                                                  worker, failed);
        if (status != PGEM_OK) {
            return status;
        }
    }
    return PGEM_OK;
}
