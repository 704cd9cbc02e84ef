/* pgem stats: reads a graph and reports what decides whether it optimizes as is: counts,
 * degrees, connected components and their fixed poses, duplicated pairs, self-loops,
 * information matrices that are not symmetric positive definite, rotations, id gaps and
 * extent; a verdict (ok, warnings, problems) sets the exit code. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli.h"
#include "union_find.h"

#define STATS_SHOWN 3            /* items listed per finding, then "... and N more" */
#define STATS_SIZES 5            /* component sizes kept, largest first */
#define STATS_REASONS 16         /* verdict reasons kept */
#define STATS_PI 3.14159265358979323846
#define STATS_QUAT_NOTE 1e-6     /* norm error worth a note (printed digits round to this) */
#define STATS_QUAT_WARN 1e-3     /* beyond rounding: the writer did not normalise */

typedef enum stats_level { STATS_NOTE = 1, STATS_WARNING = 2, STATS_PROBLEM = 3 } stats_level_t;

typedef enum stats_item_kind {
    STATS_ITEM_EDGE,             /* an edge: from, to, line */
    STATS_ITEM_POSE,             /* a pose: pose, line */
    STATS_ITEM_LEAF,             /* a pose and its only edge: pose, from, to, line */
    STATS_ITEM_PAIR              /* a duplicated pair: from, to (first edge), count, lines */
} stats_item_kind_t;

/* One finding to show. */
typedef struct stats_item {
    stats_item_kind_t kind;
    pgem_id_t pose;
    pgem_id_t from;
    pgem_id_t to;
    unsigned long line;          /* its file line (0: made by the reader) */
    unsigned long second_line;   /* pair: the line of the second edge */
    size_t count;                /* pair: edges joining it */
} stats_item_t;

/* How many of something were found, and the first few in file order. */
typedef struct stats_list {
    size_t count;
    size_t shown;
    stats_item_t items[STATS_SHOWN];
} stats_list_t;

/* Everything measured on one graph. */
typedef struct stats {
    const char *path;
    const pgem_io_graph_t *graph;
    size_t odometry;
    size_t loops;
    size_t degree_min;
    size_t degree_max;
    size_t degree_sum;
    size_t degree0;
    size_t degree1;
    stats_list_t loop_leaves;    /* poses whose only edge is a loop closure */
    size_t components;
    size_t unheld;               /* components with no held pose */
    pgem_id_t unheld_example;    /* a pose of the first such component, in file order */
    size_t sizes[STATS_SIZES];   /* largest component sizes */
    size_t sizes_kept;
    stats_list_t duplicates;     /* unordered pairs joined by more than one edge */
    size_t duplicate_edges;      /* edges beyond the first of each such pair */
    size_t duplicate_exact;      /* of those, exact copies (same direction and numbers) */
    stats_list_t self_loops;
    stats_list_t non_finite;     /* poses holding NaN or Inf (guessed along huge edges: the
                                    reader refuses such values in the file) */
    stats_list_t not_pd;         /* information refused by the core's check */
    size_t information_ok;
    size_t angles_out;           /* 2D: theta outside [-pi, pi] (poses and measurements) */
    size_t quaternions_off;      /* 3D: norm off 1 by more than 1e-6, within 1% */
    double quaternion_error;     /* 3D: largest |norm - 1| */
    stats_list_t bad_quaternions; /* 3D: norm off 1 by more than 1% */
    pgem_id_t id_min;
    pgem_id_t id_max;
    size_t id_gaps;              /* breaks in the sorted ids */
    unsigned long long id_missing; /* ids between id_min and id_max with no pose */
    double low[3];               /* bounding box of the positions */
    double high[3];
    size_t toro_edges;           /* EDGE2 lines in a file without vertices (iSAM-like) */
    int level;                   /* 0 ok, else the worst stats_level_t of the reasons */
    size_t reason_count;
    stats_level_t reason_level[STATS_REASONS];
    char reason[STATS_REASONS][256];
} stats_t;

