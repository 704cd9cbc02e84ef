/* pgem plot: draws a pose graph as SVG, its loop closures coloured by the verdict of a robust
 * solve (the weights file) and, given the injected false loops, by whether that verdict was
 * right. Reading and classifying are here; the drawing is in plot_svg.c. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "eval.h"
#include "plot.h"

#define PLOT_DEFAULT_WIDTH 1000u     /* pixels, one graph */
#define PLOT_DEFAULT_WIDTH_PAIR 1600u /* pixels, two panels across */
#define PLOT_MIN_WIDTH 200u
#define PLOT_MAX_WIDTH 20000u

/* Command-line choices of one picture. */
typedef struct plot_args {
    const char *graph;           /* the graph to draw (the result) */
    const char *output;          /* SVG file */
    const char *weights;         /* 'from to weight state' per loop (NULL: all accepted) */
    const char *outliers;        /* false loops, 'from to' per line (NULL: unknown) */
    const char *truth;           /* ground truth graph (NULL: none) */
    const char *before;          /* initial graph for a before/after pair (NULL: none) */
    const char *title;           /* NULL: GRAPH's file name */
    uint32_t width;              /* 0: the default */
} plot_args_t;

/* A graph with its poses sorted by id, its odometry edge count, and a rigid motion applied
 * to its positions: p -> R (p - from) + to (the identity unless aligned). */
typedef struct plot_source {
    pgem_io_graph_t file;
    pgem_io_pose_index_t *ids;
    size_t odometry;             /* odometry edges (0: none) */
    int aligned;
    double rotation[4];
    double from[3];
    double to[3];
} plot_source_t;

/* The loop closures to draw, with their verdicts. */
typedef struct plot_loops {
    eval_loop_t *items;
    size_t count;
    const char *path;            /* where they came from: the weights file or GRAPH */
    size_t outliers;             /* lines of the outliers file */
    int judged;                  /* from a weights file */
    int known;                   /* the false ones are marked (outliers file) */
} plot_loops_t;

static void plot_help(FILE *out, const void *context)
{
    (void)context;
    fprintf(out,
            "usage: pgem plot GRAPH -o FILE.svg [--weights W] [--outliers O] [--truth T]\n"
            "                 [--before INITIAL] [--title TEXT] [--width PX]\n"
            "\n"
            "Draws a pose graph (g2o 2D/3D or TORO) as an SVG picture in the manner of figure 1\n"
            "of Lee, Fraundorfer & Pollefeys (IROS 2013): odometry blue, loop closures accepted\n"
            "green and rejected red. A 3D graph gets two panels side by side, the top (x-y)\n"
            "and the side (x-z) projection. Panels keep an equal aspect ratio and each graph\n"
            "has a scale bar; the legend counts each kind of line.\n"
            "\n"
            "  --weights W       the file pgem optimize --weights writes, one 'from to weight\n"
            "                    state' line per loop closure: its lines are the loops drawn,\n"
            "                    and one is rejected if pruned or its weight is below %g.\n"
            "                    Without it the loop closures of GRAPH are drawn, all green.\n"
            "  --outliers O      the false loops pgem corrupt lists, one 'from to' per line,\n"
            "                    matched as pgem eval matches them. With --weights: false loops\n"
            "                    rejected red, true loops rejected orange and dashed, false\n"
            "                    loops accepted (missed) magenta and thick. Without: false\n"
            "                    loops magenta.\n"
            "  --truth T         ground truth, another graph file: poses matched by id, rigidly\n"
            "                    aligned to GRAPH (the alignment of pgem eval's ATE) and drawn\n"
            "                    in grey beneath, along GRAPH's odometry chain\n"
            "  --before INITIAL  a before/after pair: INITIAL (e.g. the corrupted input with\n"
            "                    its initial guess) on the left, GRAPH on the right, the same\n"
            "                    loops in the same colours\n"
            "  --title TEXT      the title (default: GRAPH's file name)\n"
            "  --width PX        width of the picture in pixels, %u to %u (default %u; %u\n"
            "                    for a 3D graph or with --before)\n"
            "  -o FILE.svg       the picture to write (required)\n"
            "\n"
            "The odometry chain is GRAPH's odometry edges in file order (consecutive poses in\n"
            "file order if it has none). Exit codes: 0 success, 1 an input was rejected (the\n"
            "message names the file and line), 2 bad command line, 3 a file could not be read\n"
            "or written.\n",
            PGEM_EVAL_REJECT_BELOW, PLOT_MIN_WIDTH, PLOT_MAX_WIDTH, PLOT_DEFAULT_WIDTH,
            PLOT_DEFAULT_WIDTH_PAIR);
}

