/* pgem eval: scores an optimized graph against a reference (ATE after a rigid alignment, RPE,
 * extent) and, given the injected false loops and the weights pgem optimize wrote, how well
 * the loop closures were rejected. The measures are in eval_trajectory.c and eval_loops.c. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "eval.h"

/* Command-line choices of one evaluation. */
typedef struct eval_args {
    const char *result;          /* optimized graph */
    const char *reference;       /* ground truth or a trusted solve */
    const char *outliers;        /* false loops, 'from to' per line (NULL: no loop scoring) */
    const char *weights;         /* 'from to weight state' per loop (NULL: no loop scoring) */
    double reject_below;         /* a loop with a smaller weight counts as rejected */
    int reject_given;            /* --reject-below was on the command line */
    int list;                    /* print the misclassified loops */
    int json;                    /* one JSON object on stdout */
} eval_args_t;

static void eval_help(FILE *out, const void *context)
{
    (void)context;
    fprintf(out,
            "usage: pgem eval RESULT --reference REF\n"
            "                 [--outliers OUT.outliers --weights W.txt] [--reject-below T]\n"
            "                 [--list] [--json]\n"
            "\n"
            "Scores the poses of RESULT against REF (ground truth or a trusted solve). Both\n"
            "are graph files pgem reads (g2o 2D/3D, TORO 2D); only their poses are used, so\n"
            "vertex-only files are fine. Poses are matched by id (at least 2 must match); the\n"
            "report says how many matched and how many are in only one file.\n"
            "\n"
            "  ATE     RESULT rigidly aligned to REF (least-squares rotation and translation\n"
            "          of the matched positions, no scale), then the RMSE of the position\n"
            "          error (m) and the RMS rotation error (deg, angle of R_ref^T R_aligned)\n"
            "  RPE     for consecutive matched poses in REF's order, the relative-motion\n"
            "          error delta_ref^-1 delta_result: RMSE of its translation (m) and RMS\n"
            "          of its rotation (deg); no alignment\n"
            "  extent  RMS distance of REF's matched positions from their centroid (m);\n"
            "          ate_relative = ATE translation / extent (JSON null if the extent is 0)\n"
            "\n"
            "Loop-closure rejection, when both files are given:\n"
            "  --outliers FILE   the false loops, one 'from to' per line, as pgem corrupt\n"
            "                    writes them ('#' lines and blank lines ignored)\n"
            "  --weights FILE    one 'from to weight state' line per loop closure (state\n"
            "                    accepted or pruned), as pgem optimize --weights writes them\n"
            "  --reject-below T  a loop is rejected if pruned or its weight is below T\n"
            "                    (default 0.01, the EM prune threshold; Cauchy and DCS never\n"
            "                    prune, they only down-weight, so T decides for them)\n"
            "  --list            also print the false negatives and false positives\n"
            "Pairs are ordered (from, to) and matched as a multiset: when a pair occurs more\n"
            "often in the weights than in the outliers, its later lines are the false loops\n"
            "(corrupt appends them after the original edges). A false loop missing from the\n"
            "weights is an error, and so are weights that are not RESULT's: when RESULT has\n"
            "edges, the weights must list exactly its loop closures (the same (from, to)\n"
            "pairs, as often; a vertex-only RESULT is taken at its word).\n"
            "The headline score takes the rejected loops as positives: precision = TP /\n"
            "rejected, recall = TP / outliers (TP: false loops rejected, FP: true loops\n"
            "rejected, FN: false loops accepted). Precision is 1 when nothing is rejected\n"
            "(recall then shows any miss), recall 1 when there are no outliers. Also printed,\n"
            "with the accepted loops as positives: inlier_precision = true loops accepted /\n"
            "loops accepted, inlier_recall = true loops accepted / true loops (1 if empty).\n"
            "\n"
            "  --json            print one JSON object on stdout\n"
            "\n"
            "Exit codes: 0 success, 1 an input was rejected (the message names the file and\n"
            "line), 2 bad command line, 3 a file could not be read.\n");
}

/* A non-negative finite number; prints an error and returns 0 on failure. */
static int eval_parse_threshold(const char *option, const char *text, double *value)
{
    if (text == NULL) {
        fprintf(stderr, "pgem eval: %s needs a non-negative number\n", option);
        return 0;
    }
    return pgem_cli_parse_number("pgem eval", option, text, 0, value);
}

