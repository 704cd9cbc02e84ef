/* Five poses around a square, a true loop closure home and a false one; EM weighs both. */
#include <pgem/pgem.h>
#include <stdio.h>

int main(void)
{
    pgem_config_t config = {2, 5, 6, 0, 0, 0}; /* 2D, 5 poses, 6 edges, default fill budget */
    pgem_t *graph = NULL;
    if (pgem_create(&graph, &config) != PGEM_OK) {
        return 1;
    }
    const double information[9] = {100, 0, 0, 0, 100, 0, 0, 0, 400};
    const double step[3] = {1.0, 0.0, 1.5707963267948966}; /* 1 m forward, turn left */
    const double same_place[3] = {0.0, 0.0, 0.0};
    double guess[3] = {0.0, 0.0, 0.0}; /* the odometry composed */
    pgem_add_pose(graph, 0, guess);
    for (pgem_id_t id = 1; id <= 4; id++) {
        pgem_se2_compose(guess, step, guess);
        pgem_add_pose(graph, id, guess);
        pgem_add_edge(graph, id - 1, id, step, information, PGEM_EDGE_ODOMETRY, NULL);
    }
    pgem_add_edge(graph, 4, 0, same_place, information, PGEM_EDGE_LOOP, NULL); /* true */
    pgem_add_edge(graph, 3, 1, same_place, information, PGEM_EDGE_LOOP, NULL); /* false */
    if (pgem_robust_optimize(graph, NULL, NULL, NULL) != PGEM_OK) { /* NULL options: EM */
        fprintf(stderr, "EM failed: %s\n", pgem_last_error(graph));
        return 1;
    }
    for (uint32_t k = 4; k < pgem_edge_count(graph); k++) { /* the loops, after 4 odometry */
        pgem_edge_view_t edge;
        double weight = 0.0;
        pgem_loop_state_t state = PGEM_LOOP_ACCEPTED;
        pgem_edge_at(graph, k, &edge);
        pgem_loop_weight(graph, k, &weight);
        pgem_loop_state(graph, k, &state);
        printf("loop %u -> %u: weight %.3f, %s\n", (unsigned)edge.from, (unsigned)edge.to, weight,
               state == PGEM_LOOP_PRUNED ? "pruned" : "accepted");
    }
    pgem_destroy(graph);
    return 0;
}