static int plot_width(const char *name, const char *value, uint32_t *width)
{
    if (!pgem_cli_parse_u32("pgem", name, value, width)) {
        return 0;
    }
    if (*width < PLOT_MIN_WIDTH || *width > PLOT_MAX_WIDTH) {
        fprintf(stderr, "pgem plot: --width takes %u to %u pixels, got %s\n", PLOT_MIN_WIDTH,
                PLOT_MAX_WIDTH, value);
        return 0;
    }
    return 1;
}

static int plot_value(void *user, const char *name, const char *value)
{
    plot_args_t *args = user;
    const char **field = strcmp(name, "-o") == 0         ? &args->output
                         : strcmp(name, "--weights") == 0  ? &args->weights
                         : strcmp(name, "--outliers") == 0 ? &args->outliers
                         : strcmp(name, "--truth") == 0    ? &args->truth
                         : strcmp(name, "--before") == 0   ? &args->before
                         : strcmp(name, "--title") == 0    ? &args->title
                                                           : NULL;
    if (value == NULL) {
        fprintf(stderr, "pgem plot: %s needs a value\n", name);
        return 0;
    }
    if (field == NULL) { /* --width */
        return plot_width(name, value, &args->width);
    }
    *field = value;
    return 1;
}

static int plot_positional(void *user, const char *argument)
{
    return pgem_cli_one_file("pgem plot", "graph", &((plot_args_t *)user)->graph, argument);
}