static int eval_check_args(const eval_args_t *args)
{
    if (args->result == NULL || args->reference == NULL) {
        fprintf(stderr,
                "pgem eval: RESULT and --reference REF are required (see pgem eval --help)\n");
        return PGEM_EXIT_USAGE;
    }
    if ((args->outliers == NULL) != (args->weights == NULL)) {
        fprintf(stderr, "pgem eval: --outliers and --weights go together (%s given alone)\n",
                args->outliers != NULL ? "--outliers" : "--weights");
        return PGEM_EXIT_USAGE;
    }
    if (args->outliers == NULL && (args->reject_given || args->list)) {
        fprintf(stderr, "pgem eval: %s needs --outliers and --weights\n",
                args->list ? "--list" : "--reject-below");
        return PGEM_EXIT_USAGE;
    }
    return PGEM_EXIT_OK;
}

static int eval_value(void *user, const char *name, const char *value)
{
    eval_args_t *args = user;
    if (strcmp(name, "--reject-below") == 0) {
        return args->reject_given = eval_parse_threshold(name, value, &args->reject_below);
    }
    const char **field = strcmp(name, "--reference") == 0  ? &args->reference
                         : strcmp(name, "--outliers") == 0 ? &args->outliers
                                                           : &args->weights;
    return pgem_cli_text_value("pgem eval", name, value, "a file name", field);
}

static int eval_flag(void *user, const char *name)
{
    eval_args_t *args = user;
    int *field = strcmp(name, "--list") == 0 ? &args->list
                 : strcmp(name, "--json") == 0 ? &args->json
                                               : NULL;
    if (field != NULL) {
        *field = 1;
    }
    return field != NULL;
}

static int eval_positional(void *user, const char *argument)
{
    return pgem_cli_one_file("pgem eval", "result", &((eval_args_t *)user)->result, argument);
}

/* Returns PGEM_EXIT_OK, an exit code, or -1 after --help. */
static int eval_parse(int argc, char **argv, eval_args_t *args)
{
    static const char *const valued[] = {"--reference", "--outliers", "--weights",
                                         "--reject-below"};
    const pgem_cli_parser_t parser = {
        "pgem eval", valued, sizeof valued / sizeof valued[0], eval_value, eval_flag,
        eval_positional, eval_help, NULL, NULL};
    memset(args, 0, sizeof *args);
    args->reject_below = PGEM_EVAL_REJECT_BELOW;
    if (argc < 2) {
        eval_help(stderr, NULL);
        return PGEM_EXIT_USAGE;
    }
    const int status = pgem_cli_parse_args(&parser, args, argc, argv);
    return status != 0 ? status : eval_check_args(args);
}

/* ,"key":value with 10 digits (null for a value JSON cannot hold). */
static void eval_json_number(const char *key, double value)
{
    printf(",\"%s\":", key);
    pgem_json_number(stdout, value, 10);
}

static void eval_json_list(const char *key, const eval_loop_t *loops, size_t count, int is_false)
{
    const char *separator = "";
    printf(",\"%s\":[", key);
    for (size_t k = 0; k < count; k++) {
        if (loops[k].is_false == is_false && loops[k].rejected != is_false) {
            printf("%s[%llu,%llu]", separator, (unsigned long long)loops[k].from,
                   (unsigned long long)loops[k].to);
            separator = ",";
        }
    }
    putchar(']');
}

static double eval_relative(const eval_trajectory_t *t)
{
    return t->extent > 0.0 ? t->ate_translation / t->extent : (double)NAN;
}

