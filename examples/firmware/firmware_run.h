/* The firmware example's job, shared by the Cortex-M7 image and the host build that checks it:
 * load the generated graph into a pgem instance in a static block, run EM, report; then stream
 * a mission eight times the size of a second block through pgem_update and pgem_compact. */
#ifndef FIRMWARE_RUN_H
#define FIRMWARE_RUN_H

#include <stddef.h>
#include <stdint.h>

#include <pgem/pgem.h>

#include "firmware_graph.h"
#include "stream_graph.h"

/* Factor nonzeros the block is sized for: the graph's Cholesky factor with every loop closure
 * in the structure needs fewer (the report prints the figure); pgem refuses a solve that would
 * need more with PGEM_ERR_FILL_BUDGET rather than overrun the block. */
#define FIRMWARE_FILL 17000u
/* The batch job's block, sized at compile time with the core's bound (pgem_init checks it). */
#define FIRMWARE_BATCH_BYTES PGEM_MEMORY_BOUND(2, FIRMWARE_POSES, FIRMWARE_EDGES, FIRMWARE_FILL)

/* The long mission: STREAM_POSES poses streamed through pgem_update into a block of
 * STREAM_BLOCK_POSES poses and STREAM_BLOCK_EDGES edges; at STREAM_HIGH poses (or edges at
 * the same share of their capacity) pgem_compact takes it down to STREAM_LOW poses. Each
 * removed pose's anchor (the kept pose before it and the relative pose to it) goes into a
 * table of STREAM_ANCHORS entries, so a later loop closure to it enters on the anchor; when
 * the table is full the oldest entry is forgotten and an edge to that pose is refused. */
#define STREAM_BLOCK_POSES 250u
#define STREAM_BLOCK_EDGES 400u
#define STREAM_HIGH 225u /* 90 % */
#define STREAM_LOW 175u  /* 70 % */
#define STREAM_FILL 12000u
#define STREAM_ONLINE_FILL 48000u
#define STREAM_ANCHORS 2048u
#define STREAM_BLOCK_BYTES                                                                   \
    (PGEM_MEMORY_BOUND(2, STREAM_BLOCK_POSES, STREAM_BLOCK_EDGES, STREAM_FILL) +             \
     PGEM_ONLINE_BYTES(2, STREAM_BLOCK_POSES, STREAM_BLOCK_EDGES, STREAM_ONLINE_FILL))

/* The one block both jobs take turns in. */
#define FIRMWARE_BLOCK_BYTES \
    (FIRMWARE_BATCH_BYTES > STREAM_BLOCK_BYTES ? FIRMWARE_BATCH_BYTES : STREAM_BLOCK_BYTES)

typedef struct firmware_io {
    void (*write)(const char *text, size_t length); /* the report, byte for byte */
    void (*counter_start)(void);                    /* may be NULL: no counter */
    uint64_t (*counter_read)(void);                 /* instructions (or ticks) since start */
    const char *counter_unit;                       /* what counter_read counts */
} firmware_io_t;

/* Runs the example in block (FIRMWARE_BLOCK_BYTES): the batch job, then the long mission. Lines of the report that start with '#'
 * differ between machines (sizes, counters); every other line must be identical everywhere.
 * Returns 0 on success. */
int firmware_run(const firmware_io_t *io, void *block, size_t size);

#endif
