/* The online layer, private to lib/core: the incremental solve behind pgem_update (its factor,
 * gate, save/restore, adoption of a pass, compaction and the covariance from its factor). It
 * sits above robust: its gate makes robust decisions per update. Its state (online/factor.h)
 * is opaque to every other layer; instance/ carves it and holds the pointer. */
#ifndef PGEM_ONLINE_LAYER_H
#define PGEM_ONLINE_LAYER_H

#include "robust/robust.h"

typedef struct pgem_online pgem_online_t; /* graph->online, defined in online/factor.h */

/* Carves the online state, right after struct pgem (which held it before it was opaque: the
 * block's size stayed the same), and then, after linalg's part and with config.online_fill,
 * its arrays (measuring when arena->base is NULL; a failed carve leaves graph->online NULL). */
void pgem_online_carve_state(pgem_t *graph, pgem_arena_t *arena);
void pgem_online_carve(pgem_t *graph, pgem_arena_t *arena);

#endif /* PGEM_ONLINE_LAYER_H */
