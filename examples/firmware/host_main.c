/* The firmware example on a hosted machine (x86-64, aarch64): the same job as the Cortex-M7
 * image, its report on stdout, for CTest to compare with what QEMU printed. */
#include <stdio.h>

#include "firmware_run.h"

static unsigned char block[FIRMWARE_BLOCK_BYTES];

static void host_write(const char *text, size_t length)
{
    fwrite(text, 1, length, stdout);
}

int main(void)
{
    const firmware_io_t io = {host_write, NULL, NULL, ""};
    return firmware_run(&io, block, sizeof block);
}
