/* Prints the pgem block size for given capacities: pgem_memory_size on this machine and the
 * compile-time bound PGEM_MEMORY_BOUND (which also covers 32-bit targets).
 *   block_sizes                      the README's table
 *   block_sizes DIM POSES EDGES FILL one configuration */
#include <stdio.h>
#include <stdlib.h>

#include <pgem/pgem.h>

static void row(int dimension, unsigned poses, unsigned edges, unsigned fill)
{
    const pgem_config_t config = {dimension, poses, edges, fill, 0, 0};
    const size_t exact = pgem_memory_size(&config);
    const size_t bound = PGEM_MEMORY_BOUND(dimension, poses, edges, fill);
    printf("| %dD | %u | %u | %u | %zu (%.1f KiB) | %zu (%.1f KiB) |\n", dimension, poses, edges,
           fill, exact, (double)exact / 1024.0, bound, (double)bound / 1024.0);
}

int main(int argc, char **argv)
{
    printf("| dimension | poses | edges | fill_budget | pgem_memory_size (this machine) | "
           "PGEM_MEMORY_BOUND |\n|---|---|---|---|---|---|\n");
    if (argc == 5) {
        row(atoi(argv[1]), (unsigned)strtoul(argv[2], NULL, 10),
            (unsigned)strtoul(argv[3], NULL, 10), (unsigned)strtoul(argv[4], NULL, 10));
        return 0;
    }
    if (argc != 1) {
        fprintf(stderr, "usage: block_sizes [DIM POSES EDGES FILL]\n");
        return 2;
    }
    /* edges = 1.2 x poses; fill = 34 nonzeros per pose in 2D (the firmware example's graph
     * needs 24 with every false loop still in the structure), 150 in 3D */
    const unsigned sizes[] = {250, 500, 1000};
    for (int k = 0; k < 3; k++) {
        row(2, sizes[k], sizes[k] * 6 / 5, sizes[k] * 34);
    }
    row(3, 250, 300, 250 * 150);
    return 0;
}
