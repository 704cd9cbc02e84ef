/* Quick start: a square walk with one loop closure, optimized in a caller-owned buffer. */
#include <stdio.h>

#include <pgem/pgem.h>

static unsigned char block[64 * 1024]; /* all the memory pgem will ever use */

int main(void)
{
    pgem_config_t config = {2, 16, 32, 2048, 1, 0}; /* 2D, 16 poses, 32 edges, 2048 factor nonzeros, 1 worker */
    pgem_t *graph = NULL;
    const int status = pgem_init(&graph, &config, block, sizeof block);
    if (status != PGEM_OK) { /* PGEM_ERR_BUFFER_TOO_SMALL if the block is too small */
        fprintf(stderr, "pgem_init: %s\n", pgem_error_name(status));
        return 1;
    }
    const double odometry[3] = {1.0, 0.0, 1.5707963267948966}; /* 1 m forward, turn left */
    const double information[9] = {100, 0, 0, 0, 100, 0, 0, 0, 400};
    const double drifting[3] = {1.05, 0.02, 1.62};                /* what dead reckoning saw */
    double guess[3] = {0.0, 0.0, 0.0};
    pgem_add_pose(graph, 0, guess);
    for (pgem_id_t id = 1; id <= 4; id++) {
        pgem_se2_compose(guess, drifting, guess); /* initial guess: drifting dead reckoning */
        pgem_add_pose(graph, id, guess);
        pgem_add_edge(graph, id - 1, id, odometry, information, PGEM_EDGE_ODOMETRY, NULL);
    }
    const double back_home[3] = {0.0, 0.0, 0.0}; /* pose 4 is where pose 0 was */
    if (pgem_add_edge(graph, 4, 0, back_home, information, PGEM_EDGE_LOOP, NULL) != PGEM_OK) {
        fprintf(stderr, "%s\n", pgem_last_error(graph));
        return 1;
    }
    pgem_summary_t summary;
    if (pgem_optimize(graph, NULL, &summary) != PGEM_OK) {
        fprintf(stderr, "optimize failed: %s\n", pgem_last_error(graph));
        return 1;
    }
    printf("chi2 %.3f -> %.6f after %u iterations (%s)\n", summary.initial_chi2,
           summary.final_chi2, summary.iterations, pgem_termination_name(summary.termination));
    for (pgem_id_t id = 0; id <= 4; id++) {
        double pose[3];
        pgem_pose(graph, id, pose);
        printf("pose %u: x %6.3f  y %6.3f  theta %6.3f\n", (unsigned)id, pose[0], pose[1], pose[2]);
    }
    return summary.final_chi2 < 1e-9 ? 0 : 1;
}
