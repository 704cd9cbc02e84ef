/* The firmware example's job, shared by the Cortex-M7 image and the host build that checks it:
 * load the generated graph into a pgem instance in a static block, run EM, report. */
#ifndef FIRMWARE_RUN_H
#define FIRMWARE_RUN_H

#include <stddef.h>
#include <stdint.h>

#include <pgem/pgem.h>

#include "firmware_graph.h"

/* Factor nonzeros the block is sized for: the graph's Cholesky factor with every loop closure
 * in the structure needs fewer (the report prints the figure); pgem refuses a solve that would
 * need more with PGEM_ERR_FILL_BUDGET rather than overrun the block. */
#define FIRMWARE_FILL 17000u
/* The whole block, sized at compile time with the core's bound (pgem_init checks it again). */
#define FIRMWARE_BLOCK_BYTES PGEM_MEMORY_BOUND(2, FIRMWARE_POSES, FIRMWARE_EDGES, FIRMWARE_FILL)

typedef struct firmware_io {
    void (*write)(const char *text, size_t length); /* the report, byte for byte */
    void (*counter_start)(void);                    /* may be NULL: no counter */
    uint64_t (*counter_read)(void);                 /* instructions (or ticks) since start */
    const char *counter_unit;                       /* what counter_read counts */
} firmware_io_t;

/* Runs the example in block (FIRMWARE_BLOCK_BYTES). Lines of the report that start with '#'
 * differ between machines (sizes, counters); every other line must be identical everywhere.
 * Returns 0 on success. */
int firmware_run(const firmware_io_t *io, void *block, size_t size);

#endif