static void stats_help(FILE *out, const void *context)
{
    (void)context;
    fprintf(out,
            "usage: pgem stats GRAPH [--json]\n"
            "\n"
            "Reads GRAPH (g2o 2D/3D or TORO 2D, as pgem optimize does) and reports whether it\n"
            "can be optimized as is: poses and edges (odometry: the first edge between ids i\n"
            "and i+1, else loop closure), pose ids and their gaps, FIX lines, degree (min,\n"
            "mean, max; poses of degree 0 and 1), connected components (their sizes, and\n"
            "whether each holds a fixed pose: FIX poses, or the first pose when there is no\n"
            "FIX line), unordered pairs joined by more than one edge, self-loops, edges naming\n"
            "a missing pose, information matrices that are not symmetric or not positive\n"
            "definite (Cholesky, with the tolerances pgem uses when loading), 2D angles\n"
            "outside [-pi, pi], 3D quaternions off unit norm, NaN/Inf values and the bounding\n"
            "box of the positions.\n"
            "Lists show the first %d items with their file lines.\n"
            "\n"
            "The verdict:\n"
            "  ok        optimizable as is\n"
            "  warnings  optimizable, but look: duplicated pairs, a pose held only by a loop\n"
            "            closure (if a robust kernel rejects it, the pose floats), quaternions\n"
            "            off unit norm by more than 1e-3, lines with unknown tags, EDGE2 lines\n"
            "            without vertices (how iSAM files look: square-root information)\n"
            "  problems  will not optimize correctly as is: no poses, a connected component\n"
            "            without a fixed pose, self-loops, edges naming a missing pose,\n"
            "            information not symmetric positive definite, quaternions off unit\n"
            "            norm by more than 1%% (pgem optimize refuses these when loading),\n"
            "            NaN/Inf\n"
            "Angles outside [-pi, pi] and quaternions off by less than 1e-3 are notes: pgem\n"
            "wraps and normalises them when loading. A pose of degree 1 on an odometry edge is\n"
            "a trajectory end and fine.\n"
            "\n"
            "  --json    print one JSON object on stdout (every number above, the verdict\n"
            "            and its reasons)\n"
            "\n"
            "Exit codes: 0 ok or warnings, 1 problems or the file was rejected by the reader\n"
            "(the message names the file and line), 2 bad command line, 3 the file could not\n"
            "be read.\n",
            STATS_SHOWN);
}

/* What the command line says: the graph file and --json. */
typedef struct stats_args {
    const char *path;
    int json;
} stats_args_t;

static int stats_flag(void *user, const char *name)
{
    stats_args_t *args = user;
    if (strcmp(name, "--json") != 0) {
        return 0;
    }
    args->json = 1;
    return 1;
}

static int stats_positional(void *user, const char *argument)
{
    return pgem_cli_one_file("pgem stats", "graph", &((stats_args_t *)user)->path, argument);
}

