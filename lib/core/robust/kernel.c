/* Robust kernels behind one interface: the weight a loop closure gets for its chi2. */
#include <math.h>

#include "instance.h"

double pgem_kernel_weight(pgem_kernel_t kernel, double chi2, double scale)
{
    switch (kernel) {
    case PGEM_KERNEL_EM:
    case PGEM_KERNEL_CAUCHY:
        /* Cauchy: rho(s) = c^2 log(1 + s / c^2), w = rho'(s) = 1 / (1 + s / c^2); an exact
         * fit has weight 1 even when c^2 underflows to 0 (0 / 0 would be NaN) */
        return chi2 <= 0.0 ? 1.0 : 1.0 / (1.0 + chi2 / (scale * scale));
    case PGEM_KERNEL_HUBER: {
        /* Huber on the Mahalanobis norm r = sqrt(s): w = 1 for r <= k, else k / r */
        double norm = sqrt(chi2);
        return norm <= scale ? 1.0 : scale / norm;
    }
    case PGEM_KERNEL_DCS: {
        /* DCS (Agarwal et al. 2013): s = min(1, 2 phi / (phi + chi2)), information scaled by s^2 */
        double factor = 2.0 * scale / (scale + chi2);
        return factor >= 1.0 ? 1.0 : factor * factor;
    }
    case PGEM_KERNEL_NONE:
        return 1.0;
    }
    return 1.0;
}

const char *pgem_kernel_name(pgem_kernel_t kernel)
{
    switch (kernel) {
    case PGEM_KERNEL_NONE: return "none";
    case PGEM_KERNEL_EM: return "em";
    case PGEM_KERNEL_CAUCHY: return "cauchy";
    case PGEM_KERNEL_HUBER: return "huber";
    case PGEM_KERNEL_DCS: return "dcs";
    }
    return "unknown";
}
