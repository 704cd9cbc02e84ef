/* pgem_linear_factor: the supernodal factorisation's tasks (independent subtrees) on the
 * instance's workers, then the supernodes above them, and the message when a pivot is not
 * positive. */
#include "linalg/linear.h"

size_t pgem_factor_work_doubles(uint32_t max_poses, int block, int worker)
{
    /* half a pose block per pose for worker 0, an eighth for the others (they run whole
     * subtrees of at most 1/64 of the flops each, whose supernodes are smaller; worker 0 also
     * runs the supernodes above them), but at least one k block of the largest micro-tiles'
     * operands (no product has more columns than the instance has unknowns), at most
     * PGEM_DENSE_WORK_MAX */
    const size_t unknowns = (size_t)max_poses * (size_t)block;
    const size_t k = unknowns < PGEM_DENSE_KC ? unknowns : PGEM_DENSE_KC;
    const size_t least = k * PGEM_DENSE_TILE_SPAN;
    size_t doubles = unknowns * (size_t)block / (worker == 0 ? 2u : 8u);
    doubles = doubles < least ? least : doubles;
    return doubles > PGEM_DENSE_WORK_MAX ? PGEM_DENSE_WORK_MAX : doubles;
}

size_t pgem_factor_shared_doubles(uint32_t max_poses, uint32_t max_edges, int block)
{
    const size_t scratch_ints = 3u * (size_t)max_edges + 4u * (size_t)max_poses + 4u;
    size_t doubles = (scratch_ints + 1u) / 2u;
    const size_t dense = pgem_factor_work_doubles(max_poses, block, 0);
    const size_t solves = (size_t)max_poses * (size_t)block * (size_t)block;
    doubles = doubles < dense ? dense : doubles;
    return doubles < solves ? solves : doubles;
}

pgem_factor_column_t pgem_factor_column_view(const pgem_factor_t *factor, int column)
{
    const int b = factor->block;
    const int s = factor->block_super[column];
    const int first = factor->super_first[s];
    const int height = pgem_factor_height(factor, s);
    pgem_factor_column_t view;
    view.inside = factor->super_first[s + 1] - 1 - column;
    view.count = view.inside + factor->row_start[s + 1] - factor->row_start[s];
    view.below = factor->rows + factor->row_start[s];
    for (int c = 0; c < PGEM_TANGENT_SIZE_MAX; c++) {
        view.base[c] = NULL;
    }
    for (int c = 0; c < b; c++) {
        const int local = (column - first) * b + c;
        view.base[c] = factor->values + factor->value_start[s] + pgem_factor_column(height, local);
    }
    return view;
}

static int pgem_not_positive_definite(const pgem_linear_t *linear, const pgem_store_t *store,
                                      char *message, int unknown)
{
    const int block = unknown / linear->block;
    message[0] = '\0';
    pgem_text_append(message, PGEM_MESSAGE_SIZE,
                     "normal equations not positive definite at unknown ");
    pgem_text_i64(message, PGEM_MESSAGE_SIZE, unknown);
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (linear->pose_block[p] == block) {
            pgem_text_append(message, PGEM_MESSAGE_SIZE, " (pose ");
            pgem_text_u64(message, PGEM_MESSAGE_SIZE, store->pose_id[p]);
            pgem_text_append(message, PGEM_MESSAGE_SIZE, ")");
        }
    }
    pgem_text_append(message, PGEM_MESSAGE_SIZE,
                     ": is the information of its edges too small or degenerate?");
    return PGEM_ERR_NOT_POSITIVE_DEFINITE;
}

/* The tasks' part of a factorisation on several workers: each runs the tasks assigned to it
 * (linalg/factor/schedule.c), in order, and stops at its first failure. */
typedef struct pgem_factor_job {
    pgem_linear_t *linear;
    int failed_task[PGEM_MAX_THREADS];   /* first task that failed on each worker, or -1 */
    int failed_column[PGEM_MAX_THREADS]; /* and its column */
} pgem_factor_job_t;

static void pgem_factor_tasks(void *context, uint32_t worker)
{
    pgem_factor_job_t *job = context;
    pgem_factor_t *factor = &job->linear->factor;
    job->failed_task[worker] = -1;
    for (int t = 0; t < factor->task_count; t++) {
        if (factor->task_worker[t] == (int)worker &&
            pgem_numeric_task(job->linear, t, &factor->workers[worker],
                              &job->failed_column[worker]) != PGEM_OK) {
            job->failed_task[worker] = t;
            return;
        }
    }
}

/* The tasks on the executor's workers; PGEM_OK, or the failure of the first task (in task
 * order, as one worker running them in turn would meet it) with *failed its column. */
static int pgem_factor_parallel(pgem_linear_t *linear, const pgem_executor_t *executor,
                                int workers, int *failed)
{
    pgem_factor_t *factor = &linear->factor;
    pgem_factor_job_t job;
    job.linear = linear;
    pgem_schedule_assign(factor, workers);
    factor->progress_share = (double)workers; /* worker 0 reports for all */
    executor->run(executor->executor, pgem_factor_tasks, &job);
    factor->progress_share = 1.0;
    int first = -1;
    for (int w = 0; w < workers; w++) {
        if (job.failed_task[w] >= 0 && (first < 0 || job.failed_task[w] < job.failed_task[first])) {
            first = w;
        }
    }
    if (first < 0) {
        return PGEM_OK;
    }
    *failed = job.failed_column[first];
    return PGEM_ERR_NOT_POSITIVE_DEFINITE;
}

int pgem_linear_factor(pgem_linear_t *linear, const pgem_store_t *store,
                       const pgem_executor_t *executor, char *message)
{
    pgem_factor_t *factor = &linear->factor;
    int workers = executor->run != NULL ? (int)executor->workers : 1;
    workers = workers < factor->worker_count ? workers : factor->worker_count;
    int failed = 0;
    int status = PGEM_OK;
    linear->covariance = PGEM_COVARIANCE_NONE;
    pgem_numeric_begin(linear);
    if (workers > 1 && factor->task_count > 1) {
        status = pgem_factor_parallel(linear, executor, workers, &failed);
    } else {
        for (int t = 0; t < factor->task_count && status == PGEM_OK; t++) {
            status = pgem_numeric_task(linear, t, &factor->workers[0], &failed);
        }
    }
    if (status == PGEM_OK) {
        status = pgem_numeric_top(linear, &factor->workers[0], &failed);
    }
    return status == PGEM_OK ? PGEM_OK
                             : pgem_not_positive_definite(linear, store, message, failed);
}