/* Returns PGEM_EXIT_OK, an exit code, or -1 after --help. */
static int stats_parse(int argc, char **argv, const char **path, int *json)
{
    const pgem_cli_parser_t parser = {
        "pgem stats", NULL, 0, NULL, stats_flag, stats_positional, stats_help, NULL, NULL};
    stats_args_t args = {NULL, 0};
    if (argc < 2) {
        stats_help(stderr, NULL);
        return PGEM_EXIT_USAGE;
    }
    const int status = pgem_cli_parse_args(&parser, &args, argc, argv);
    *path = args.path;
    *json = args.json;
    if (status != 0) {
        return status;
    }
    if (*path == NULL) {
        fprintf(stderr, "pgem stats: no graph file (see pgem stats --help)\n");
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

/* Counts an item and keeps it if it is among the first STATS_SHOWN by line. */
static void stats_list_add(stats_list_t *list, stats_item_t item)
{
    list->count++;
    size_t at = list->shown;
    while (at > 0 && list->items[at - 1].line > item.line) {
        at--;
    }
    if (at >= STATS_SHOWN) {
        return;
    }
    size_t last = list->shown < STATS_SHOWN ? list->shown : STATS_SHOWN - 1u;
    for (size_t k = last; k > at; k--) {
        list->items[k] = list->items[k - 1];
    }
    list->items[at] = item;
    if (list->shown < STATS_SHOWN) {
        list->shown++;
    }
}

static stats_item_t stats_edge_item(const pgem_io_edge_t *edge)
{
    stats_item_t item = {STATS_ITEM_EDGE, 0, edge->from, edge->to, edge->line, 0, 1};
    return item;
}

static stats_item_t stats_pose_item(const pgem_io_pose_t *pose)
{
    stats_item_t item = {STATS_ITEM_POSE, pose->id, 0, 0, pose->line, 0, 1};
    return item;
}

static int stats_all_finite(const double *values, size_t count)
{
    for (size_t k = 0; k < count; k++) {
        if (!isfinite(values[k])) {
            return 0;
        }
    }
    return 1;
}

/* Theta (2D) or the quaternion (3D) of a pose or measurement with finite values. */
static void stats_rotation(stats_t *s, const double *value, stats_item_t item)
{
    if (s->graph->dimension == 2) {
        s->angles_out += fabs(value[2]) > STATS_PI;
        return;
    }
    double q[4];
    memcpy(q, value + 3, sizeof q);
    int refused;
    double error = fabs(pgem_cli_quat_check(q, &refused) - 1.0);
    s->quaternion_error = fmax(s->quaternion_error, error);
    if (refused) {
        stats_list_add(&s->bad_quaternions, item);
    } else if (error > STATS_QUAT_NOTE) {
        s->quaternions_off++;
    }
}

/* Ids (range, gaps, from the poses sorted by id), values and bounding box of the poses. */
static void stats_poses(stats_t *s, const pgem_io_pose_index_t *ids)
{
    const pgem_io_graph_t *g = s->graph;
    const size_t size = (size_t)PGEM_POSE_SIZE(g->dimension);
    const int axes = g->dimension == 3 ? 3 : 2;
    for (int a = 0; a < 3; a++) {
        s->low[a] = HUGE_VAL;
        s->high[a] = -HUGE_VAL;
    }
    for (size_t k = 0; k < g->pose_count; k++) {
        const pgem_io_pose_t *pose = &g->poses[k];
        if (!stats_all_finite(pose->pose, size)) {
            stats_list_add(&s->non_finite, stats_pose_item(pose));
            continue;
        }
        stats_rotation(s, pose->pose, stats_pose_item(pose));
        for (int a = 0; a < axes; a++) {
            s->low[a] = fmin(s->low[a], pose->pose[a]);
            s->high[a] = fmax(s->high[a], pose->pose[a]);
        }
    }
    if (g->pose_count > 0) {
        s->id_min = ids[0].id;
        s->id_max = ids[g->pose_count - 1u].id;
    }
    for (size_t k = 1; k < g->pose_count; k++) {
        if (ids[k].id - ids[k - 1u].id > 1u) {
            s->id_gaps++;
            s->id_missing += (unsigned long long)(ids[k].id - ids[k - 1u].id - 1u);
        }
    }
}

/* Values and information of one edge (the reader refuses NaN and Inf in them). The reader
 * fills both triangles of the information, so only positive definiteness can fail. */
static void stats_edge_values(stats_t *s, const pgem_io_edge_t *edge)
{
    const int n = PGEM_TANGENT_SIZE(s->graph->dimension);
    stats_rotation(s, edge->measurement, stats_edge_item(edge));
    if (pgem_information_check(edge->information, n, NULL) == PGEM_OK) {
        s->information_ok++;
    } else {
        stats_list_add(&s->not_pd, stats_edge_item(edge));
    }
}

/* Kinds, values, degrees and the union-find of every edge (the reader refuses an edge naming
 * a missing pose). */
static void stats_edges(stats_t *s, const pgem_io_pose_index_t *ids, uint32_t *parent, size_t *degree,
                        size_t *incident)
{
    const pgem_io_graph_t *g = s->graph;
    for (size_t k = 0; k < g->self_loop_count; k++) { /* left out of the graph by the reader */
        stats_list_add(&s->self_loops, stats_edge_item(&g->self_loops[k]));
    }
    for (size_t k = 0; k < g->edge_count; k++) {
        const pgem_io_edge_t *edge = &g->edges[k];
        size_t from = pgem_io_find_pose(ids, g->pose_count, edge->from);
        size_t to = pgem_io_find_pose(ids, g->pose_count, edge->to);
        if (edge->kind == PGEM_EDGE_ODOMETRY) {
            s->odometry++;
        } else {
            s->loops++;
        }
        stats_edge_values(s, edge);
        degree[from]++;
        degree[to]++;
        incident[from] = incident[to] = k;
        (void)pgem_part_join(parent, (uint32_t)from, (uint32_t)to);
    }
}

/* Degree summary and the poses whose only edge is a loop closure. */
static void stats_degrees(stats_t *s, const size_t *degree, const size_t *incident)
{
    const pgem_io_graph_t *g = s->graph;
    s->degree_min = g->pose_count > 0 ? degree[0] : 0u;
    for (size_t k = 0; k < g->pose_count; k++) {
        s->degree_min = degree[k] < s->degree_min ? degree[k] : s->degree_min;
        s->degree_max = degree[k] > s->degree_max ? degree[k] : s->degree_max;
        s->degree_sum += degree[k];
        s->degree0 += degree[k] == 0u;
        s->degree1 += degree[k] == 1u;
        const pgem_io_edge_t *edge = degree[k] == 1u ? &g->edges[incident[k]] : NULL;
        if (edge != NULL && edge->kind == PGEM_EDGE_LOOP) {
            stats_item_t item = stats_edge_item(edge);
            item.kind = STATS_ITEM_LEAF;
            item.pose = g->poses[k].id;
            stats_list_add(&s->loop_leaves, item);
        }
    }
}

/* Components, their sizes, and which of them hold a fixed pose. size and held have one
 * entry per pose (indexed by root), zeroed. */
static void stats_components(stats_t *s, const pgem_io_pose_index_t *ids, uint32_t *parent,
                             size_t *size, unsigned char *held)
{
    const pgem_io_graph_t *g = s->graph;
    for (size_t k = 0; k < g->pose_count; k++) {
        size[pgem_part_root(parent, (uint32_t)k)]++;
    }
    for (size_t k = 0; k < g->fixed_count; k++) {
        size_t index = pgem_io_find_pose(ids, g->pose_count, g->fixed[k]);
        if (index != PGEM_IO_NO_POSE) {
            held[pgem_part_root(parent, (uint32_t)index)] = 1u;
        }
    }
    if (g->fixed_count == 0 && g->pose_count > 0) {
        held[pgem_part_root(parent, 0)] = 1u; /* the gauge: the first pose added */
    }
    for (size_t k = 0; k < g->pose_count; k++) {
        if (parent[k] != (uint32_t)k) {
            continue;
        }
        s->components++;
        size_t at = s->sizes_kept < STATS_SIZES ? s->sizes_kept++ : STATS_SIZES;
        while (at > 0 && s->sizes[at - 1u] < size[k]) {
            if (at < STATS_SIZES) {
                s->sizes[at] = s->sizes[at - 1u];
            }
            at--;
        }
        if (at < STATS_SIZES) {
            s->sizes[at] = size[k];
        }
    }
    for (size_t k = 0; k < g->pose_count; k++) {
        size_t root = pgem_part_root(parent, (uint32_t)k);
        if (held[root] == 0u) {
            s->unheld_example = s->unheld == 0u ? g->poses[k].id : s->unheld_example;
            s->unheld++;
            held[root] = 2u; /* counted */
        }
    }
}

static int stats_same_edge(const pgem_io_edge_t *a, const pgem_io_edge_t *b, int dimension)
{
    const size_t n = (size_t)PGEM_TANGENT_SIZE(dimension);
    return a->from == b->from && a->to == b->to &&
           memcmp(a->measurement, b->measurement,
                  (size_t)PGEM_POSE_SIZE(dimension) * sizeof(double)) == 0 &&
           memcmp(a->information, b->information, n * n * sizeof(double)) == 0;
}

/* Unordered pairs joined by more than one edge (pairs: one entry per edge, from <= to). */
static void stats_duplicates(stats_t *s, pgem_cli_pair_t *pairs)
{
    const pgem_io_graph_t *g = s->graph;
    for (size_t k = 0; k < g->edge_count; k++) {
        pgem_id_t a = g->edges[k].from, b = g->edges[k].to;
        pairs[k] = (pgem_cli_pair_t){a < b ? a : b, a < b ? b : a, k};
    }
    pgem_cli_sort_pairs(pairs, g->edge_count);
    for (size_t start = 0, end; start < g->edge_count; start = end) {
        end = pgem_cli_pair_run_end(pairs, g->edge_count, start, pairs[start].from,
                                    pairs[start].to);
        if (end - start < 2u) {
            continue;
        }
        const pgem_io_edge_t *first = &g->edges[pairs[start].index];
        stats_item_t item = stats_edge_item(first);
        item.kind = STATS_ITEM_PAIR;
        item.second_line = g->edges[pairs[start + 1u].index].line;
        item.count = end - start;
        stats_list_add(&s->duplicates, item);
        s->duplicate_edges += end - start - 1u;
        for (size_t k = start + 1u; k < end; k++) {
            s->duplicate_exact +=
                (size_t)stats_same_edge(first, &g->edges[pairs[k].index], g->dimension);
        }
    }
}

/* A 2D file with edges but no vertex line whose edges are TORO EDGE2 lines looks like an
 * iSAM file (square-root information): counts those EDGE2 lines. */
static void stats_isam_check(stats_t *s)
{
    const pgem_io_graph_t *g = s->graph;
    if (g->dimension == 2 && g->pose_count > 0 && g->chained_poses == g->pose_count) {
        s->toro_edges = g->toro_edges;
    }
}

static void stats_reason(stats_t *s, stats_level_t level, const char *format, ...)
{
    if (s->reason_count == STATS_REASONS) {
        return;
    }
    va_list args;
    va_start(args, format);
    vsnprintf(s->reason[s->reason_count], sizeof s->reason[0], format, args);
    va_end(args);
    s->reason_level[s->reason_count++] = level;
    s->level = (int)level > s->level ? (int)level : s->level;
}

static void stats_problems(stats_t *s)
{
    const pgem_io_graph_t *g = s->graph;
    if (g->pose_count == 0) {
        stats_reason(s, STATS_PROBLEM, "no poses");
    }
    if (s->unheld > 0) {
        stats_reason(s, STATS_PROBLEM, "%zu of %zu components without a fixed pose", s->unheld,
                     s->components);
    }
    if (s->non_finite.count > 0) {
        stats_reason(s, STATS_PROBLEM, "%zu line%s with NaN or Inf", s->non_finite.count,
                     pgem_cli_plural(s->non_finite.count));
    }
    if (s->not_pd.count > 0) {
        stats_reason(s, STATS_PROBLEM, "%zu information matri%s not positive definite",
                     s->not_pd.count, s->not_pd.count == 1u ? "x" : "ces");
    }
    if (s->bad_quaternions.count > 0) {
        stats_reason(s, STATS_PROBLEM, "%zu quaternion%s off unit norm by more than 1%%",
                     s->bad_quaternions.count, pgem_cli_plural(s->bad_quaternions.count));
    }
}

static void stats_warnings(stats_t *s)
{
    const pgem_io_graph_t *g = s->graph;
    if (s->duplicates.count > 0) {
        stats_reason(s, STATS_WARNING, "%zu duplicated pair%s", s->duplicates.count,
                     pgem_cli_plural(s->duplicates.count));
    }
    if (s->loop_leaves.count > 0) {
        stats_reason(s, STATS_WARNING, "%zu pose%s held only by a loop closure",
                     s->loop_leaves.count, pgem_cli_plural(s->loop_leaves.count));
    }
    if (s->bad_quaternions.count == 0 && s->quaternion_error > STATS_QUAT_WARN) {
        stats_reason(s, STATS_WARNING, "quaternions off unit norm by up to %.2g",
                     s->quaternion_error);
    }
    if (s->self_loops.count > 0) {
        stats_reason(s, STATS_WARNING, "%zu self-loop edge%s skipped", s->self_loops.count,
                     pgem_cli_plural(s->self_loops.count));
    }
    if (g->unknown_lines > 0) {
        stats_reason(s, STATS_WARNING, "%zu line%s with unknown tags skipped", g->unknown_lines,
                     pgem_cli_plural(g->unknown_lines));
    }
    if (s->toro_edges > 0) {
        stats_reason(s, STATS_WARNING, "EDGE2 lines without vertices (an iSAM file?)");
    }
    if (s->angles_out > 0) {
        stats_reason(s, STATS_NOTE, "%zu angle%s outside [-pi, pi]", s->angles_out,
                     pgem_cli_plural(s->angles_out));
    }
    if (s->quaternions_off > 0) {
        stats_reason(s, STATS_NOTE, "%zu quaternion%s off unit norm by more than 1e-6",
                     s->quaternions_off, pgem_cli_plural(s->quaternions_off));
    }
    if (g->chained_poses > 0) {
        stats_reason(s, STATS_NOTE, "%zu pose%s without a VERTEX line", g->chained_poses,
                     pgem_cli_plural(g->chained_poses));
    }
    if (g->equiv_lines > 0) {
        stats_reason(s, STATS_NOTE, "%zu TORO EQUIV line%s skipped", g->equiv_lines,
                     pgem_cli_plural(g->equiv_lines));
    }
}

/* What the file's own counts cannot show: the graph loaded as `pgem optimize` loads it, then
 * the core's checks before a solve (pgem_check_solvable: an edge and a free pose, every part
 * held, a finite chi2), so `stats` says problems wherever `optimize` would refuse. */
static void stats_solvable(stats_t *s)
{
    const pgem_io_graph_t *g = s->graph;
    char message[1024] = "";
    pgem_t *instance = NULL;
    if (g->pose_count > 0 && g->edge_count == 0) {
        stats_reason(s, STATS_PROBLEM, "no edges: nothing to optimize");
        return;
    }
    int status = pgem_cli_load_quietly(g, NULL, 1u, &instance, NULL, message, sizeof message);
    if (status == PGEM_OK) {
        status = pgem_check_solvable(instance);
        snprintf(message, sizeof message, "%s", pgem_last_error(instance));
    }
    pgem_destroy(instance);
    if (status != PGEM_OK) {
        stats_reason(s, STATS_PROBLEM, "optimize would refuse it: %s", message);
    }
}

/* Runs every check; returns PGEM_EXIT_OK or PGEM_EXIT_FAILURE when out of memory. */
static int stats_measure(stats_t *s)
{
    const pgem_io_graph_t *g = s->graph;
    const size_t poses = g->pose_count > 0 ? g->pose_count : 1u;
    const size_t edges = g->edge_count > 0 ? g->edge_count : 1u;
    pgem_io_pose_index_t *ids = pgem_io_index_poses(g);
    size_t *counts = calloc(3u * poses, sizeof *counts); /* degree, incident, size */
    uint32_t *parent = calloc(poses, sizeof *parent);   /* union-find (pgem_part_root) */
    unsigned char *held = calloc(poses, 1u);
    pgem_cli_pair_t *pairs = malloc(edges * sizeof *pairs);
    int status = PGEM_EXIT_OK;
    if (ids == NULL || counts == NULL || parent == NULL || held == NULL || pairs == NULL) {
        fprintf(stderr, "pgem stats: out of memory\n");
        status = PGEM_EXIT_FAILURE;
    } else {
        size_t *degree = counts, *incident = counts + poses;
        for (size_t k = 0; k < g->pose_count; k++) {
            parent[k] = (uint32_t)k;
        }
        stats_poses(s, ids);
        stats_edges(s, ids, parent, degree, incident);
        stats_degrees(s, degree, incident);
        stats_components(s, ids, parent, counts + 2u * poses, held);
        stats_duplicates(s, pairs);
        stats_isam_check(s);
        stats_problems(s);
        if (s->level < STATS_PROBLEM) {
            stats_solvable(s);
        }
        stats_warnings(s);
    }
    free(ids);
    free(counts);
    free(parent);
    free(held);
    free(pairs);
    return status;
}

static const char *stats_verdict(const stats_t *s)
{
    return s->level >= STATS_PROBLEM ? "problems" : s->level >= STATS_WARNING ? "warnings" : "ok";
}

/* ---- text report ---- */

static void stats_print_item(const stats_item_t *item)
{
    if (item->kind == STATS_ITEM_PAIR) {
        printf("             %llu - %llu: %zu edges, lines %lu, %lu%s\n",
               (unsigned long long)item->from, (unsigned long long)item->to, item->count,
               item->line, item->second_line, item->count > 2u ? ", ..." : "");
    } else if (item->kind == STATS_ITEM_LEAF) {
        printf("             pose %llu: only edge %llu -> %llu, line %lu\n",
               (unsigned long long)item->pose, (unsigned long long)item->from,
               (unsigned long long)item->to, item->line);
    } else if (item->kind == STATS_ITEM_POSE) {
        printf("             line %lu: pose %llu\n", item->line, (unsigned long long)item->pose);
    } else {
        printf("             line %lu: edge %llu -> %llu\n", item->line,
               (unsigned long long)item->from, (unsigned long long)item->to);
    }
}

static void stats_print_list(const char *label, const char *what, const stats_list_t *list)
{
    if (list->count == 0) {
        return;
    }
    printf("%-13s%zu %s\n", label, list->count, what);
    for (size_t k = 0; k < list->shown; k++) {
        stats_print_item(&list->items[k]);
    }
    if (list->count > list->shown) {
        printf("             ... and %zu more\n", list->count - list->shown);
    }
}

static void stats_print_ids(const stats_t *s)
{
    const pgem_io_graph_t *g = s->graph;
    if (g->pose_count == 0) {
        printf("%-13s0\n", "poses");
        return;
    }
    printf("%-13s%zu, ids %llu .. %llu", "poses", g->pose_count, (unsigned long long)s->id_min,
           (unsigned long long)s->id_max);
    if (s->id_gaps == 0) {
        printf(" (contiguous)\n");
    } else {
        printf(" (%zu gap%s, %llu id%s missing)\n", s->id_gaps, pgem_cli_plural(s->id_gaps),
               s->id_missing, s->id_missing == 1u ? "" : "s");
    }
    if (g->fixed_count > 0) {
        printf("%-13s%zu pose%s named by FIX lines:", "fixed", g->fixed_count,
               pgem_cli_plural(g->fixed_count));
        for (size_t k = 0; k < g->fixed_count && k < STATS_SHOWN; k++) {
            printf(" %llu", (unsigned long long)g->fixed[k]);
        }
        printf("%s\n", g->fixed_count > STATS_SHOWN ? " ..." : "");
    }
}

static void stats_print_structure(const stats_t *s)
{
    const pgem_io_graph_t *g = s->graph;
    printf("%-13s%zu: %zu odometry, %zu loop closure%s\n", "edges", g->edge_count, s->odometry,
           s->loops, pgem_cli_plural(s->loops));
    if (g->pose_count == 0) {
        return;
    }
    printf("%-13smin %zu, mean %.2f, max %zu; %zu pose%s of degree 0, %zu of degree 1\n",
           "degree", s->degree_min, (double)s->degree_sum / (double)g->pose_count, s->degree_max,
           s->degree0, pgem_cli_plural(s->degree0), s->degree1);
    stats_print_list("", "held only by a loop closure:", &s->loop_leaves);
    printf("%-13s%zu", "components", s->components);
    for (size_t k = 0; k < s->sizes_kept; k++) {
        printf("%s%zu", k == 0 ? (s->components == 1u ? " (" : ": sizes ") : ", ", s->sizes[k]);
    }
    printf("%s", s->components == 1u ? (g->pose_count == 1u ? " pose)" : " poses)")
                 : s->components > STATS_SIZES ? ", ..." : "");
    if (s->unheld == 0) {
        printf(", %s\n", g->fixed_count > 0 ? "each with a FIX pose" : "held by the first pose");
    } else {
        printf("; %zu without a fixed pose\n", s->unheld);
        printf("             e.g. the part with pose %llu: FIX a pose in each part, or join them\n",
               (unsigned long long)s->unheld_example);
    }
}

static void stats_print_defects(const stats_t *s)
{
    if (s->duplicates.count > 0) {
        char what[96];
        snprintf(what, sizeof what,
                 "pair%s joined more than once (%zu extra edge%s, %zu exact copies)",
                 pgem_cli_plural(s->duplicates.count), s->duplicate_edges,
                 pgem_cli_plural(s->duplicate_edges), s->duplicate_exact);
        stats_print_list("duplicates", what, &s->duplicates);
    }
    stats_print_list("self-loops", "(edges joining a pose to itself, left out):",
                     &s->self_loops);
    stats_print_list("non-finite", "lines with NaN or Inf:", &s->non_finite);
    if (s->graph->edge_count > 0) {
        printf("%-13s%zu of %zu symmetric positive definite\n", "information", s->information_ok,
               s->graph->edge_count);
    }
    stats_print_list("", "not positive definite:", &s->not_pd);
    if (s->graph->dimension == 2) {
        printf("%-13s%zu angle%s outside [-pi, pi]%s\n", "rotations", s->angles_out,
               pgem_cli_plural(s->angles_out), s->angles_out > 0 ? " (wrapped when loaded)" : "");
    } else if (s->graph->dimension == 3) {
        printf("%-13s%zu quaternion%s off unit norm by more than 1e-6 (largest %.2g)\n",
               "rotations", s->quaternions_off + s->bad_quaternions.count,
               pgem_cli_plural(s->quaternions_off + s->bad_quaternions.count), s->quaternion_error);
        stats_print_list("", "off by more than 1% (refused when loaded):", &s->bad_quaternions);
    }
}

static void stats_print_text(const stats_t *s)
{
    const pgem_io_graph_t *g = s->graph;
    printf("%-13s%s (%s)\n", "file", s->path,
           g->dimension == 3 ? "3D" : g->dimension == 2 ? "2D" : "empty");
    if (g->chained_poses > 0) {
        printf("%-13sno VERTEX lines: %zu poses guessed along the edges\n", "", g->chained_poses);
    }
    if (s->toro_edges > 0) {
        printf("%-13s%zu EDGE2 lines and no vertex: iSAM .txt files look like this, and their\n"
               "%-13snumbers are square-root information (see FORMATS.md)\n",
               "", s->toro_edges, "");
    }
    if (g->unknown_lines > 0) {
        printf("%-13s%zu line%s with unknown tags skipped (first '%s', line %lu)\n", "",
               g->unknown_lines, pgem_cli_plural(g->unknown_lines), g->first_unknown_tag,
               g->first_unknown_line);
    }
    if (g->equiv_lines > 0) {
        printf("%-13s%zu TORO EQUIV line%s skipped\n", "", g->equiv_lines,
               pgem_cli_plural(g->equiv_lines));
    }
    stats_print_ids(s);
    stats_print_structure(s);
    stats_print_defects(s);
    if (g->pose_count > 0 && s->low[0] <= s->high[0]) {
        printf("%-13sx %.6g .. %.6g, y %.6g .. %.6g", "extent", s->low[0], s->high[0], s->low[1],
               s->high[1]);
        if (g->dimension == 3) {
            printf(", z %.6g .. %.6g", s->low[2], s->high[2]);
        }
        printf("\n");
    }
    /* the reasons after the verdict, wrapped at 100 columns */
    int column = printf("%-13s%s", "verdict", stats_verdict(s));
    const char *separator = ": ";
    for (size_t k = 0; k < s->reason_count; k++) {
        if (s->reason_level[k] >= STATS_WARNING) {
            int width = (int)(strlen(separator) + strlen(s->reason[k]));
            if (column + width > 100) {
                printf("%s\n%13s", separator[0] == ';' ? ";" : ":", "");
                column = 13 + printf("%s", s->reason[k]);
            } else {
                column += printf("%s%s", separator, s->reason[k]);
            }
            separator = "; ";
        }
    }
    printf("\n");
}

/* ---- JSON ---- */

static void stats_json_list(const char *key, const stats_list_t *list)
{
    printf(",\"%s\":%zu,\"%s_first\":[", key, list->count, key);
    for (size_t k = 0; k < list->shown; k++) {
        const stats_item_t *item = &list->items[k];
        printf("%s{\"line\":%lu,", k > 0 ? "," : "", item->line);
        if (item->kind == STATS_ITEM_PAIR) {
            printf("\"from\":%llu,\"to\":%llu,\"edges\":%zu,\"second_line\":%lu}",
                   (unsigned long long)item->from, (unsigned long long)item->to, item->count,
                   item->second_line);
        } else if (item->kind == STATS_ITEM_LEAF) {
            printf("\"pose\":%llu,\"from\":%llu,\"to\":%llu}", (unsigned long long)item->pose,
                   (unsigned long long)item->from, (unsigned long long)item->to);
        } else if (item->kind == STATS_ITEM_POSE) {
            printf("\"pose\":%llu}", (unsigned long long)item->pose);
        } else {
            printf("\"from\":%llu,\"to\":%llu}", (unsigned long long)item->from,
                   (unsigned long long)item->to);
        }
    }
    printf("]");
}

static void stats_json_box(const char *key, const double *corner, int axes, int present)
{
    printf(",\"%s\":", key);
    if (!present) {
        printf("null");
        return;
    }
    for (int a = 0; a < axes; a++) {
        putchar(a == 0 ? '[' : ',');
        pgem_json_number(stdout, corner[a], 10);
    }
    printf("]");
}

static void stats_json_reasons(const stats_t *s, const char *key, int warnings)
{
    const char *separator = "";
    printf(",\"%s\":[", key);
    for (size_t k = 0; k < s->reason_count; k++) {
        if ((s->reason_level[k] >= STATS_WARNING) == warnings) {
            printf("%s", separator);
            pgem_json_string(stdout, s->reason[k]);
            separator = ",";
        }
    }
    printf("]");
}

static void stats_print_json(const stats_t *s)
{
    const pgem_io_graph_t *g = s->graph;
    const int have = g->pose_count > 0;
    printf("{\"file\":");
    pgem_json_string(stdout, s->path);
    printf(",\"dimension\":%d,\"poses\":%zu,\"edges\":%zu,\"odometry\":%zu,\"loops\":%zu,"
           "\"poses_without_vertex\":%zu,\"unknown_lines\":%zu,\"equiv_lines\":%zu,"
           "\"isam_like_edges\":%zu,\"fixed\":%zu",
           g->dimension, g->pose_count, g->edge_count, s->odometry, s->loops, g->chained_poses,
           g->unknown_lines, g->equiv_lines, s->toro_edges, g->fixed_count);
    if (have) {
        printf(",\"id_min\":%llu,\"id_max\":%llu", (unsigned long long)s->id_min,
               (unsigned long long)s->id_max);
    } else {
        printf(",\"id_min\":null,\"id_max\":null");
    }
    printf(",\"id_gaps\":%zu,\"ids_missing\":%llu,\"degree_min\":%zu", s->id_gaps, s->id_missing,
           s->degree_min);
    printf(",\"degree_mean\":");
    pgem_json_number(stdout, have ? (double)s->degree_sum / (double)g->pose_count : (double)NAN,
                     10);
    printf(",\"degree_max\":%zu,\"degree0\":%zu,\"degree1\":%zu", s->degree_max, s->degree0,
           s->degree1);
    stats_json_list("loop_leaves", &s->loop_leaves);
    printf(",\"components\":%zu,\"components_without_fixed\":%zu,\"component_sizes\":[",
           s->components, s->unheld);
    for (size_t k = 0; k < s->sizes_kept; k++) {
        printf("%s%zu", k > 0 ? "," : "", s->sizes[k]);
    }
    printf("]");
    stats_json_list("duplicate_pairs", &s->duplicates);
    printf(",\"duplicate_edges\":%zu,\"duplicate_exact\":%zu", s->duplicate_edges,
           s->duplicate_exact);
    stats_json_list("self_loops", &s->self_loops);
    /* The reader refuses edges naming a missing pose and fills both triangles of the
     * information: those findings are always none. */
    printf(",\"missing_pose_edges\":0,\"missing_pose_edges_first\":[]");
    stats_json_list("non_finite", &s->non_finite);
    printf(",\"information_ok\":%zu,\"information_asymmetric\":0,"
           "\"information_asymmetric_first\":[]", s->information_ok);
    stats_json_list("information_not_pd", &s->not_pd);
    printf(",\"angles_out_of_range\":%zu,\"quaternions_off\":%zu,\"quaternion_error_max\":",
           s->angles_out, s->quaternions_off + s->bad_quaternions.count);
    pgem_json_number(stdout, s->quaternion_error, 10);
    stats_json_list("quaternions_refused", &s->bad_quaternions);
    int axes = g->dimension == 3 ? 3 : 2, box = have && s->low[0] <= s->high[0];
    stats_json_box("bbox_min", s->low, axes, box);
    stats_json_box("bbox_max", s->high, axes, box);
    printf(",\"verdict\":\"%s\"", stats_verdict(s));
    stats_json_reasons(s, "reasons", 1);
    stats_json_reasons(s, "notes", 0);
    printf("}\n");
}

int pgem_cmd_stats(int argc, char **argv)
{
    const char *path;
    int json;
    int status = stats_parse(argc, argv, &path, &json);
    if (status != PGEM_EXIT_OK) {
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    pgem_io_graph_t graph = {0};
    status = pgem_cli_read_graph("pgem stats", path, PGEM_CLI_LIST_SELF_LOOPS, &graph);
    if (status != PGEM_EXIT_OK) {
        pgem_io_graph_free(&graph);
        return status;
    }
    stats_t *s = calloc(1u, sizeof *s);
    if (s == NULL) {
        fprintf(stderr, "pgem stats: out of memory\n");
        pgem_io_graph_free(&graph);
        return PGEM_EXIT_FAILURE;
    }
    s->path = path;
    s->graph = &graph;
    status = stats_measure(s);
    if (status == PGEM_EXIT_OK) {
        if (json) {
            stats_print_json(s);
        } else {
            stats_print_text(s);
        }
        status = s->level >= STATS_PROBLEM ? PGEM_EXIT_FAILURE : PGEM_EXIT_OK;
    }
    free(s);
    pgem_io_graph_free(&graph);
    return status;
}
