/* Links against an installed pgem and solves a three-pose triangle. */
#include <stdio.h>

#include <pgem/pgem.h>

int main(void)
{
    pgem_config_t config = {2, 3, 3, 0, 0, 0};
    pgem_t *graph = NULL;
    double information[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double poses[3][3] = {{0, 0, 0}, {1.1, 0.1, 1.6}, {0.9, 1.2, 3.0}};
    double steps[3][3] = {{1, 0, 1.5707963267948966}, {1, 0, 1.5707963267948966},
                          {1.4142135623730951, 0, 2.356194490192345}};
    if (pgem_create(&graph, &config) != PGEM_OK) {
        return 1;
    }
    for (int k = 0; k < 3; k++) {
        pgem_add_pose(graph, (pgem_id_t)k, poses[k]);
    }
    pgem_add_edge(graph, 0, 1, steps[0], information, PGEM_EDGE_ODOMETRY, NULL);
    pgem_add_edge(graph, 1, 2, steps[1], information, PGEM_EDGE_ODOMETRY, NULL);
    pgem_add_edge(graph, 2, 0, steps[2], information, PGEM_EDGE_LOOP, NULL);
    pgem_summary_t summary;
    int status = pgem_optimize(graph, NULL, &summary);
    printf("consumer: %s, chi2 %.3g -> %.3g\n", pgem_error_name(status), summary.initial_chi2,
           summary.final_chi2);
    pgem_destroy(graph);
    return status == PGEM_OK && summary.final_chi2 < summary.initial_chi2 ? 0 : 1;
}
