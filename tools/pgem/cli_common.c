/* Helpers of the command-line tool: clock, option values, loading and writing graphs. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
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

int pgem_cli_parse_kernel(const char *text, pgem_kernel_t *kernel)
{
    static const pgem_kernel_t kernels[] = {PGEM_KERNEL_NONE, PGEM_KERNEL_EM, PGEM_KERNEL_CAUCHY,
                                            PGEM_KERNEL_HUBER, PGEM_KERNEL_DCS};
    for (size_t k = 0; text != NULL && k < sizeof kernels / sizeof kernels[0]; k++) {
        if (strcmp(text, pgem_kernel_name(kernels[k])) == 0) {
            *kernel = kernels[k];
            return 1;
        }
    }
    fprintf(stderr, "pgem: --robust takes em, cauchy, huber, dcs or none (got '%s')\n",
            text != NULL ? text : "");
    return 0;
}

int pgem_cli_parse_positive(const char *option, const char *text, double *value)
{
    char *end = NULL;
    double parsed = text != NULL ? strtod(text, &end) : -1.0;
    if (text == NULL || end == text || *end != '\0' || !(parsed > 0.0) || !isfinite(parsed)) {
        fprintf(stderr, "pgem: %s needs a positive number, got '%s'\n", option, text != NULL ? text : "");
        return 0;
    }
    *value = parsed;
    return 1;
}

int pgem_cli_write_weights(const pgem_t *instance, const char *path)
{
    FILE *file = fopen(path, "w");
    if (file == NULL) {
        fprintf(stderr, "pgem: %s: cannot open for writing: %s\n", path, strerror(errno));
        return -1;
    }
    fprintf(file, "# from to weight state (one line per loop closure)\n");
    for (uint32_t k = 0; k < pgem_edge_count(instance); k++) {
        pgem_edge_view_t edge;
        pgem_edge_at(instance, k, &edge);
        if (edge.kind == PGEM_EDGE_LOOP) {
            fprintf(file, "%llu %llu %.9g %s\n", (unsigned long long)edge.from,
                    (unsigned long long)edge.to, edge.weight, edge.active ? "accepted" : "pruned");
        }
    }
    if (fclose(file) != 0) {
        fprintf(stderr, "pgem: %s: write failed: %s\n", path, strerror(errno));
        return -1;
    }
    return 0;
}

double pgem_cli_uniform(uint64_t *state)
{
    uint64_t z = (*state += UINT64_C(0x9e3779b97f4a7c15));
    z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
    z ^= z >> 31;
    return (double)(z >> 11) * (1.0 / 9007199254740992.0);
}

double pgem_cli_gaussian(uint64_t *state)
{
    double u = pgem_cli_uniform(state), v = pgem_cli_uniform(state);
    return sqrt(-2.0 * log(u + 1e-300)) * cos(6.283185307179586 * v);
}

void pgem_cli_json_string(const char *text)
{
    putchar('"');
    for (const unsigned char *c = (const unsigned char *)text; *c != '\0'; c++) {
        if (*c == '"' || *c == '\\') {
            printf("\\%c", *c);
        } else if (*c < 0x20u) {
            printf("\\u%04x", (unsigned)*c);
        } else {
            putchar(*c);
        }
    }
    putchar('"');
}
