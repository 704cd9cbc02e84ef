/* The firmware example on a Cortex-M7 (QEMU's mps2-an500): the whole pgem instance lives in one
 * static block in RAM, the graph in a const table in flash, the report goes out through
 * semihosting. The job itself is firmware_run.c, shared with the host build that checks it. */
#include "board.h"
#include "firmware_run.h"

static unsigned char block[FIRMWARE_BLOCK_BYTES] __attribute__((aligned(16)));

static uint64_t instructions(void)
{
    return board_counter_read() * BOARD_COUNTER_NS_PER_TICK;
}

int main(void)
{
    const firmware_io_t io = {board_write, board_counter_start, instructions,
                              "instructions (QEMU -icount shift=0: one per ns of virtual time)"};
    return firmware_run(&io, block, sizeof block);
}
