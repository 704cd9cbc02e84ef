/* Pieces shared by the solvers: applying a step, norms, progress reports, numeric failure. */
#include <math.h>

#include "solver/solver.h"

void pgem_apply_step(const pgem_solve_parts_t *parts, const double *step)
{
    const size_t size = (size_t)PGEM_POSE_SIZE(parts->config->dimension);
    for (uint32_t p = 0; p < parts->store->pose_count; p++) {
        const double *delta = pgem_linear_pose_delta(parts->linear, step, p);
        if (delta == NULL) {
            continue;
        }
        double *pose = parts->store->pose + (size_t)p * size;
        if (parts->config->dimension == 3) {
            pgem_se3_boxplus(pose, delta, pose);
        } else {
            pgem_se2_boxplus(pose, delta, pose);
        }
    }
}

double pgem_norm(const double *values, int count)
{
    double sum = 0.0;
    for (int k = 0; k < count; k++) {
        sum += values[k] * values[k];
    }
    return sqrt(sum);
}

int pgem_report(const pgem_solve_options_t *options, uint32_t iteration, double chi2,
                double step_norm, double lambda, int accepted)
{
    if (options->on_iteration == NULL) {
        return 0;
    }
    pgem_iteration_t info = {iteration, chi2, step_norm, lambda, accepted};
    return options->on_iteration(&info, options->user);
}

int pgem_fail_numeric(char *message, const char *what, uint32_t iteration)
{
    message[0] = '\0';
    pgem_text_append(message, PGEM_MESSAGE_SIZE, what);
    pgem_text_append(message, PGEM_MESSAGE_SIZE, " is not finite at iteration ");
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, iteration);
    return PGEM_ERR_NUMERIC;
}

int pgem_chi2_converged(double before, double after, double tolerance)
{
    if (tolerance < 0.0) {
        return 0;
    }
    if (before <= 0.0) {
        return 1;
    }
    return fabs(before - after) / before < tolerance;
}
