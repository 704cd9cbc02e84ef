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
    const char *shift;           /* --shift text, or NULL: random measurements */
} corrupt_args_t;

static const char *const corrupt_policy_names[] = {"random", "local", "random-grouped", "local-grouped"};

static size_t corrupt_index(uint64_t *state, size_t count)
{
    size_t index = (size_t)(pgem_cli_uniform(state) * (double)count);
    return index < count ? index : count - 1u;
}

static void corrupt_help(FILE *out, const void *context)
{
    (void)context;
    fprintf(out,
            "usage: pgem corrupt IN -o OUT --policy random|local|random-grouped|local-grouped\n"
            "                    --count K [--group-size G] --seed S [--information V]\n"
            "                    [--shift D]\n"
            "\n"
            "Appends K false loop closures after the original edges (the protocol of Suenderhauf &\n"
            "Protzel): random joins two uniformly random poses, local a pose and one within %d\n"
            "ids of it; the grouped policies add groups of G (default 10) consecutive, mutually\n"
            "consistent false loops. Each false measurement is a random pose (translation\n"
            "uniform in +-10 m, any rotation); information is copied from the file's first loop\n"
            "closure (or its first edge), or given with --information V: one number (a diagonal\n"
            "matrix) or the upper triangle row by row as in g2o (6 numbers in 2D, 21 in 3D),\n"
            "separated by commas. --shift D makes an attacker's loops instead: every false loop\n"
            "measures the relative pose of the input's estimates with its second pose moved by the\n"
            "same rigid shift D, expressed in the frame of its group's first pose (2D: x,y,theta;\n"
            "3D: x,y,z,rx,ry,rz, rotation as angle-axis), so a group agrees with itself and with\n"
            "the odometry on both stretches, and only the path between its ends contradicts it\n"
            "(corrupt an optimised graph for the true relative poses).\n"
            "Writes OUT and OUT.outliers (one 'from to' per line).\n"
            "The same input and seed always give the same output.\n",
            CORRUPT_LOCAL_SPAN);
}

/* The command line as it is read: the choices, and which of the required ones were given. */
typedef struct corrupt_parsed {
    corrupt_args_t *args;
    int have_policy, have_count, have_seed;
} corrupt_parsed_t;

static int corrupt_policy(const char *value, corrupt_parsed_t *parsed)
{
    for (int p = 0; value != NULL && p < 4; p++) {
        if (strcmp(value, corrupt_policy_names[p]) == 0) {
            parsed->args->policy = (corrupt_policy_t)p;
            return parsed->have_policy = 1;
        }
    }
    fprintf(stderr, "pgem corrupt: --policy takes random, local, random-grouped or local-grouped\n");
    return 0;
}

static int corrupt_value(void *user, const char *name, const char *value)
{
    corrupt_parsed_t *parsed = user;
    corrupt_args_t *args = parsed->args;
    if (strcmp(name, "--policy") == 0) {
        return corrupt_policy(value, parsed);
    }
    if (strcmp(name, "--count") == 0) {
        return parsed->have_count = pgem_cli_parse_u32("pgem", name, value, &args->count);
    }
    if (strcmp(name, "--seed") == 0) {
        return parsed->have_seed = pgem_cli_parse_u32("pgem", name, value, &args->seed);
    }
    if (strcmp(name, "--group-size") == 0) {
        return pgem_cli_parse_at_least("pgem corrupt", name, value, 1u, "loop", &args->group_size);
    }
    const char **field = strcmp(name, "-o") == 0          ? &args->output
                         : strcmp(name, "--shift") == 0 ? &args->shift
                                                        : &args->information;
    return pgem_cli_text_value("pgem corrupt", name, value, "a value", field);
}

static int corrupt_positional(void *user, const char *argument)
{
    return pgem_cli_one_file("pgem corrupt", "input", &((corrupt_parsed_t *)user)->args->input,
                             argument);
}

