/* The online layer, private to lib/core: the incremental solve behind pgem_update (its factor,
 * gate, save/restore, adoption of a pass, compaction and the covariance from its factor). It
 * sits above robust: its gate makes robust decisions per update. Its state (online/factor.h)
 * is opaque to every other layer; instance/ carves it, holds the pointer and lends it with
 * the other parts (pgem_online_entry_t); the public calls are instance/online.c's. */
#ifndef PGEM_ONLINE_LAYER_H
#define PGEM_ONLINE_LAYER_H

#include "pgem/compact.h"
#include "pgem/update.h"
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

/* What the online layer's entries (update, settle, adoption, compaction, save and restore,
 * the covariance) work on, lent for one call by instance/online.c: the factor's parts and the
 * robust parts (the loops' distances and checks, the robust layer's scratch, and for a settle
 * the solve's parts). Both lend the same store, linear system, config and message buffer. */
typedef struct pgem_online_entry {
    pgem_online_parts_t factor;
    pgem_robust_parts_t robust;
} pgem_online_entry_t;

/* Carves the online state, right after struct pgem (which held it before it was opaque: the
 * block's size stayed the same), and then, after linalg's part and with config.online_fill,
 * its arrays (measuring when arena->base is NULL: the state is NULL then, and after a failed
 * carve; the arrays are carved for the config's capacities and the tangent's dimension). */
pgem_online_t *pgem_online_carve_state(pgem_arena_t *arena);
void pgem_online_carve(pgem_online_t *state, const pgem_config_t *config, int tangent,
                       pgem_arena_t *arena);

/* The online layer's entries behind the public calls of the same names (pgem/update.h,
 * pgem/compact.h, pgem/covariance.h), past their checks of NULL arguments (instance/online.c):
 * pgem_update, pgem_update_settle; pgem_update_adopt of the pass's store, robust state and
 * dimension; pgem_compact; pgem_update_save_size for the doubles per pose and the config's
 * capacities, pgem_update_save and pgem_update_restore; pgem_update_covariance. */
int pgem_online_update(const pgem_online_entry_t *entry, const pgem_update_options_t *options,
                       pgem_update_summary_t *summary);
int pgem_online_settle(const pgem_online_entry_t *entry, const pgem_robust_options_t *robust,
                       pgem_robust_summary_t *summary);
int pgem_online_adopt(const pgem_online_entry_t *entry, const pgem_store_t *from,
                      const pgem_robust_state_t *from_robust, int from_dimension,
                      pgem_adopt_summary_t *summary);
int pgem_online_compact(const pgem_online_entry_t *entry, uint32_t target_poses,
                        const pgem_compact_options_t *options, pgem_compact_summary_t *summary);
size_t pgem_online_save_size(int pose_size, const pgem_config_t *config);
int pgem_online_save(const pgem_online_entry_t *entry, void *buffer, size_t size);
int pgem_online_restore(const pgem_online_entry_t *entry, const void *buffer, size_t size);
int pgem_online_update_covariance(const pgem_online_entry_t *entry, pgem_id_t id,
                                  double *covariance);

#endif /* PGEM_ONLINE_LAYER_H */
