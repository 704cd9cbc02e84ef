/* The online layer, private to lib/core: the incremental solve behind pgem_update (its factor,
 * gate, save/restore, adoption of a pass, compaction and the covariance from its factor). It
 * sits above robust: its gate makes robust decisions per update. Its state (online/factor.h)
 * is opaque to every other layer; instance/ carves it and holds the pointer. */
#ifndef PGEM_ONLINE_LAYER_H
#define PGEM_ONLINE_LAYER_H

#include "robust/robust.h"

typedef struct pgem_online pgem_online_t; /* graph->online, defined in online/factor.h */

/* What the incremental factor works on, lent for one call: its state, the store, the linear
 * system (for CSparse's ordering), the resolved config (online_fill, capacities), the
 * dimension (tangent rows, doubles per pose) and the message buffer (PGEM_MESSAGE_SIZE). */
typedef struct pgem_online_parts {
    pgem_online_t *online;
    pgem_store_t *store;
    pgem_linear_t *linear;
    const pgem_config_t *config;
    int tangent;
    int pose_size;
    char *message;
} pgem_online_parts_t;

/* Carves the online state, right after struct pgem (which held it before it was opaque: the
 * block's size stayed the same), and then, after linalg's part and with config.online_fill,
 * its arrays (measuring when arena->base is NULL: the state is NULL then, and after a failed
 * carve; the arrays are carved for the config's capacities and the tangent's dimension). */
pgem_online_t *pgem_online_carve_state(pgem_arena_t *arena);
void pgem_online_carve(pgem_online_t *state, const pgem_config_t *config, int tangent,
                       pgem_arena_t *arena);

#endif /* PGEM_ONLINE_LAYER_H */
