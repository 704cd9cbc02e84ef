/* Static buffer: every byte pgem uses is one static array sized at compile time; nothing is
 * malloc'd by this program or by pgem_init, adding or solving. Links only pgem::core.
 *
 * How to size the block: PGEM_MEMORY_BOUND(dimension, poses, edges, fill_budget) is a
 * compile-time upper bound (used below); pgem_memory_size(&config) gives the exact number of
 * bytes at run time (this program prints both). Roughly:
 *   2D: 437 bytes per pose + 231 per edge + 8.4 per factor nonzero (fill_budget)
 *   3D: 997 bytes per pose + 695 per edge + 8.1 per factor nonzero
 * Either way pgem_init checks at run time: it refuses a block smaller than the configuration
 * needs (PGEM_ERR_BUFFER_TOO_SMALL), so a config change that outgrows the block is caught there.
 * How to size fill_budget: after a solve, pgem_memory_use() reports the factor's nonzeros
 * (a solve that needs more fails with PGEM_ERR_FILL_BUDGET and the message gives the number).
 *
 * One caveat with the system CSparse: its symbolic analysis (first solve after the graph
 * changes) mallocs and frees its own workspace. Built from source (PGEM_CSPARSE_SOURCE_DIR, as
 * the firmware build does) it draws from the block instead;
 * docs/design/csparse-and-exhaustion.md explains both. */
#include <stdio.h>

#include <pgem/pgem.h>

#define SIDE 8                          /* an 8 x 8 lawnmower sweep: 64 poses */
#define MAX_POSES (SIDE * SIDE)
#define MAX_EDGES (2 * MAX_POSES)
#define FILL_BUDGET 4096                /* factor nonzeros (the default would be 32 * 9 * 64) */
#define BLOCK_BYTES PGEM_MEMORY_BOUND(2, MAX_POSES, MAX_EDGES, FILL_BUDGET)

static unsigned char block[BLOCK_BYTES]; /* all the memory pgem will ever use */

/* Index of the pose at (row, column) of the sweep: rows alternate direction, one metre apart. */
static int at(int row, int column)
{
    return row * SIDE + (row % 2 == 0 ? column : SIDE - 1 - column);
}

int main(void)
{
    const pgem_config_t config = {2, MAX_POSES, MAX_EDGES, FILL_BUDGET, 0, 0};
    const size_t needed = pgem_memory_size(&config);
    printf("block: %zu bytes needed, %zu reserved\n", needed, sizeof block);
    pgem_t *graph = NULL;
    const int status = pgem_init(&graph, &config, block, sizeof block);
    if (status != PGEM_OK) { /* BUFFER_TOO_SMALL: raise BLOCK_BYTES; CONFIG: a bad capacity */
        fprintf(stderr, "pgem_init: %s\n", pgem_error_name(status));
        return 1;
    }

    const double information[9] = {100, 0, 0, 0, 100, 0, 0, 0, 100};
    double truth[MAX_POSES][3]; /* heading 0 throughout: the robot strafes, for brevity */
    for (int row = 0; row < SIDE; row++) {
        for (int column = 0; column < SIDE; column++) {
            double *pose = truth[at(row, column)];
            pose[0] = column;
            pose[1] = row;
            pose[2] = 0.0;
        }
    }
    for (int k = 0; k < MAX_POSES; k++) {
        double guess[3] = {truth[k][0] * 1.02, truth[k][1] * 0.97 + 0.01 * k, 0.002 * k};
        pgem_add_pose(graph, (pgem_id_t)k, guess); /* a distorted initial guess */
    }
    for (int k = 0; k < MAX_POSES; k++) {
        double z[3];
        if (k > 0) { /* odometry along the sweep */
            pgem_se2_between(truth[k - 1], truth[k], z);
            pgem_add_edge(graph, (pgem_id_t)(k - 1), (pgem_id_t)k, z, information,
                          PGEM_EDGE_ODOMETRY, NULL);
        }
        /* loop closures: each pose sees its neighbour in the previous row (where that
         * neighbour is not already its odometry predecessor) */
        const int row = k / SIDE, column = (int)truth[k][0];
        const int below = row > 0 ? at(row - 1, column) : -1;
        if (below >= 0 && below != k - 1) {
            pgem_se2_between(truth[below], truth[k], z);
            pgem_add_edge(graph, (pgem_id_t)below, (pgem_id_t)k, z, information, PGEM_EDGE_LOOP,
                          NULL);
        }
    }

    pgem_solve_options_t options = {0};
    options.method = PGEM_LEVENBERG_MARQUARDT;
    pgem_summary_t summary;
    if (pgem_optimize(graph, &options, &summary) != PGEM_OK) {
        fprintf(stderr, "optimize failed: %s\n", pgem_last_error(graph));
        return 1;
    }
    pgem_memory_stats_t stats;
    pgem_memory_use(graph, &stats);
    printf("%u poses, %u edges: chi2 %.3f -> %.6f after %u iterations (%s, %s)\n",
           pgem_pose_count(graph), pgem_edge_count(graph), summary.initial_chi2,
           summary.final_chi2, summary.iterations, pgem_method_name(options.method),
           pgem_termination_name(summary.termination));
    printf("factor: %u of %u budgeted nonzeros; %zu of %zu block bytes used\n",
           stats.factor_nonzeros, stats.factor_budget, stats.used_bytes, stats.block_bytes);
    const int corner = at(SIDE - 1, SIDE - 1); /* the far corner */
    double pose[3];
    pgem_pose(graph, (pgem_id_t)corner, pose);
    printf("pose %d: x %.3f  y %.3f  (truth: %.0f, %.0f)\n", corner, pose[0], pose[1],
           truth[corner][0], truth[corner][1]);
    return summary.final_chi2 < 1e-9 ? 0 : 1;
}