static void eval_print_json(const eval_args_t *args, const eval_trajectory_t *t,
                            const eval_scores_t *scores, const eval_loop_t *loops)
{
    printf("{\"result\":");
    pgem_json_string(stdout, args->result);
    printf(",\"reference\":");
    pgem_json_string(stdout, args->reference);
    printf(",\"dimension\":%d,\"poses_matched\":%zu,\"poses_only_result\":%zu,"
           "\"poses_only_reference\":%zu",
           t->dimension, t->matched, t->only_result, t->only_reference);
    eval_json_number("ate_translation_rmse", t->ate_translation);
    eval_json_number("ate_rotation_rmse_deg", t->ate_rotation_deg);
    eval_json_number("rpe_translation_rmse", t->rpe_translation);
    eval_json_number("rpe_rotation_rmse_deg", t->rpe_rotation_deg);
    eval_json_number("extent_rms", t->extent);
    eval_json_number("ate_relative", eval_relative(t));
    if (scores != NULL) {
        printf(",\"loops\":%zu,\"outliers\":%zu,\"rejected\":%zu,\"true_positives\":%zu,"
               "\"false_positives\":%zu,\"false_negatives\":%zu",
               scores->loops, scores->outliers, scores->rejected, scores->true_positives,
               scores->false_positives, scores->false_negatives);
        eval_json_number("precision", scores->precision);
        eval_json_number("recall", scores->recall);
        eval_json_number("inlier_precision", scores->inlier_precision);
        eval_json_number("inlier_recall", scores->inlier_recall);
        eval_json_number("reject_below", args->reject_below);
        if (args->list) {
            eval_json_list("false_negative_pairs", loops, scores->loops, 1);
            eval_json_list("false_positive_pairs", loops, scores->loops, 0);
        }
    }
    printf("}\n");
}

static void eval_print_list(const char *what, const eval_args_t *args, const eval_loop_t *loops,
                            size_t count, int is_false)
{
    for (size_t k = 0; k < count; k++) {
        if (loops[k].is_false == is_false && loops[k].rejected != is_false) {
            printf("%-10s %llu %llu (weight %.6g, %s, %s line %lu)\n", what,
                   (unsigned long long)loops[k].from, (unsigned long long)loops[k].to,
                   loops[k].weight, loops[k].pruned ? "pruned" : "accepted", args->weights,
                   loops[k].line);
        }
    }
}

static void eval_print_text(const eval_args_t *args, const eval_trajectory_t *t,
                            const eval_scores_t *scores, const eval_loop_t *loops)
{
    printf("result     %s (%dD)\nreference  %s\n", args->result, t->dimension, args->reference);
    printf("poses      %zu matched, %zu only in the result, %zu only in the reference\n",
           t->matched, t->only_result, t->only_reference);
    printf("ATE        %.6g m RMSE, %.6g deg RMS rotation (rigid alignment, no scale)\n",
           t->ate_translation, t->ate_rotation_deg);
    printf("RPE        %.6g m RMSE, %.6g deg RMS rotation (consecutive poses)\n",
           t->rpe_translation, t->rpe_rotation_deg);
    if (t->extent > 0.0) {
        printf("extent     %.6g m RMS; ATE / extent %.6g\n", t->extent, eval_relative(t));
    } else {
        printf("extent     0 m (all matched reference positions coincide); ATE / extent n/a\n");
    }
    if (scores == NULL) {
        return;
    }
    printf("loops      %zu, %zu false; %zu rejected (pruned or weight < %g)\n", scores->loops,
           scores->outliers, scores->rejected, args->reject_below);
    printf("rejection  precision %.6g, recall %.6g (TP %zu, FP %zu, FN %zu; positives: rejected)\n",
           scores->precision, scores->recall, scores->true_positives, scores->false_positives,
           scores->false_negatives);
    printf("inliers    precision %.6g, recall %.6g (positives: accepted)\n",
           scores->inlier_precision, scores->inlier_recall);
    if (args->list) {
        eval_print_list("false-neg", args, loops, scores->loops, 1);
        eval_print_list("false-pos", args, loops, scores->loops, 0);
    }
}

/* A loop closure's pair and where it came from, for matching the weights to the result. */
typedef struct eval_pair {
    pgem_id_t from;
    pgem_id_t to;
    unsigned long line;
} eval_pair_t;

static int eval_pair_compare(const void *a, const void *b)
{
    const eval_pair_t *x = a, *y = b;
    if (x->from != y->from) {
        return x->from < y->from ? -1 : 1;
    }
    if (x->to != y->to) {
        return x->to < y->to ? -1 : 1;
    }
    return (x->line > y->line) - (x->line < y->line);
}

/* The weights must be the result's: when the result has edges, its loop closures and the
 * weights lines are the same multiset of (from, to) pairs (pgem optimize writes them from the
 * same graph; the order may differ where the writer puts a pair's odometry first). A vertex-
 * only result cannot vouch for them, and they are taken as given. Prints the first mismatch,
 * naming the file, the line and the ids; returns a PGEM_EXIT_* code. */
