/* A robust solve's options: checked (naming the option that is wrong) and resolved to their
 * documented defaults. A zeroed struct means EM with its defaults (PGEM_KERNEL_EM is 0). */
#include <string.h>

#include "robust/robust.h"

pgem_robust_options_t pgem_robust_resolve(const pgem_robust_options_t *options)
{
    pgem_robust_options_t out;
    memset(&out, 0, sizeof out);
    if (options != NULL) {
        out = *options;
    }
    out.scale = out.scale > 0.0 ? out.scale : 1.0;
    out.prune_threshold = out.prune_threshold > 0.0 ? out.prune_threshold : 0.01;
    out.weight_tolerance = out.weight_tolerance > 0.0 ? out.weight_tolerance : 1e-3;
    out.m_step_iterations = out.m_step_iterations > 0u ? out.m_step_iterations : 1u;
    out.max_em_iterations = out.max_em_iterations > 0u ? out.max_em_iterations
                                                       : (out.literal ? 100u : 5u);
    out.max_rounds = out.max_rounds > 0u ? out.max_rounds : 20u;
    out.odometry_inflation = out.odometry_inflation > 0.0 ? out.odometry_inflation : 4.0;
    out.predictable_rotation = out.predictable_rotation > 0.0 ? out.predictable_rotation : 0.1;
    if (out.literal || out.kernel != PGEM_KERNEL_EM) {
        out.distance = PGEM_DISTANCE_POINT; /* the paper, and the IRLS kernels: point chi2 */
    }
    if (out.literal || out.kernel != PGEM_KERNEL_EM || out.dormant_threshold < 0.0) {
        out.dormant_threshold = 0.0; /* no weight is below 0: never dormant */
    } else if (out.dormant_threshold == 0.0) {
        out.dormant_threshold = out.prune_threshold / 100.0;
    }
    return out;
}

/* NaN fails every "> 0" test in pgem_robust_resolve and would silently become the default;
 * Inf would disable the kernel or the gate. Both are refused, naming the option. */
/* message: PGEM_MESSAGE_SIZE bytes, set as pgem_fail would. */
static int pgem_robust_refuse(char *message, const char *text)
{
    message[0] = '\0';
    pgem_text_append(message, PGEM_MESSAGE_SIZE, text);
    return PGEM_ERR_INVALID_ARGUMENT;
}

int pgem_check_robust_options(const pgem_robust_options_t *options, char *message)
{
    if (options == NULL) {
        return PGEM_OK;
    }
    if ((unsigned)options->distance > (unsigned)PGEM_DISTANCE_POINT) {
        return pgem_robust_refuse(message, "unknown loop distance");
    }
    if ((unsigned)options->kernel > (unsigned)PGEM_KERNEL_USER) { /* negative values too */
        return pgem_robust_refuse(message, "unknown robust kernel");
    }
    if (options->kernel == PGEM_KERNEL_USER && options->kernel_function == NULL) {
        return pgem_robust_refuse(message, "PGEM_KERNEL_USER needs options.kernel_function");
    }
    const double values[] = {options->scale, options->prune_threshold, options->weight_tolerance,
                             options->gate, options->dormant_threshold,
                             options->odometry_inflation, options->predictable_rotation};
    const char *const names[] = {"scale", "prune_threshold", "weight_tolerance", "gate",
                                 "dormant_threshold", "odometry_inflation",
                                 "predictable_rotation"};
    for (size_t k = 0; k < sizeof values / sizeof values[0]; k++) {
        int status = pgem_text_option(message, values[k], names[k]);
        if (status != PGEM_OK) {
            return status;
        }
    }
    return PGEM_OK;
}

