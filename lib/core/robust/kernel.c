/* Robust kernels behind one interface: rho and its derivative (the weight) at a loop closure's
 * chi2, for the built-in kernels, and the weight a solve gives a loop, a user's kernel
 * included. */
#include <math.h>

#include "robust/robust.h"

/* Cauchy: rho(s) = c^2 log(1 + s / c^2), w = rho'(s) = 1 / (1 + s / c^2); an exact fit has
 * weight 1 (and rho 0) even when c^2 underflows to 0 (0 / 0 would be NaN). */
static pgem_kernel_value_t pgem_cauchy(double chi2, double scale)
{
    const double c2 = scale * scale;
    pgem_kernel_value_t value = {0.0, 1.0};
    if (!(chi2 <= 0.0)) { /* NaN stays NaN */
        value.weight = 1.0 / (1.0 + chi2 / c2);
        value.rho = c2 * log1p(chi2 / c2);
    }
    return value;
}

/* Huber on the Mahalanobis norm r = sqrt(s): rho = s, w = 1 for r <= k; else rho = 2 k r -
 * k^2, w = k / r. */
static pgem_kernel_value_t pgem_huber(double chi2, double scale)
{
    const double norm = sqrt(chi2);
    pgem_kernel_value_t value = {chi2, 1.0};
    if (!(norm <= scale)) {
        value.weight = scale / norm;
        value.rho = 2.0 * scale * norm - scale * scale;
    }
    return value;
}

/* DCS (Agarwal et al. 2013): s = min(1, 2 phi / (phi + chi2)), information scaled by s^2: w =
 * s^2, and rho = chi2 where s = 1, else phi (3 chi2 - phi) / (phi + chi2) (continuous, with
 * rho' = w). */
static pgem_kernel_value_t pgem_dcs(double chi2, double scale)
{
    const double factor = 2.0 * scale / (scale + chi2);
    pgem_kernel_value_t value = {chi2, 1.0};
    if (!(factor >= 1.0)) {
        value.weight = factor * factor;
        value.rho = scale * (3.0 * chi2 - scale) / (scale + chi2);
    }
    return value;
}

pgem_kernel_value_t pgem_kernel_evaluate(pgem_kernel_t kernel, double chi2, double scale)
{
    const pgem_kernel_value_t plain = {chi2, 1.0};
    switch (kernel) {
    case PGEM_KERNEL_EM:
    case PGEM_KERNEL_CAUCHY:
        return pgem_cauchy(chi2, scale);
    case PGEM_KERNEL_HUBER:
        return pgem_huber(chi2, scale);
    case PGEM_KERNEL_DCS:
        return pgem_dcs(chi2, scale);
    case PGEM_KERNEL_NONE:
    case PGEM_KERNEL_USER:
        return plain;
    }
    return plain;
}

double pgem_kernel_weight(pgem_kernel_t kernel, double chi2, double scale)
{
    return pgem_kernel_evaluate(kernel, chi2, scale).weight;
}

int pgem_loop_kernel_weight(const pgem_robust_state_t *robust, const pgem_store_t *store,
                            const pgem_robust_options_t *options, uint32_t k, double *weight,
                            char *message)
{
    const double distance = robust->edge_distance[k];
    if (options->kernel != PGEM_KERNEL_USER) {
        *weight = pgem_kernel_weight(options->kernel, distance, options->scale);
        return PGEM_OK;
    }
    *weight = options->kernel_function(distance, options->scale, options->kernel_user).weight;
    if (*weight >= 0.0 && *weight <= 1.0) {
        return PGEM_OK;
    }
    message[0] = '\0';
    pgem_text_append(message, PGEM_MESSAGE_SIZE, "the user kernel's weight for loop closure ");
    pgem_store_edge_name(store, k, message);
    pgem_text_append(message, PGEM_MESSAGE_SIZE, " is not in [0, 1]");
    return PGEM_ERR_NUMERIC;
}

const char *pgem_kernel_name(pgem_kernel_t kernel)
{
    switch (kernel) {
    case PGEM_KERNEL_NONE: return "none";
    case PGEM_KERNEL_EM: return "em";
    case PGEM_KERNEL_CAUCHY: return "cauchy";
    case PGEM_KERNEL_HUBER: return "huber";
    case PGEM_KERNEL_DCS: return "dcs";
    case PGEM_KERNEL_USER: return "user";
    }
    return "unknown";
}
