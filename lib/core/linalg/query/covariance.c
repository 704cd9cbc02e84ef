/* Marginal covariances of poses for the covariance calls (pgem/covariance.h), in the linear
 * system's tangent, from what the factor holds: L (a solve along a pose's path to the root,
 * linalg/query/marginal.c) or H^-1 on L's pattern (the sparse inverse,
 * linalg/query/inverse.c, whose diagonal blocks are every pose's marginal). Held poses have no block: their covariance is
 * zero. No allocation: the solves' right-hand sides live in the shared region. */
#include <string.h>

#include "linalg/linear.h"

int pgem_linear_covariance_state(const pgem_linear_t *linear, const pgem_store_t *store)
{
    if (linear->covariance_topology != store->topology ||
        linear->covariance_revision != store->revision) {
        return PGEM_COVARIANCE_NONE;
    }
    return linear->covariance;
}

void pgem_linear_covariance_mark(pgem_linear_t *linear, const pgem_store_t *store, int state)
{
    linear->covariance = state;
    linear->covariance_topology = store->topology;
    linear->covariance_revision = store->revision;
}

/* The b x b identity and zero blocks, row-major. */
static void pgem_identity_blocks(int b, double *identity, double *zero)
{
    memset(identity, 0, (size_t)(b * b) * sizeof(double));
    memset(zero, 0, (size_t)(b * b) * sizeof(double));
    for (int k = 0; k < b; k++) {
        identity[k * b + k] = 1.0;
    }
}

void pgem_linear_pose_covariance(pgem_linear_t *linear, uint32_t p, double *out)
{
    const int b = linear->block;
    double identity[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double zero[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    pgem_identity_blocks(b, identity, zero);
    if (linear->covariance == PGEM_COVARIANCE_INVERSE) {
        pgem_linear_marginal_diagonal(linear, p, p, identity, zero, out);
    } else {
        pgem_linear_marginal(linear, p, p, identity, zero, out);
    }
}

/* The cross block S = Sigma_pq from four solves that each hold b right-hand sides (the shared
 * region has room for one b x b block per pose, not two): with D = diag(1 .. b),
 *   U = M([I I]) - Sigma_pp - Sigma_qq = S + S^T,
 *   T = M([I D]) - Sigma_pp - D Sigma_qq D = S D + D S^T,
 * so S_ii = U_ii / 2 and, for i != j, S_ij = (T_ij - d_i U_ij) / (d_j - d_i), where
 * M(A) = A H^-1 A^T for A = [A_p A_q] (the polarisation identity, in closed form). */
static void pgem_cross_block(pgem_linear_t *linear, uint32_t p, uint32_t q, const double *own_p,
                             const double *own_q, double *cross)
{
    const int b = linear->block;
    double identity[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double scale[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double sum[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    double scaled[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    pgem_identity_blocks(b, identity, scale);
    for (int k = 0; k < b; k++) {
        scale[k * b + k] = (double)(k + 1);
    }
    pgem_linear_marginal(linear, p, q, identity, identity, sum);
    pgem_linear_marginal(linear, p, q, identity, scale, scaled);
    for (int i = 0; i < b; i++) {
        for (int j = 0; j < b; j++) {
            const double d_i = (double)(i + 1), d_j = (double)(j + 1);
            const double u = sum[i * b + j] - own_p[i * b + j] - own_q[i * b + j];
            const double t = scaled[i * b + j] - own_p[i * b + j] - d_i * d_j * own_q[i * b + j];
            cross[i * b + j] = i == j ? 0.5 * u : (t - d_i * u) / (d_j - d_i);
        }
    }
}

int pgem_linear_joint_covariance(pgem_linear_t *linear, const pgem_store_t *store,
                                 const pgem_executor_t *executor, char *message, uint32_t p,
                                 uint32_t q, double *out)
{
    const int b = linear->block;
    if (linear->covariance == PGEM_COVARIANCE_INVERSE) { /* the solves need L again */
        const int status = pgem_linear_factor(linear, store, executor, message);
        if (status != PGEM_OK) {
            return status; /* (the factor was fine before the inverse: not expected) */
        }
        pgem_linear_covariance_mark(linear, store, PGEM_COVARIANCE_FACTOR);
    }
    double own_p[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    double own_q[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    double cross[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    pgem_linear_pose_covariance(linear, p, own_p);
    pgem_linear_pose_covariance(linear, q, own_q);
    if (p == q) {
        memcpy(cross, own_p, sizeof cross);
    } else if (linear->pose_block[p] < 0 || linear->pose_block[q] < 0) {
        memset(cross, 0, sizeof cross); /* a held pose: no correlation */
    } else {
        pgem_cross_block(linear, p, q, own_p, own_q, cross);
    }
    const int n = 2 * b;
    for (int i = 0; i < b; i++) {
        for (int j = 0; j < b; j++) {
            out[i * n + j] = own_p[i * b + j];
            out[(b + i) * n + b + j] = own_q[i * b + j];
            out[i * n + b + j] = cross[i * b + j];
            out[(b + j) * n + i] = cross[i * b + j];
        }
    }
    return PGEM_OK;
}

void pgem_linear_all_covariances(pgem_linear_t *linear, const pgem_store_t *store, double *out)
{
    const int b = linear->block;
    if (linear->covariance == PGEM_COVARIANCE_FACTOR) {
        pgem_linear_invert(linear);
        pgem_linear_covariance_mark(linear, store, PGEM_COVARIANCE_INVERSE);
    }
    for (uint32_t p = 0; p < store->pose_count; p++) {
        pgem_linear_pose_covariance(linear, p, out + (size_t)p * (size_t)(b * b));
    }
}
