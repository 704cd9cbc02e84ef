/* pgem_copy: one instance's graph into another (empty) one, with the fill-reducing ordering
 * when it is still the current graph's, so a host can size a block exactly (analyse with any
 * fill budget, read the factor's nonzeros, copy into a block of exactly that budget) without
 * loading or ordering twice. */
#include <string.h>

#include "instance.h"

static int pgem_copy_refused(pgem_t *to, int code, const char *text)
{
    return pgem_fail(to, code, text);
}

int pgem_copy(pgem_t *to, const pgem_t *from)
{
    if (to == NULL || from == NULL || to == from) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (to->config.dimension != from->config.dimension) {
        return pgem_copy_refused(to, PGEM_ERR_DIMENSION, "pgem_copy: the instances' dimensions differ");
    }
    if (to->store.pose_count != 0u) {
        return pgem_copy_refused(to, PGEM_ERR_INVALID_ARGUMENT, "pgem_copy: the target holds poses already");
    }
    if (from->store.pose_count > to->config.max_poses || from->store.edge_count > to->config.max_edges) {
        return pgem_copy_refused(to, PGEM_ERR_CAPACITY,
                                 "pgem_copy: the target has room for fewer poses or edges");
    }
    pgem_store_copy(&to->store, &from->store, from->pose_size, from->tangent);
    pgem_linear_copy_ordering(to->linear, &to->store, from->linear, &from->store);
    pgem_message_clear(to);
    return PGEM_OK;
}
