/* Fuzz target: the g2o reader (pgem_io_read_stream with PGEM_FORMAT_G2O), then load, a short
 * solve and write round trips of what it read (fuzz_reader.h lists the checks). */
#include "fuzz_reader.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_reader_run(data, size, PGEM_FORMAT_G2O, "fuzz.g2o");
    return 0;
}

/* Hand-written seeds: 2D with loop closures and FIX, 3D, an edge-only file (poses guessed
 * along the chain), and lines the reader counts or skips. */
static const char *const seeds[] = {
    "VERTEX_SE2 0 0 0 0\n"
    "VERTEX_SE2 1 1 0 0\n"
    "VERTEX_SE2 2 2 0.1 0.05\n"
    "VERTEX_SE2 3 2 1 1.57\n"
    "FIX 0\n"
    "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 400\n"
    "EDGE_SE2 1 2 1 0 0 100 0 0 100 0 400\n"
    "EDGE_SE2 2 3 0 1 1.5708 100 0 0 100 0 400\n"
    "EDGE_SE2 3 0 -2 1 1.5708 50 1 0 50 0 200\n"
    "EDGE_SE2 0 2 9 -4 2 50 0 0 50 0 200\n",

    "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\n"
    "VERTEX_SE3:QUAT 1 1 0 0 0 0 0.0998 0.995\n"
    "VERTEX_SE3:QUAT 2 2 0.2 0 0 0 0.1987 0.9801\n"
    "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0.0998 0.995 100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 "
    "400\n"
    "EDGE_SE3:QUAT 1 2 1 0.1 0 0 0 0.0998 0.995 100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 "
    "0 400\n"
    "EDGE_SE3:QUAT 2 0 -2 0 0 0 0 -0.1987 0.9801 10 0 0 0 0 0 10 0 0 0 0 10 0 0 0 40 0 0 40 0 "
    "40\n",

    "# edges only: the reader composes the poses\n"
    "EDGE_SE2 5 6 1 0 0.1 1 0 0 1 0 1\n"
    "EDGE_SE2 7 6 -1 0 -0.1 1 0 0 1 0 1\n"
    "EDGE_SE2 5 9 3 0.5 0.3 1 0 0 1 0 1\r\n"
    "EDGE_SE2 12 13 1 0 0 1 0 0 1 0 1\n"
    "FIX 5 12\n",

    "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n"
    "\n"
    "VERTEX_SE2\t8430738502437568512 1e-310 -0 3.14159\n"
    "VERTEX_SE2 8430738502437568513 1.5e3 2E-2 -9.42\n"
    "EDGE_SE2 8430738502437568512 8430738502437568513 1 2 3 1 0.5 0 2 0 1\n"
    "VERTEX_XY 3 1 2\n",
};

size_t fuzz_seed(unsigned index, uint8_t *buffer, size_t capacity)
{
    return fuzz_reader_seed(seeds, sizeof seeds / sizeof seeds[0], index, buffer, capacity);
}
