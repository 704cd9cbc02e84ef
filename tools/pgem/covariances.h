/* pgem optimize --covariances (covariances.c). */
#ifndef PGEM_CLI_COVARIANCES_H
#define PGEM_CLI_COVARIANCES_H

#include "pgem/pgem.h"

/* Every pose's covariance at the current estimate (pose_count blocks of n x n, heap; free it),
 * and the seconds the factor and the inverse took; NULL after printing why. */
double *pgem_cli_covariances(pgem_t *graph, double *seconds);

/* One line per pose, "id" and the upper triangle of its covariance (%.12g), written whole or
 * not at all. Returns a PGEM_EXIT_* code (printing the error). */
int pgem_cli_write_covariances(const pgem_t *graph, const double *covariances, const char *path);

#endif /* PGEM_CLI_COVARIANCES_H */