static int eval_weights_belong(const eval_args_t *args, const pgem_io_graph_t *result,
                               const eval_loop_t *loops, size_t count)
{
    if (result->edge_count == 0) {
        return PGEM_EXIT_OK;
    }
    size_t graph_loops = 0;
    for (size_t e = 0; e < result->edge_count; e++) {
        graph_loops += result->edges[e].kind == PGEM_EDGE_LOOP;
    }
    eval_pair_t *mine = malloc((graph_loops + count + 1) * sizeof *mine);
    if (mine == NULL) {
        fprintf(stderr, "pgem eval: out of memory\n");
        return PGEM_EXIT_FAILURE;
    }
    eval_pair_t *theirs = mine + graph_loops;
    size_t n = 0;
    for (size_t e = 0; e < result->edge_count; e++) {
        if (result->edges[e].kind == PGEM_EDGE_LOOP) {
            mine[n++] = (eval_pair_t){result->edges[e].from, result->edges[e].to,
                                      result->edges[e].line};
        }
    }
    for (size_t k = 0; k < count; k++) {
        theirs[k] = (eval_pair_t){loops[k].from, loops[k].to, loops[k].line};
    }
    qsort(mine, graph_loops, sizeof *mine, eval_pair_compare);
    qsort(theirs, count, sizeof *theirs, eval_pair_compare);
    size_t i = 0, j = 0;
    while (i < graph_loops && j < count && mine[i].from == theirs[j].from &&
           mine[i].to == theirs[j].to) {
        i++;
        j++;
    }
    int status = PGEM_EXIT_OK;
    if (i < graph_loops || j < count) {
        const int extra = j < count && (i == graph_loops || theirs[j].from < mine[i].from ||
                                         (theirs[j].from == mine[i].from &&
                                          theirs[j].to < mine[i].to));
        if (extra) {
            fprintf(stderr, "pgem eval: %s:%lu: loop closure %llu -> %llu is not a loop closure "
                    "of %s (it has %zu, %s lists %zu): the weights belong to another graph\n",
                    args->weights, theirs[j].line, (unsigned long long)theirs[j].from,
                    (unsigned long long)theirs[j].to, args->result, graph_loops, args->weights,
                    count);
        } else {
            fprintf(stderr, "pgem eval: %s:%lu: loop closure %llu -> %llu has no line in %s (%s "
                    "has %zu loop closures, %s lists %zu): the weights belong to another "
                    "graph\n", args->result, mine[i].line, (unsigned long long)mine[i].from,
                    (unsigned long long)mine[i].to, args->weights, args->result, graph_loops,
                    args->weights, count);
        }
        status = PGEM_EXIT_FAILURE;
    }
    free(mine);
    return status;
}

static int eval_run(const eval_args_t *args)
{
    pgem_io_graph_t result = {0}, reference = {0};
    eval_trajectory_t trajectory;
    eval_scores_t scores;
    eval_loop_t *loops = NULL;
    int status = pgem_eval_read_graph(args->result, &result);
    if (status == PGEM_EXIT_OK) {
        status = pgem_eval_read_graph(args->reference, &reference);
    }
    if (status == PGEM_EXIT_OK) {
        status = pgem_eval_trajectory(&reference, &result, &trajectory);
    }
    if (status == PGEM_EXIT_OK && args->outliers != NULL) {
        status = pgem_eval_loops(args->outliers, args->weights, args->reject_below, &loops,
                                 &scores);
        if (status == PGEM_EXIT_OK) {
            status = eval_weights_belong(args, &result, loops, scores.loops);
        }
    }
    if (status == PGEM_EXIT_OK) {
        const eval_scores_t *scored = args->outliers != NULL ? &scores : NULL;
        if (args->json) {
            eval_print_json(args, &trajectory, scored, loops);
        } else {
            eval_print_text(args, &trajectory, scored, loops);
        }
    }
    free(loops);
    pgem_io_graph_free(&result);
    pgem_io_graph_free(&reference);
    return status;
}

int pgem_cmd_eval(int argc, char **argv)
{
    eval_args_t args;
    int status = eval_parse(argc, argv, &args);
    if (status != PGEM_EXIT_OK) {
        return status < 0 ? PGEM_EXIT_OK : status;
    }
    return eval_run(&args);
}
