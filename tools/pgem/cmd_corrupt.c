/* pgem corrupt: appends false loop closures to a graph under the four policies of Suenderhauf
 * & Protzel (random, local, random-grouped, local-grouped) and lists them in OUT.outliers. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"

#define CORRUPT_LOCAL_SPAN 20 /* local policies: second pose within 20 ids of the first */

typedef enum corrupt_policy { CORRUPT_RANDOM, CORRUPT_LOCAL, CORRUPT_RANDOM_GROUPED, CORRUPT_LOCAL_GROUPED } corrupt_policy_t;

/* Command-line choices of one corruption. */
typedef struct corrupt_args {
    const char *input;           /* clean graph */
    const char *output;          /* corrupted graph; OUTPUT.outliers lists the false pairs */
    corrupt_policy_t policy;     /* how the pairs are drawn */
    uint32_t count;              /* false loops to add */
    uint32_t group_size;         /* consecutive loops per group (grouped policies) */
    uint32_t seed;               /* random seed */
    const char *information;     /* --information text, or NULL: copy the first loop's */
} corrupt_args_t;

static const char *const corrupt_policy_names[] = {"random", "local", "random-grouped", "local-grouped"};

static size_t corrupt_index(uint64_t *state, size_t count)
{
    size_t index = (size_t)(pgem_cli_uniform(state) * (double)count);
    return index < count ? index : count - 1u;
}

static void corrupt_help(FILE *out)
{
    fprintf(out,
            "usage: pgem corrupt IN -o OUT --policy random|local|random-grouped|local-grouped\n"
            "                    --count K [--group-size G] --seed S [--information V]\n"
            "\n"
            "Appends K false loop closures after the original edges (the protocol of Suenderhauf &\n"
            "Protzel): random joins two uniformly random poses, local a pose and one within %d\n"
            "ids of it; the grouped policies add groups of G (default 10) consecutive, mutually\n"
            "consistent false loops. Each false measurement is a random pose (translation\n"
            "uniform in +-10 m, any rotation); information is copied from the file's first loop\n"
            "closure (or its first edge), or given with --information V: one number (a diagonal\n"
            "matrix) or the upper triangle row by row as in g2o (6 numbers in 2D, 21 in 3D),\n"
            "separated by commas. Writes OUT and OUT.outliers (one 'from to' per line).\n"
            "The same input and seed always give the same output.\n",
            CORRUPT_LOCAL_SPAN);
}