/* Returns PGEM_EXIT_OK, an exit code, or -1 after --help. */
static int plot_parse(int argc, char **argv, plot_args_t *args)
{
    static const char *const valued[] = {"-o",     "--weights", "--outliers", "--truth",
                                         "--before", "--title", "--width"};
    const pgem_cli_parser_t parser = {
        "pgem plot", valued, sizeof valued / sizeof valued[0], plot_value, NULL, plot_positional,
        plot_help, NULL, NULL};
    memset(args, 0, sizeof *args);
    if (argc < 2) {
        plot_help(stderr, NULL);
        return PGEM_EXIT_USAGE;
    }
    const int status = pgem_cli_parse_args(&parser, args, argc, argv);
    if (status != 0) {
        return status;
    }
    if (args->graph == NULL || args->output == NULL) {
        fprintf(stderr, "pgem plot: GRAPH and -o FILE.svg are required (see pgem plot --help)\n");
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

/* Reads a graph file, sorts its pose ids and counts its odometry edges. Prints errors;
 * returns a PGEM_EXIT_* code. */
static int plot_read(const char *path, plot_source_t *source)
{
    memset(source, 0, sizeof *source);
    source->rotation[3] = 1.0;
    const unsigned flags = PGEM_CLI_NEED_POSES | PGEM_CLI_WARN_CHAINED;
    int status = pgem_cli_read_graph("pgem plot", path, flags, &source->file);
    if (status != PGEM_EXIT_OK) {
        return status;
    }
    source->ids = pgem_io_index_poses(&source->file);
    if (source->ids == NULL) {
        fprintf(stderr, "pgem plot: out of memory\n");
        return PGEM_EXIT_FAILURE;
    }
    for (size_t k = 0; k < source->file.edge_count; k++) {
        source->odometry += (size_t)(source->file.edges[k].kind == PGEM_EDGE_ODOMETRY);
    }
    return PGEM_EXIT_OK;
}

static void plot_release(plot_source_t *source)
{
    pgem_io_graph_free(&source->file);
    free(source->ids);
    source->ids = NULL;
}

/* The (moved) position of pose id; returns 0 when the graph has no such pose. */
static int plot_position(const plot_source_t *source, pgem_id_t id, double out[3])
{
    size_t index = pgem_io_find_pose(source->ids, source->file.pose_count, id);
    if (index == PGEM_IO_NO_POSE) {
        return 0;
    }
    const double *pose = source->file.poses[index].pose;
    out[0] = pose[0];
    out[1] = pose[1];
    out[2] = source->file.dimension == 3 ? pose[2] : 0.0;
    if (source->aligned) {
        for (int d = 0; d < 3; d++) {
            out[d] -= source->from[d];
        }
        pgem_quat_rotate(source->rotation, out, out);
        for (int d = 0; d < 3; d++) {
            out[d] += source->to[d];
        }
    }
    return 1;
}

/* Adds the segment from id a to id b, continuing the last stroke when it ended at a. A pose
 * missing from the source breaks the stroke. Returns 0 when out of memory. */
static int plot_chain_step(const plot_source_t *source, pgem_id_t a, pgem_id_t b,
                           plot_lines_t *lines, int *open, pgem_id_t *last)
{
    double p[3], q[3];
    if (!plot_position(source, a, p) || !plot_position(source, b, q)) {
        *open = 0;
        return 1;
    }
    int ok = 1;
    if (!*open || *last != a) {
        ok = plot_lines_add(lines, p, 1);
    }
    ok = ok && plot_lines_add(lines, q, 0);
    *open = 1;
    *last = b;
    return ok;
}

/* The odometry chain of `topology` (its odometry edges in file order, or its poses in file
 * order when it has none) drawn at the positions of `source`. Returns 0 when out of memory. */
static int plot_chain(const plot_source_t *topology, const plot_source_t *source,
                      plot_lines_t *lines)
{
    const pgem_io_graph_t *file = &topology->file;
    int open = 0, ok = 1;
    pgem_id_t last = 0;
    if (topology->odometry == 0) {
        for (size_t k = 0; ok && k + 1u < file->pose_count; k++) {
            ok = plot_chain_step(source, file->poses[k].id, file->poses[k + 1u].id, lines, &open,
                                 &last);
        }
        return ok;
    }
    for (size_t k = 0; ok && k < file->edge_count; k++) {
        const pgem_io_edge_t *edge = &file->edges[k];
        if (edge->kind == PGEM_EDGE_ODOMETRY) {
            ok = plot_chain_step(source, edge->from, edge->to, lines, &open, &last);
        }
    }
    return ok;
}

/* The loops to draw: the weights lines, or GRAPH's loop closures (all accepted); the false
 * ones marked from the outliers file. Prints errors; returns a PGEM_EXIT_* code. */
static int plot_collect_loops(const plot_args_t *args, const plot_source_t *source,
                              plot_loops_t *loops)
{
    const pgem_io_graph_t *graph = &source->file;
    int status = PGEM_EXIT_OK;
    memset(loops, 0, sizeof *loops);
    if (args->weights != NULL) {
        loops->path = args->weights;
        loops->judged = 1;
        status = pgem_eval_read_weights(args->weights, &loops->items, &loops->count);
        size_t in_graph = graph->edge_count - source->odometry;
        if (status == PGEM_EXIT_OK && loops->count != in_graph) {
            fprintf(stderr, "pgem plot: warning: %s lists %zu loop closures, %s has %zu\n",
                    args->weights, loops->count, args->graph, in_graph);
        }
    } else {
        loops->path = args->graph;
        loops->items = malloc((graph->edge_count > 0 ? graph->edge_count : 1u) *
                              sizeof *loops->items);
        if (loops->items == NULL) {
            fprintf(stderr, "pgem plot: out of memory\n");
            return PGEM_EXIT_FAILURE;
        }
        for (size_t k = 0; k < graph->edge_count; k++) {
            const pgem_io_edge_t *edge = &graph->edges[k];
            if (edge->kind == PGEM_EDGE_LOOP) {
                eval_loop_t loop = {edge->from, edge->to, 1.0, edge->line, 0, 0, 0};
                loops->items[loops->count++] = loop;
            }
        }
    }
    if (status == PGEM_EXIT_OK && args->outliers != NULL) {
        loops->known = 1;
        status = pgem_eval_mark_outliers(args->outliers, loops->path, loops->items, loops->count,
                                         &loops->outliers);
    }
    if (status == PGEM_EXIT_OK && loops->judged) {
        pgem_eval_mark_rejected(loops->items, loops->count, PGEM_EVAL_REJECT_BELOW);
    }
    return status;
}

static plot_style_t plot_classify(const plot_loops_t *loops, const eval_loop_t *loop)
{
    if (loop->is_false) {
        return loop->rejected ? PLOT_REJECTED : PLOT_MISSED;
    }
    if (loop->rejected) {
        return loops->known ? PLOT_TRUE_REJECTED : PLOT_REJECTED;
    }
    return PLOT_ACCEPTED;
}

/* Adds every loop at the positions of source, by class; counts them per class when counts is
 * not NULL. Prints errors; returns a PGEM_EXIT_* code. */
static int plot_add_loops(const plot_loops_t *loops, const plot_source_t *source,
                          plot_graph_t *drawn, size_t counts[PLOT_STYLE_COUNT])
{
    for (size_t k = 0; k < loops->count; k++) {
        const eval_loop_t *loop = &loops->items[k];
        double p[3], q[3];
        int have_from = plot_position(source, loop->from, p);
        if (!have_from || !plot_position(source, loop->to, q)) {
            fprintf(stderr, "pgem plot: %s:%lu: loop %llu %llu: pose %llu is not in %s\n",
                    loops->path, loop->line, (unsigned long long)loop->from,
                    (unsigned long long)loop->to,
                    (unsigned long long)(have_from ? loop->to : loop->from), source->file.source);
            return PGEM_EXIT_FAILURE;
        }
        plot_style_t style = plot_classify(loops, loop);
        plot_lines_t *lines = &drawn->lines[style];
        if (!plot_lines_add(lines, p, 1) || !plot_lines_add(lines, q, 0)) {
            fprintf(stderr, "pgem plot: out of memory\n");
            return PGEM_EXIT_FAILURE;
        }
        if (counts != NULL) {
            counts[style]++;
        }
    }
    return PGEM_EXIT_OK;
}

static const char *plot_basename(const char *path)
{
    const char *slash = strrchr(path, '/');
    return slash != NULL ? slash + 1 : path;
}

/* The legend's texts: what each kind of line is, with its count. */
static void plot_legend(const plot_args_t *args, const plot_loops_t *loops, size_t odometry,
                        size_t truth_matched, const size_t counts[PLOT_STYLE_COUNT],
                        plot_figure_t *figure)
{
    char (*legend)[160] = figure->legend;
    const size_t size = sizeof figure->legend[0];
    size_t accepted = counts[PLOT_ACCEPTED], rejected = counts[PLOT_REJECTED];
    size_t true_rejected = counts[PLOT_TRUE_REJECTED], missed = counts[PLOT_MISSED];
    snprintf(legend[PLOT_ODOMETRY], size, "%zu odometry edge%s", odometry,
             pgem_cli_plural(odometry));
    if (args->truth != NULL) {
        snprintf(legend[PLOT_TRUTH], size, "ground truth, rigidly aligned (%zu pose%s matched)",
                 truth_matched, pgem_cli_plural(truth_matched));
    }
    if (!loops->judged) {
        snprintf(legend[PLOT_ACCEPTED], size, "%zu %sloop closure%s (no weights: none rejected)",
                 accepted, loops->known ? "true " : "", pgem_cli_plural(accepted));
        if (loops->known) {
            snprintf(legend[PLOT_MISSED], size, "%zu false loop%s", missed,
                     pgem_cli_plural(missed));
        }
        return;
    }
    if (!loops->known) {
        snprintf(legend[PLOT_ACCEPTED], size, "%zu loop%s accepted", accepted,
                 pgem_cli_plural(accepted));
        snprintf(legend[PLOT_REJECTED], size, "%zu loop%s rejected (pruned or weight < %g)",
                 rejected, pgem_cli_plural(rejected), PGEM_EVAL_REJECT_BELOW);
        return;
    }
    snprintf(legend[PLOT_ACCEPTED], size, "%zu true loop%s accepted", accepted,
             pgem_cli_plural(accepted));
    snprintf(legend[PLOT_REJECTED], size, "%zu false loop%s rejected", rejected,
             pgem_cli_plural(rejected));
    snprintf(legend[PLOT_TRUE_REJECTED], size, "%zu true loop%s rejected", true_rejected,
             pgem_cli_plural(true_rejected));
    snprintf(legend[PLOT_MISSED], size, "%zu false loop%s accepted (missed)", missed,
             pgem_cli_plural(missed));
}

/* Reads a graph drawn with GRAPH (--truth, --before) and checks its dimension. */
static int plot_read_beside(const plot_args_t *args, const plot_source_t *graph, const char *path,
                            plot_source_t *source)
{
    int status = plot_read(path, source);
    if (status == PGEM_EXIT_OK && source->file.dimension != graph->file.dimension) {
        fprintf(stderr, "pgem plot: dimensions differ: %s is %dD, %s is %dD\n", args->graph,
                graph->file.dimension, path, source->file.dimension);
        status = PGEM_EXIT_FAILURE;
    }
    return status;
}

/* Reads --truth, checks it against GRAPH and aligns it rigidly to GRAPH. */
static int plot_read_truth(const plot_args_t *args, const plot_source_t *graph,
                           plot_source_t *truth, size_t *matched)
{
    int status = plot_read_beside(args, graph, args->truth, truth);
    if (status != PGEM_EXIT_OK) {
        return status;
    }
    status = pgem_eval_align(&graph->file, &truth->file, truth->ids, truth->rotation, truth->to,
                             truth->from, matched);
    if (status == PGEM_EXIT_OK && *matched == 0) {
        fprintf(stderr, "pgem plot: no pose id of %s is in %s\n", args->truth, args->graph);
        status = PGEM_EXIT_FAILURE;
    }
    truth->aligned = 1;
    return status;
}

/* Title, subtitle and captions. */
static void plot_texts(const plot_args_t *args, const plot_source_t *graph,
                       const plot_loops_t *loops, plot_figure_t *figure)
{
    snprintf(figure->title, sizeof figure->title, "%s",
             args->title != NULL ? args->title : plot_basename(args->graph));
    snprintf(figure->subtitle, sizeof figure->subtitle, "%dD, %zu poses, %zu loop closures%s%s",
             graph->file.dimension, graph->file.pose_count, loops->count,
             loops->judged ? ", verdicts from " : "",
             loops->judged ? plot_basename(args->weights) : "");
    if (args->before != NULL) {
        snprintf(figure->graphs[0].caption, sizeof figure->graphs[0].caption, "before: %s",
                 plot_basename(args->before));
        snprintf(figure->graphs[1].caption, sizeof figure->graphs[1].caption, "after: %s",
                 plot_basename(args->graph));
    }
}

/* Builds the figure from the files named by args. Prints errors; returns a PGEM_EXIT_* code. */
static int plot_build(const plot_args_t *args, plot_figure_t *figure)
{
    plot_source_t graph, truth, before;
    plot_loops_t loops = {NULL, 0u, NULL, 0u, 0, 0};
    size_t counts[PLOT_STYLE_COUNT] = {0}, matched = 0;
    memset(&truth, 0, sizeof truth);
    memset(&before, 0, sizeof before);
    int status = plot_read(args->graph, &graph);
    if (status == PGEM_EXIT_OK && args->before != NULL) {
        status = plot_read_beside(args, &graph, args->before, &before);
    }
    if (status == PGEM_EXIT_OK && args->truth != NULL) {
        status = plot_read_truth(args, &graph, &truth, &matched);
    }
    if (status == PGEM_EXIT_OK) {
        status = plot_collect_loops(args, &graph, &loops);
    }
    figure->dimension = graph.file.dimension;
    figure->graph_count = args->before != NULL ? 2u : 1u;
    plot_graph_t *result = &figure->graphs[figure->graph_count - 1u];
    if (status == PGEM_EXIT_OK && args->before != NULL) {
        status = plot_add_loops(&loops, &before, &figure->graphs[0], NULL);
    }
    if (status == PGEM_EXIT_OK) {
        status = plot_add_loops(&loops, &graph, result, counts);
    }
    if (status == PGEM_EXIT_OK) {
        int ok = plot_chain(&graph, &graph, &result->lines[PLOT_ODOMETRY]);
        ok = ok && (args->truth == NULL || plot_chain(&graph, &truth, &result->lines[PLOT_TRUTH]));
        ok = ok && (args->before == NULL ||
                    plot_chain(&before, &before, &figure->graphs[0].lines[PLOT_ODOMETRY]));
        if (!ok) {
            fprintf(stderr, "pgem plot: out of memory\n");
            status = PGEM_EXIT_FAILURE;
        }
    }
    if (status == PGEM_EXIT_OK) {
        size_t odometry = graph.odometry > 0 ? graph.odometry : graph.file.pose_count - 1u;
        plot_legend(args, &loops, odometry, matched, counts, figure);
        plot_texts(args, &graph, &loops, figure);
    }
    free(loops.items);
    plot_release(&graph);
    plot_release(&truth);
    plot_release(&before);
    return status;
}

static int plot_write(const plot_args_t *args, const plot_figure_t *figure)
{
    pgem_cli_file_t out;
    if (pgem_cli_file_open(&out, "pgem plot", args->output) != 0) {
        return PGEM_EXIT_IO;
    }
    return pgem_cli_file_commit(&out, plot_write_svg(figure, out.stream) != 0);
}

int pgem_cmd_plot(int argc, char **argv)
{
    plot_args_t args;
    int status = plot_parse(argc, argv, &args);
    if (status != PGEM_EXIT_OK) {
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    plot_figure_t *figure = calloc(1u, sizeof *figure);
    if (figure == NULL) {
        fprintf(stderr, "pgem plot: out of memory\n");
        return PGEM_EXIT_FAILURE;
    }
    status = plot_build(&args, figure);
    unsigned width = figure->graph_count > 1u || figure->dimension == 3 ? PLOT_DEFAULT_WIDTH_PAIR
                                                                        : PLOT_DEFAULT_WIDTH;
    figure->width = args.width != 0 ? args.width : width;
    if (status == PGEM_EXIT_OK) {
        status = plot_write(&args, figure);
    }
    plot_figure_free(figure);
    free(figure);
    return status;
}
