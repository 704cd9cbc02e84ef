/* The order of a factorisation, decided by the analysis from the supernodal tree alone (never
 * from the number of workers, so every worker count gives the same bits): the largest
 * subtrees holding at most a 1/PGEM_SUBTREE_SHARE of the flops each are tasks a worker runs
 * whole; the supernodes above them run afterwards in postorder. Tasks are handed to workers
 * by pgem_schedule_assign. */
#include "linalg/linear.h"

void pgem_schedule_analyze(pgem_linear_t *linear)
{
    pgem_factor_t *factor = &linear->factor;
    const int count = factor->super_count;
    double *subtree = factor->values; /* free until the first factorisation; >= count doubles */
    int *size = factor->head;         /* supernodes in each subtree */
    double total = 0.0;
    for (int s = 0; s < count; s++) {
        subtree[s] = 0.0;
        size[s] = 0;
    }
    for (int s = 0; s < count; s++) { /* children come first in the postorder */
        const double own = pgem_factor_supernode_flops(factor, s);
        subtree[s] += own;
        size[s] += 1;
        total += own;
        const int up = pgem_factor_parent(factor, linear->block_parent, s);
        if (up >= 0) {
            subtree[up] += subtree[s];
            size[up] += size[s];
        }
    }
    const double limit = total / PGEM_SUBTREE_SHARE;
    int placed = 0, tasks = 0;
    for (int s = 0; s < count; s++) {
        const int up = pgem_factor_parent(factor, linear->block_parent, s);
        if (subtree[s] <= limit && (up < 0 || subtree[up] > limit)) {
            factor->task_first[tasks++] = placed;
            for (int d = s - size[s] + 1; d <= s; d++) {
                factor->order[placed++] = d;
            }
        }
    }
    factor->task_first[tasks] = placed;
    factor->task_count = tasks;
    for (int s = 0; s < count; s++) { /* the rest, in postorder */
        if (subtree[s] > limit) {
            factor->order[placed++] = s;
        }
    }
    factor->task_workers = 0;
}

void pgem_schedule_assign(pgem_factor_t *factor, int workers)
{
    if (factor->task_workers == workers) {
        return;
    }
    double load[PGEM_MAX_THREADS] = {0.0};
    for (int t = 0; t < factor->task_count; t++) {
        double flops = 0.0;
        for (int k = factor->task_first[t]; k < factor->task_first[t + 1]; k++) {
            flops += pgem_factor_supernode_flops(factor, factor->order[k]);
        }
        int least = 0;
        for (int w = 1; w < workers; w++) {
            least = load[w] < load[least] ? w : least;
        }
        factor->task_worker[t] = least;
        load[least] += flops;
    }
    factor->task_workers = workers;
}