static int corrupt_parse(int argc, char **argv, corrupt_args_t *args)
{
    *args = (corrupt_args_t){NULL, NULL, CORRUPT_RANDOM, 0u, 10u, 0u, NULL};
    int have_policy = 0, have_count = 0, have_seed = 0;
    for (int k = 1; k < argc; k++) {
        const char *arg = argv[k], *value = k + 1 < argc ? argv[k + 1] : NULL;
        if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            corrupt_help(stdout);
            return -1;
        }
        if (arg[0] != '-') {
            if (args->input != NULL) {
                fprintf(stderr, "pgem corrupt: more than one input file ('%s')\n", arg);
                return PGEM_EXIT_USAGE;
            }
            args->input = arg;
            continue;
        }
        int ok = value != NULL;
        if (ok && strcmp(arg, "-o") == 0) {
            args->output = value;
        } else if (ok && strcmp(arg, "--policy") == 0) {
            ok = 0;
            for (int p = 0; p < 4; p++) {
                if (strcmp(value, corrupt_policy_names[p]) == 0) {
                    args->policy = (corrupt_policy_t)p;
                    ok = have_policy = 1;
                }
            }
            if (!ok) {
                fprintf(stderr, "pgem corrupt: --policy takes random, local, random-grouped or local-grouped\n");
            }
        } else if (ok && strcmp(arg, "--count") == 0) {
            ok = have_count = pgem_cli_parse_u32("pgem", arg, value, &args->count);
        } else if (ok && strcmp(arg, "--group-size") == 0) {
            ok = pgem_cli_parse_at_least("pgem corrupt", arg, value, 1u, "loop", &args->group_size);
        } else if (ok && strcmp(arg, "--information") == 0) {
            args->information = value;
        } else if (ok && strcmp(arg, "--seed") == 0) {
            ok = have_seed = pgem_cli_parse_u32("pgem", arg, value, &args->seed);
        } else {
            fprintf(stderr, "pgem corrupt: unknown or incomplete option '%s' (see --help)\n", arg);
            ok = 0;
        }
        if (!ok) {
            return PGEM_EXIT_USAGE;
        }
        k++;
    }
    if (args->input == NULL || args->output == NULL || !have_policy || !have_count || !have_seed) {
        fprintf(stderr, "pgem corrupt: IN, -o OUT, --policy, --count and --seed are required\n");
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

/* A random relative pose: translation uniform in +-10 m, rotation uniform. */
static void corrupt_measurement(uint64_t *rng, int dimension, double *measurement)
{
    for (int d = 0; d < 3; d++) {
        measurement[d] = 20.0 * pgem_cli_uniform(rng) - 10.0;
    }
    if (dimension == 2) {
        measurement[2] = pgem_wrap_angle(6.283185307179586 * pgem_cli_uniform(rng));
        return;
    }
    double q[4], norm = 0.0;
    do { /* uniform on the unit 3-sphere by rejection */
        norm = 0.0;
        for (int d = 0; d < 4; d++) {
            q[d] = 2.0 * pgem_cli_uniform(rng) - 1.0;
            norm += q[d] * q[d];
        }
    } while (norm > 1.0 || norm < 1e-6);
    pgem_quat_normalize(q);
    memcpy(measurement + 3, q, sizeof q);
}

/* The first pose of a pair and its partner, by policy (indices into the pose list). */
static void corrupt_pair(uint64_t *rng, const corrupt_args_t *args, size_t poses, size_t span,
                         size_t *first, size_t *second)
{
    int local = args->policy == CORRUPT_LOCAL || args->policy == CORRUPT_LOCAL_GROUPED;
    do {
        *first = corrupt_index(rng, poses - span + 1u);
        if (local) {
            size_t reach = CORRUPT_LOCAL_SPAN < poses - span ? CORRUPT_LOCAL_SPAN : poses - span;
            size_t low = *first >= reach ? *first - reach : 0u;
            size_t high = *first + reach < poses - span ? *first + reach : poses - span;
            *second = low + corrupt_index(rng, high - low + 1u);
        } else {
            *second = corrupt_index(rng, poses - span + 1u);
        }
    } while (*second + 1u >= *first && *first + 1u >= *second); /* not a self-loop or odometry */
}

/* --information: one value (diagonal) or the upper triangle, comma-separated, into a full
 * row-major n x n matrix. Prints an error and returns 0 when it is malformed or fails the
 * check the core applies when an edge is added ("not positive definite"). */
static int corrupt_parse_information(const char *text, int dimension, double *information)
{
    const int n = dimension == 2 ? 3 : 6, triangle = n * (n + 1) / 2;
    double values[21];
    int count = 0;
    const char *cursor = text;
    while (1) {
        char *end;
        double value = strtod(cursor, &end);
        if (end == cursor || !isfinite(value) || count == triangle) {
            fprintf(stderr, "pgem corrupt: --information '%s': expected 1 or %d finite numbers separated by commas\n",
                    text, triangle);
            return 0;
        }
        values[count++] = value;
        if (*end == '\0') {
            break;
        }
        if (*end != ',') {
            fprintf(stderr, "pgem corrupt: --information '%s': unexpected '%c' after number %d\n", text, *end, count);
            return 0;
        }
        cursor = end + 1;
    }
    if (count != 1 && count != triangle) {
        fprintf(stderr, "pgem corrupt: --information '%s': %d numbers; a %dD graph takes 1 or %d\n", text,
                count, dimension, triangle);
        return 0;
    }
    memset(information, 0, (size_t)(n * n) * sizeof *information);
    for (int i = 0, k = 0; i < n; i++) {
        for (int j = i; j < n; j++) {
            double value = count == 1 ? (i == j ? values[0] : 0.0) : values[k++];
            information[i * n + j] = information[j * n + i] = value;
        }
    }
    if (pgem_information_check(information, n, NULL) != PGEM_OK) {
        fprintf(stderr, "pgem corrupt: --information '%s' is not positive definite\n", text);
        return 0;
    }
    return 1;
}

static const pgem_io_edge_t *corrupt_template(const pgem_io_graph_t *graph)
{
    for (size_t k = 0; k < graph->edge_count; k++) {
        if (graph->edges[k].kind == PGEM_EDGE_LOOP) {
            return &graph->edges[k];
        }
    }
    return graph->edge_count > 0 ? &graph->edges[0] : NULL;
}

static size_t corrupt_group(const corrupt_args_t *args)
{
    int grouped = args->policy == CORRUPT_RANDOM_GROUPED || args->policy == CORRUPT_LOCAL_GROUPED;
    return grouped ? args->group_size : 1u;
}

/* 1 if the graph can take false loops: enough poses for a group, an edge to copy from. */
static int corrupt_possible(const corrupt_args_t *args, const pgem_io_graph_t *graph)
{
    if (corrupt_template(graph) == NULL || graph->pose_count < corrupt_group(args) + 3u) {
        fprintf(stderr, "pgem corrupt: %s has too few poses or no edge to copy information from\n", args->input);
        return 0;
    }
    return 1;
}

/* Appends the false loops to the graph's edge array and writes their pairs to `outliers`. */
static int corrupt_apply(const corrupt_args_t *args, const double *information,
                         pgem_io_graph_t *graph, FILE *outliers)
{
    const size_t group = corrupt_group(args);
    pgem_io_edge_t model = *corrupt_template(graph);
    if (information != NULL) {
        memcpy(model.information, information, sizeof model.information);
    }
    pgem_io_edge_t *edges = realloc(graph->edges, (graph->edge_count + args->count) * sizeof *edges);
    if (edges == NULL) {
        fprintf(stderr, "pgem corrupt: out of memory\n");
        return PGEM_EXIT_FAILURE;
    }
    graph->edges = edges;
    graph->edge_capacity = graph->edge_count + args->count;
    uint64_t rng = args->seed;
    for (uint32_t added = 0; added < args->count;) {
        size_t first, second;
        corrupt_pair(&rng, args, graph->pose_count, group - 1u, &first, &second);
        corrupt_measurement(&rng, graph->dimension, model.measurement);
        for (size_t g = 0; g < group && added < args->count; g++, added++) {
            pgem_io_edge_t *edge = &graph->edges[graph->edge_count++];
            *edge = model;
            edge->from = graph->poses[first + g].id;
            edge->to = graph->poses[second + g].id;
            edge->kind = PGEM_EDGE_LOOP;
            edge->line = 0;
            fprintf(outliers, "%llu %llu\n", (unsigned long long)edge->from, (unsigned long long)edge->to);
        }
    }
    return PGEM_EXIT_OK;
}

int pgem_cmd_corrupt(int argc, char **argv)
{
    corrupt_args_t args;
    int status = corrupt_parse(argc, argv, &args);
    if (status != PGEM_EXIT_OK) {
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    pgem_io_graph_t graph = {0};
    char outliers_path[4096];
    status = pgem_cli_read_graph("pgem", args.input, 0u, &graph);
    if (status != PGEM_EXIT_OK) {
        pgem_io_graph_free(&graph);
        return status;
    }
    if (!corrupt_possible(&args, &graph)) {
        pgem_io_graph_free(&graph);
        return PGEM_EXIT_FAILURE;
    }
    double information[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX] = {0};
    if (args.information != NULL && !corrupt_parse_information(args.information, graph.dimension, information)) {
        pgem_io_graph_free(&graph);
        return PGEM_EXIT_USAGE;
    }
    snprintf(outliers_path, sizeof outliers_path, "%s.outliers", args.output);
    pgem_cli_file_t outliers;
    if (pgem_cli_file_open(&outliers, "pgem corrupt", outliers_path) != 0) {
        pgem_io_graph_free(&graph);
        return PGEM_EXIT_IO;
    }
    status = corrupt_apply(&args, args.information != NULL ? information : NULL, &graph,
                           outliers.stream);
    if (status == PGEM_EXIT_OK) {
        status = pgem_cli_write_graph("pgem corrupt", &graph, args.output);
    }
    if (status != PGEM_EXIT_OK) {
        pgem_cli_file_discard(&outliers); /* no list of loops that were never written */
    } else {
        status = pgem_cli_file_commit(&outliers, 0);
    }
    if (status == PGEM_EXIT_OK) {
        printf("%s: added %u false loop closures (%s, seed %u) -> %s, %s\n", args.input, args.count,
               corrupt_policy_names[args.policy], args.seed, args.output, outliers_path);
    }
    pgem_io_graph_free(&graph);
    return status;
}
