/* The public calls of the solver layer (pgem/solver.h, pgem/covariance.h) over an instance:
 * the argument checks, then the solver's own calls on the parts it works on (its state, the
 * store, the linear system, the config, the executor and the message), so the solver layer
 * itself never sees struct pgem (docs/design/core-layers.md). */
#include "instance.h"
#include "pgem/covariance.h"

int pgem_analyze(pgem_t *graph)
{
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_solve_parts_t parts = pgem_solve_parts(graph);
    return pgem_solver_analyze(&parts);
}

int pgem_fill_needed(pgem_t *graph, uint32_t *nonzeros)
{
    if (graph == NULL || nonzeros == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_solve_parts_t parts = pgem_solve_parts(graph);
    return pgem_solver_fill_needed(&parts, nonzeros);
}

int pgem_check_solvable(pgem_t *graph)
{
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_solve_parts_t parts = pgem_solve_parts(graph);
    return pgem_solver_check_solvable(&parts);
}

int pgem_optimize(pgem_t *graph, const pgem_solve_options_t *options, pgem_summary_t *summary)
{
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_solve_parts_t parts = pgem_solve_parts(graph);
    return pgem_solver_optimize(&parts, options, summary);
}

int pgem_covariance_prepare(pgem_t *graph)
{
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_solve_parts_t parts = pgem_solve_parts(graph);
    return pgem_solver_covariance_prepare(&parts);
}

int pgem_covariance(pgem_t *graph, pgem_id_t id, double *covariance)
{
    if (graph == NULL || covariance == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_solve_parts_t parts = pgem_solve_parts(graph);
    return pgem_solver_covariance(&parts, id, covariance);
}

int pgem_joint_covariance(pgem_t *graph, pgem_id_t a, pgem_id_t b, double *covariance)
{
    if (graph == NULL || covariance == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_solve_parts_t parts = pgem_solve_parts(graph);
    return pgem_solver_joint_covariance(&parts, a, b, covariance);
}

int pgem_covariances(pgem_t *graph, double *covariances)
{
    if (graph == NULL || covariances == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_solve_parts_t parts = pgem_solve_parts(graph);
    return pgem_solver_covariances(&parts, covariances);
}
