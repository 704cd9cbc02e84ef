/* EM in 2D: a robot drives twice around a 10 m square; the place recognizer closes a loop every
 * few poses of the second lap, and three times it is wrong. pgem_robust_optimize with
 * PGEM_KERNEL_EM weights every loop closure, prunes the ones the map cannot explain, and leaves
 * the weights and prune states on the edges, where this program reads them. */
#include <math.h>
#include <stdio.h>

#include <pgem/pgem.h>

#define LAP 40                 /* poses per lap: 4 sides of 10 one-metre steps */
#define POSES (2 * LAP + 1)    /* two laps, back at the start */
#define FALSE_LOOPS 3

static void step_truth(int k, double step[3])
{
    step[0] = 1.0; /* one metre forward, turning left at each corner */
    step[1] = 0.0;
    step[2] = k % 10 == 0 ? 1.5707963267948966 : 0.0;
}

int main(void)
{
    pgem_config_t config = {2, POSES, 2 * POSES, 0, 0, 0}; /* 2D; fill budget: the default */
    pgem_t *graph = NULL;
    if (pgem_create(&graph, &config) != PGEM_OK) {
        return 1;
    }
    /* Odometry: sigma 5 cm and 0.02 rad, so information 1 / sigma^2 on the diagonal. */
    const double information[9] = {400, 0, 0, 0, 400, 0, 0, 0, 2500};
    double truth[POSES][3] = {{0.0, 0.0, 0.0}};
    double guess[3] = {0.0, 0.0, 0.0};
    pgem_add_pose(graph, 0, guess);
    for (int k = 1; k < POSES; k++) {
        double step[3], measured[3];
        step_truth(k, step);
        pgem_se2_compose(truth[k - 1], step, truth[k]);
        /* what the wheel encoders report: the true step plus a little deterministic noise */
        measured[0] = step[0] + 0.03 * sin(1.3 * k);
        measured[1] = step[1] + 0.03 * cos(2.1 * k);
        measured[2] = step[2] + 0.01 * sin(0.7 * k);
        pgem_se2_compose(guess, measured, guess); /* initial guess: dead reckoning */
        pgem_add_pose(graph, (pgem_id_t)k, guess);
        pgem_add_edge(graph, (pgem_id_t)(k - 1), (pgem_id_t)k, measured, information,
                      PGEM_EDGE_ODOMETRY, NULL);
    }
    /* True loop closures: every 4th pose of lap 2 recognises the same place on lap 1. */
    for (int k = LAP + 4; k < POSES; k += 4) {
        double z[3];
        pgem_se2_between(truth[k], truth[k - LAP], z);
        pgem_add_edge(graph, (pgem_id_t)k, (pgem_id_t)(k - LAP), z, information, PGEM_EDGE_LOOP,
                      NULL);
    }
    /* False ones: perceptual aliasing claims "same place" (identity) for distant poses. */
    const int false_from[FALSE_LOOPS] = {46, 63, 75};
    const int false_to[FALSE_LOOPS] = {22, 9, 30};
    uint32_t false_index[FALSE_LOOPS];
    for (int f = 0; f < FALSE_LOOPS; f++) {
        const double same_place[3] = {0.0, 0.0, 0.0};
        pgem_add_edge(graph, (pgem_id_t)false_from[f], (pgem_id_t)false_to[f], same_place,
                      information, PGEM_EDGE_LOOP, &false_index[f]);
    }

    pgem_robust_options_t options = {0}; /* zero = the documented defaults: EM */
    pgem_robust_summary_t summary;
    if (pgem_robust_optimize(graph, &options, NULL, &summary) != PGEM_OK) {
        fprintf(stderr, "EM failed: %s\n", pgem_last_error(graph));
        pgem_destroy(graph);
        return 1;
    }
    printf("EM: %u rounds, %u E/M iterations, %u of %u loop closures pruned, chi2 %.3f -> %.3f\n",
           summary.rounds, summary.em_iterations, summary.pruned, summary.loops,
           summary.initial_chi2, summary.final_chi2);

    /* Every loop closure with its weight and state, read back from the graph. */
    unsigned false_pruned = 0, true_pruned = 0, true_loops = 0;
    for (uint32_t e = 0; e < pgem_edge_count(graph); e++) {
        pgem_edge_view_t edge;
        pgem_edge_at(graph, e, &edge);
        if (edge.kind != PGEM_EDGE_LOOP) {
            continue;
        }
        int is_false = 0;
        for (int f = 0; f < FALSE_LOOPS; f++) {
            is_false |= false_index[f] == e;
        }
        printf("loop %2u -> %2u  weight %.3f  %-8s%s\n", (unsigned)edge.from, (unsigned)edge.to,
               edge.weight, edge.active ? "accepted" : "pruned", is_false ? "  (false)" : "");
        false_pruned += is_false && !edge.active;
        true_pruned += !is_false && !edge.active;
        true_loops += !is_false;
    }
    printf("false loop closures pruned: %u of %d, true loop closures pruned: %u of %u\n",
           false_pruned, FALSE_LOOPS, true_pruned, true_loops);
    double end[3];
    pgem_pose(graph, POSES - 1, end);
    printf("last pose: x %.3f  y %.3f  (truth: 0, 0)\n", end[0], end[1]);
    pgem_destroy(graph);
    return false_pruned == FALSE_LOOPS && true_pruned == 0 ? 0 : 1;
}
