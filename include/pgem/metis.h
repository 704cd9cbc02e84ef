/* METIS's nested dissection as an orderer for pgem_set_ordering (hosted builds with METIS). */
#ifndef PGEM_METIS_H
#define PGEM_METIS_H

#include "pgem/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The orderer that calls METIS_NodeND on the block graph (both triangles built from the
 * analysis's upper pattern; METIS's default options). Link pgem::metis. */
pgem_orderer_t pgem_metis_orderer(void);

/** pgem_set_ordering(graph, choice, the METIS orderer). */
int pgem_metis_use(pgem_t *graph, pgem_order_choice_t choice);

#ifdef __cplusplus
}
#endif

#endif
