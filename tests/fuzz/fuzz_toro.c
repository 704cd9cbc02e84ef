/* Fuzz target: the TORO reader (pgem_io_read_stream with PGEM_FORMAT_TORO; TORO is 2D only,
 * VERTEX3 / EDGE3 count as unknown lines, see FORMATS.md), then load, a short solve and write
 * round trips of what it read (fuzz_reader.h lists the checks). */
#include "fuzz_reader.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_reader_run(data, size, PGEM_FORMAT_TORO, "fuzz.graph");
    return 0;
}

/* Hand-written seeds: vertices and edges (information in TORO's xx xy yy tt xt yt order), an
 * edge-only file with EQUIV lines, and newer-to-older edges as w100.graph writes them. */
static const char *const seeds[] = {
    "VERTEX2 0 0 0 0\n"
    "VERTEX2 1 1 0 0\n"
    "VERTEX2 2 2 0 0.2\n"
    "EDGE2 0 1 1 0 0 100 0 100 400 0 0\n"
    "EDGE2 1 2 1 0 0.2 100 1 100 400 2 3\n"
    "EDGE2 0 2 2 0.1 0.2 50 0 50 200 0 0\n",

    "EQUIV 0 1\n"
    "EDGE2 3 4 1 0 0 1 0 1 1 0 0\r\n"
    "EDGE2 4 5 1 0 1.5708 1 0 1 1 0 0\n"
    "EDGE2 5 3 -1 1 1.5708 1 0 1 1 0 0\n"
    "VERTEX3 0 0 0 0 0 0 0\n",

    "VERTEX2 2 2 0 3.1\n"
    "VERTEX2 1 1 0 0\n"
    "VERTEX2 0 0 0 0\n"
    "EDGE2 2 1 -1 0 -3.1 20 0 20 50 0 0\n"
    "EDGE2 1 0 -1 0 0 20 0 20 50 0 0\n"
    "# a comment\n"
    "EDGE2 2 0 -2 0.5 3.1 5 0.1 5 10 0.01 0.02\n",
};

size_t fuzz_seed(unsigned index, uint8_t *buffer, size_t capacity)
{
    return fuzz_reader_seed(seeds, sizeof seeds / sizeof seeds[0], index, buffer, capacity);
}
