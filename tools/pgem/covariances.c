/* pgem optimize --covariances: every pose's marginal covariance at the result, one line per
 * pose, "id" then the upper triangle row by row (6 numbers in 2D, 21 in 3D; FORMATS.md). */
#include <stdio.h>
#include <stdlib.h>

#include "cli.h"
#include "covariances.h"

double *pgem_cli_covariances(pgem_t *graph, double *seconds)
{
    const int n = PGEM_TANGENT_SIZE(pgem_dimension(graph));
    const double start = pgem_cli_now();
    double *covariances = malloc((size_t)pgem_pose_count(graph) * (size_t)(n * n) * sizeof(double) + 1u);
    if (covariances == NULL) {
        fprintf(stderr, "pgem: no memory for %u poses' covariances\n", pgem_pose_count(graph));
        return NULL;
    }
    int status = pgem_covariance_prepare(graph);
    if (status == PGEM_OK) {
        status = pgem_covariances(graph, covariances);
    }
    if (status != PGEM_OK) {
        fprintf(stderr, "pgem: covariances failed: %s\n", pgem_last_error(graph));
        free(covariances);
        return NULL;
    }
    *seconds = pgem_cli_now() - start;
    return covariances;
}

int pgem_cli_write_covariances(const pgem_t *graph, const double *covariances, const char *path)
{
    const int n = PGEM_TANGENT_SIZE(pgem_dimension(graph));
    pgem_cli_file_t file;
    if (pgem_cli_file_open(&file, "pgem", path) != 0) {
        return PGEM_EXIT_IO;
    }
    int failed = 0;
    for (uint32_t p = 0; p < pgem_pose_count(graph) && !failed; p++) {
        pgem_id_t id = 0;
        (void)pgem_pose_at(graph, p, &id, NULL, NULL);
        const double *block = covariances + (size_t)p * (size_t)(n * n);
        failed |= fprintf(file.stream, "%llu", (unsigned long long)id) < 0;
        for (int i = 0; i < n; i++) {
            for (int j = i; j < n; j++) {
                failed |= fprintf(file.stream, " %.12g", block[i * n + j]) < 0;
            }
        }
        failed |= fputc('\n', file.stream) == EOF;
    }
    return pgem_cli_file_commit(&file, failed);
}
