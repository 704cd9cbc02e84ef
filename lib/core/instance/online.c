/* The public calls of the online layer (pgem/update.h, pgem/compact.h, pgem_update_covariance
 * of pgem/covariance.h) over an instance: the checks of NULL arguments, then the layer's own
 * calls on the parts it is lent (pgem_online_entry_t), so the online layer itself never sees
 * struct pgem (docs/design/core-layers.md). */
#include <string.h>

#include "instance.h"
#include "pgem/covariance.h"

int pgem_update(pgem_t *graph, const pgem_update_options_t *options,
                pgem_update_summary_t *summary)
{
    if (summary != NULL) {
        memset(summary, 0, sizeof *summary);
    }
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_online_entry_t entry = pgem_online_entry(graph);
    return pgem_online_update(&entry, options, summary);
}

int pgem_update_settle(pgem_t *graph, const pgem_robust_options_t *robust,
                       pgem_robust_summary_t *summary)
{
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_online_entry_t entry = pgem_online_entry(graph);
    return pgem_online_settle(&entry, robust, summary);
}

int pgem_update_adopt(pgem_t *graph, const pgem_t *pass, pgem_adopt_summary_t *summary)
{
    if (summary != NULL) {
        memset(summary, 0, sizeof *summary);
    }
    if (graph == NULL || pass == NULL || graph == pass) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_online_entry_t entry = pgem_online_entry(graph);
    return pgem_online_adopt(&entry, &pass->store, &pass->robust, pass->config.dimension,
                             summary);
}

int pgem_compact(pgem_t *graph, uint32_t target_poses, const pgem_compact_options_t *options,
                 pgem_compact_summary_t *summary)
{
    if (graph == NULL) {
        if (summary != NULL) {
            memset(summary, 0, sizeof *summary);
        }
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_online_entry_t entry = pgem_online_entry(graph);
    return pgem_online_compact(&entry, target_poses, options, summary);
}

size_t pgem_update_save_size(const pgem_t *graph)
{
    return graph != NULL ? pgem_online_save_size(graph->pose_size, &graph->config) : 0u;
}

int pgem_update_save(pgem_t *graph, void *buffer, size_t size)
{
    if (graph == NULL || buffer == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_online_entry_t entry = pgem_online_entry(graph);
    return pgem_online_save(&entry, buffer, size);
}

int pgem_update_restore(pgem_t *graph, const void *buffer, size_t size)
{
    if (graph == NULL || buffer == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_online_entry_t entry = pgem_online_entry(graph);
    return pgem_online_restore(&entry, buffer, size);
}

int pgem_update_covariance(pgem_t *graph, pgem_id_t id, double *covariance)
{
    if (graph == NULL || covariance == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const pgem_online_entry_t entry = pgem_online_entry(graph);
    return pgem_online_update_covariance(&entry, id, covariance);
}