static int corrupt_parse(int argc, char **argv, corrupt_args_t *args)
{
    static const char *const valued[] = {"-o",     "--policy",      "--count",
                                         "--seed", "--group-size",  "--information",
                                         "--shift"};
    const pgem_cli_parser_t parser = {
        "pgem corrupt", valued, sizeof valued / sizeof valued[0], corrupt_value, NULL,
        corrupt_positional, corrupt_help, NULL, NULL};
    *args = (corrupt_args_t){NULL, NULL, CORRUPT_RANDOM, 0u, 10u, 0u, NULL, NULL};
    corrupt_parsed_t parsed = {args, 0, 0, 0};
    const int status = pgem_cli_parse_args(&parser, &parsed, argc, argv);
    if (status != 0) {
        return status;
    }
    const int have_policy = parsed.have_policy, have_count = parsed.have_count,
              have_seed = parsed.have_seed;
    if (args->input == NULL || args->output == NULL || !have_policy || !have_count || !have_seed) {
        fprintf(stderr, "pgem corrupt: IN, -o OUT, --policy, --count and --seed are required\n");
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
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

/* Up to `most` finite numbers separated by commas from `text` (option `option`); prints an
 * error and returns -1 when malformed, else how many. */
static int corrupt_numbers(const char *option, const char *text, double *values, int most)
{
    int count = 0;
    const char *cursor = text;
    while (1) {
        char *end;
        double value = strtod(cursor, &end);
        if (end == cursor || !isfinite(value) || count == most) {
            fprintf(stderr, "pgem corrupt: %s '%s': expected at most %d finite numbers separated by commas\n",
                    option, text, most);
            return -1;
        }
        values[count++] = value;
        if (*end == '\0') {
            return count;
        }
        if (*end != ',') {
            fprintf(stderr, "pgem corrupt: %s '%s': unexpected '%c' after number %d\n", option, text, *end, count);
            return -1;
        }
        cursor = end + 1;
    }
}

/* --information: one value (diagonal) or the upper triangle, comma-separated, into a full
 * row-major n x n matrix. Prints an error and returns 0 when it is malformed or fails the
 * check the core applies when an edge is added ("not positive definite"). */
static int corrupt_parse_information(const char *text, int dimension, double *information)
{
    const int n = dimension == 2 ? 3 : 6, triangle = n * (n + 1) / 2;
    double values[21];
    const int count = corrupt_numbers("--information", text, values, triangle);
    if (count < 0) {
        return 0;
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

/* --shift: 3 numbers in 2D (x, y, theta), 6 in 3D (x, y, z and an angle-axis rotation), into
 * a pose. Prints an error and returns 0 when malformed. */
static int corrupt_parse_shift(const char *text, int dimension, double shift[PGEM_POSE_SIZE_MAX])
{
    const int want = dimension == 2 ? 3 : 6;
    double values[6];
    const int count = corrupt_numbers("--shift", text, values, want);
    if (count < 0) {
        return 0;
    }
    if (count != want) {
        fprintf(stderr, "pgem corrupt: --shift '%s': %d numbers; a %dD graph takes %d\n", text, count,
                dimension, want);
        return 0;
    }
    memcpy(shift, values, 3u * sizeof *shift);
    if (dimension == 2) {
        shift[2] = pgem_wrap_angle(values[2]);
    } else {
        pgem_so3_exp(values + 3, shift + 3);
    }
    return 1;
}

static void corrupt_compose(int dimension, const double *a, const double *b, double *out)
{
    if (dimension == 2) {
        pgem_se2_compose(a, b, out);
    } else {
        pgem_se3_compose(a, b, out);
    }
}

/* The attacker's measurement from pose `from` to pose `to` of a group based at pose `base`:
 * from^-1 (base shift base^-1) to, the relative pose with `to` moved rigidly by the shift
 * expressed in the base's frame. */
static void corrupt_shifted(int dimension, const double *base, const double *shift, const double *from,
                            const double *to, double *measurement)
{
    double moved[PGEM_POSE_SIZE_MAX], relative[PGEM_POSE_SIZE_MAX];
    if (dimension == 2) {
        pgem_se2_between(base, to, relative);
    } else {
        pgem_se3_between(base, to, relative);
    }
    corrupt_compose(dimension, shift, relative, moved);
    corrupt_compose(dimension, base, moved, moved);
    if (dimension == 2) {
        pgem_se2_between(from, moved, measurement);
    } else {
        pgem_se3_between(from, moved, measurement);
    }
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
static int corrupt_apply(const corrupt_args_t *args, const double *information, const double *shift,
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
        pgem_cli_random_pose(&rng, graph->dimension, model.measurement);
        for (size_t g = 0; g < group && added < args->count; g++, added++) {
            pgem_io_edge_t *edge = &graph->edges[graph->edge_count++];
            *edge = model;
            edge->from = graph->poses[first + g].id;
            edge->to = graph->poses[second + g].id;
            if (shift != NULL) {
                corrupt_shifted(graph->dimension, graph->poses[first].pose, shift, graph->poses[first + g].pose,
                                graph->poses[second + g].pose, edge->measurement);
            }
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
    double shift[PGEM_POSE_SIZE_MAX] = {0};
    if (args.shift != NULL && !corrupt_parse_shift(args.shift, graph.dimension, shift)) {
        pgem_io_graph_free(&graph);
        return PGEM_EXIT_USAGE;
    }
    snprintf(outliers_path, sizeof outliers_path, "%s.outliers", args.output);
    pgem_cli_file_t outliers;
    if (pgem_cli_file_open(&outliers, "pgem corrupt", outliers_path) != 0) {
        pgem_io_graph_free(&graph);
        return PGEM_EXIT_IO;
    }
    status = corrupt_apply(&args, args.information != NULL ? information : NULL,
                           args.shift != NULL ? shift : NULL, &graph, outliers.stream);
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
