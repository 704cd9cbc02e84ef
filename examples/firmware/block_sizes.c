/* Prints the pgem block size for given capacities: pgem_memory_size on this machine and the
 * compile-time bound PGEM_MEMORY_BOUND (which also covers 32-bit targets).
 *   block_sizes                      the table of docs/FIRMWARE.md
 *   block_sizes DIM POSES EDGES FILL one configuration
 *   block_sizes --per-item           the bytes one more pose, edge or factor value takes (the
 *                                    figure docs/design/memory.md and docs/FIRMWARE.md quote);
 *                                    exit 1 if one exceeds what PGEM_MEMORY_BOUND allows for it */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <pgem/pgem.h>

static void row(int dimension, unsigned poses, unsigned edges, unsigned fill)
{
    const pgem_config_t config = {dimension, poses, edges, fill, 0, 0};
    const size_t exact = pgem_memory_size(&config);
    const size_t bound = PGEM_MEMORY_BOUND(dimension, poses, edges, fill);
    printf("| %dD | %u | %u | %u | %zu (%.1f KiB) | %zu (%.1f KiB) |\n", dimension, poses, edges,
           fill, exact, (double)exact / 1024.0, bound, (double)bound / 1024.0);
}

/* The capacities the per-item figures are measured at: a large graph, so that the fixed costs
 * (the instance, alignment, the workspace's floor) are out of the differences. */
#define ITEM_POSES 40000u
#define ITEM_EDGES 60000u
#define ITEM_FILL 4000000u
#define ITEM_STEP 4000u

static size_t item_size(int dimension, unsigned poses, unsigned edges, unsigned fill)
{
    const pgem_config_t config = {dimension, poses, edges, fill, 0, 0};
    return pgem_memory_size(&config);
}

/* pgem_memory_size's growth per pose, edge and factor value at the capacities above, and the
 * same for PGEM_MEMORY_BOUND; 1 if the exact growth is within the bound's, else 0. */
static int per_item(int dimension)
{
    const unsigned p = ITEM_POSES, e = ITEM_EDGES, f = ITEM_FILL, s = ITEM_STEP;
    const size_t base = item_size(dimension, p, e, f);
    const double pose = (double)(item_size(dimension, p + s, e, f) - base) / s;
    const double edge = (double)(item_size(dimension, p, e + s, f) - base) / s;
    const double fill = (double)(item_size(dimension, p, e, f + s) - base) / s;
    const size_t bound = PGEM_MEMORY_BOUND(dimension, p, e, f);
    const double bound_pose = (double)(PGEM_MEMORY_BOUND(dimension, p + s, e, f) - bound) / s;
    const double bound_edge = (double)(PGEM_MEMORY_BOUND(dimension, p, e + s, f) - bound) / s;
    printf("%dD: %.1f bytes per pose, %.1f per edge, %.2f per factor value (bound %.1f, %.1f)\n",
           dimension, pose, edge, fill, bound_pose, bound_edge);
    return pose <= bound_pose && edge <= bound_edge;
}

int main(int argc, char **argv)
{
    if (argc == 2 && strcmp(argv[1], "--per-item") == 0) {
        printf("pgem_memory_size per item at %u poses, %u edges, %u factor values, one worker\n",
               ITEM_POSES, ITEM_EDGES, ITEM_FILL);
        const int ok2 = per_item(2);
        const int ok3 = per_item(3);
        return ok2 && ok3 ? 0 : 1;
    }
    printf("| dimension | poses | edges | fill_budget | pgem_memory_size (this machine) | "
           "PGEM_MEMORY_BOUND |\n|---|---|---|---|---|---|\n");
    if (argc == 5) {
        row(atoi(argv[1]), (unsigned)strtoul(argv[2], NULL, 10),
            (unsigned)strtoul(argv[3], NULL, 10), (unsigned)strtoul(argv[4], NULL, 10));
        return 0;
    }
    if (argc != 1) {
        fprintf(stderr, "usage: block_sizes [DIM POSES EDGES FILL | --per-item]\n");
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
