/* Helpers of the command-line tool: clock, option values, loading and writing graphs. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "cli.h"

double pgem_cli_now(void)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

int pgem_cli_parse_u32(const char *option, const char *text, uint32_t *value)
{
    char *end = NULL;
    errno = 0;
    unsigned long parsed = text != NULL ? strtoul(text, &end, 10) : 0;
    if (text == NULL || *text == '\0' || *text == '-' || *end != '\0' || errno != 0 ||
        parsed > UINT32_MAX) {
        fprintf(stderr, "pgem: %s needs a non-negative integer, got '%s'\n", option,
                text != NULL ? text : "");
        return 0;
    }
    *value = (uint32_t)parsed;
    return 1;
}

static int pgem_cli_try_load(const pgem_io_graph_t *file, const pgem_config_t *config,
                             pgem_t **instance)
{
    char message[1024];
    int status = pgem_create(instance, config);
    if (status != PGEM_OK) {
        fprintf(stderr, "pgem: cannot create an instance: %s\n", pgem_error_description(status));
        return status;
    }
    status = pgem_io_load(file, *instance, message, sizeof message);
    if (status != PGEM_OK) {
        fprintf(stderr, "pgem: %s\n", message);
        pgem_destroy(*instance);
        *instance = NULL;
    }
    return status;
}

/* Recreates *instance with a fill budget of exactly `fill` and re-analyses it. */
static int pgem_cli_resize(const pgem_io_graph_t *file, pgem_config_t *config, uint32_t fill,
                           pgem_t **instance)
{
    pgem_destroy(*instance);
    *instance = NULL;
    config->fill_budget = fill;
    int status = pgem_cli_try_load(file, config, instance);
    return status == PGEM_OK ? pgem_analyze(*instance) : status;
}

int pgem_cli_load(const pgem_io_graph_t *file, const char *path, pgem_t **instance)
{
    pgem_config_t config;
    pgem_io_config(file, &config);
    int status = pgem_cli_try_load(file, &config, instance);
    if (status != PGEM_OK || pgem_edge_count(*instance) == 0u) {
        return status;
    }
    /* The factor's size is known only after the analysis: size the block to exactly it. */
    status = pgem_analyze(*instance);
    pgem_memory_stats_t stats;
    pgem_get_memory_stats(*instance, &stats);
    if (status == PGEM_ERR_FILL_BUDGET ||
        (status == PGEM_OK && stats.factor_nonzeros < stats.factor_budget - stats.factor_budget / 4u)) {
        status = pgem_cli_resize(file, &config, stats.factor_nonzeros, instance);
    }
    if (status != PGEM_OK && *instance != NULL) {
        fprintf(stderr, "pgem: %s: %s\n", path, pgem_last_error(*instance));
    }
    return status;
}

int pgem_cli_write(const pgem_t *instance, const char *path)
{
    pgem_io_graph_t out = {0};
    char message[1024];
    int status = pgem_io_from_instance(instance, &out);
    if (status == PGEM_OK) {
        status = pgem_io_write(path, PGEM_FORMAT_G2O, &out, message, sizeof message);
        if (status != PGEM_OK) {
            fprintf(stderr, "pgem: %s\n", message);
        }
    } else {
        fprintf(stderr, "pgem: cannot copy the graph for writing: %s\n", pgem_error_description(status));
    }
    pgem_io_graph_free(&out);
    return status;
}
