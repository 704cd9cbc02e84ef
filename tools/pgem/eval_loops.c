/* pgem eval, loop rejection: reads the false loops (outliers file) and the per-loop weights,
 * finds the false loops among the weights lines and counts what was rejected. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "eval.h"

#define EVAL_MAX_FIELDS 4 /* fields of a weights line */

/* Pairs here (pgem_cli_pair_t) carry, as index, the index of the loop for the weights and
 * the file line for the outliers. */

/* A text file read line by line. */
typedef struct eval_text {
    FILE *file;
    const char *path;
    char *line;
    size_t capacity;
    unsigned long number;        /* 1-based number of the current line */
} eval_text_t;

static int eval_open(eval_text_t *text, const char *path)
{
    memset(text, 0, sizeof *text);
    text->path = path;
    text->file = fopen(path, "r");
    if (text->file == NULL) {
        fprintf(stderr, "pgem: %s: cannot open: %s\n", path, strerror(errno));
        return PGEM_EXIT_IO;
    }
    return PGEM_EXIT_OK;
}

static void eval_close(eval_text_t *text)
{
    if (text->file != NULL) {
        fclose(text->file);
    }
    free(text->line);
    text->file = NULL;
    text->line = NULL;
}

/* Splits the next line that is neither blank nor a '#' comment into at most max + 1 fields
 * (one more than wanted, to notice extra ones). *count is 0 at the end of the file. */
static int eval_next_line(eval_text_t *text, char **fields, size_t max, size_t *count)
{
    *count = 0;
    for (;;) {
        errno = 0;
        ssize_t length = getline(&text->line, &text->capacity, text->file);
        if (length < 0) {
            if (ferror(text->file) || errno == ENOMEM) {
                fprintf(stderr, "pgem: %s:%lu: read error: %s\n", text->path,
                        text->number + 1u, errno != 0 ? strerror(errno) : "unknown");
                return PGEM_EXIT_IO;
            }
            return PGEM_EXIT_OK;
        }
        text->number++;
        if (strlen(text->line) != (size_t)length) {
            fprintf(stderr, "pgem: %s:%lu: line contains a NUL byte (binary data?)\n",
                    text->path, text->number);
            return PGEM_EXIT_FAILURE;
        }
        char *cursor = text->line;
        while (*count <= max) {
            cursor += strspn(cursor, " \t\r\n");
            if (*cursor == '\0') {
                break;
            }
            fields[(*count)++] = cursor;
            cursor += strcspn(cursor, " \t\r\n");
            if (*cursor != '\0') {
                *cursor++ = '\0';
            }
        }
        if (*count > 0 && fields[0][0] != '#') {
            return PGEM_EXIT_OK;
        }
        *count = 0;
    }
}

/* An unsigned 64-bit decimal id (digits only). */
static int eval_parse_id(const char *text, pgem_id_t *id)
{
    char *end = NULL;
    if (text[0] < '0' || text[0] > '9') {
        return 0;
    }
    errno = 0;
    unsigned long long parsed = strtoull(text, &end, 10);
    if (*end != '\0' || errno != 0) {
        return 0;
    }
    *id = (pgem_id_t)parsed;
    return 1;
}

/* 'from to' of fields[0..1] into a key; prints an error naming the line on failure. */
static int eval_parse_pair(const eval_text_t *text, char **fields, pgem_id_t *from, pgem_id_t *to)
{
    for (int k = 0; k < 2; k++) {
        if (!eval_parse_id(fields[k], k == 0 ? from : to)) {
            fprintf(stderr,
                    "pgem: %s:%lu: field %d (%s) is not an unsigned 64-bit id: '%.40s'\n",
                    text->path, text->number, k + 1, k == 0 ? "from" : "to", fields[k]);
            return 0;
        }
    }
    return 1;
}

/* Room for one more element of `size` bytes; returns the (maybe moved) array or NULL. */
static void *eval_reserve(void *items, size_t *capacity, size_t count, size_t size)
{
    if (count < *capacity) {
        return items;
    }
    size_t grown = *capacity < 64u ? 64u : 2u * *capacity;
    void *moved = realloc(items, grown * size);
    if (moved != NULL) {
        *capacity = grown;
    }
    return moved;
}

/* Parses the fields of one line into *item; prints an error naming the line and returns 0
 * on failure. */
typedef int (*eval_parse_fn)(const eval_text_t *text, char **fields, size_t count, void *item);

/* Reads every line of a file through parse into a grown array of `size`-byte items, in file
 * order (*items is the caller's to free, also on failure). */
static int eval_read_items(const char *path, size_t max_fields, eval_parse_fn parse, size_t size,
                           void **items, size_t *count)
{
    eval_text_t text;
    char *fields[EVAL_MAX_FIELDS + 1] = {NULL};
    union {
        pgem_cli_pair_t pair;
        eval_loop_t loop;
    } item;
    size_t fields_read = 0, capacity = 0;
    int status = eval_open(&text, path);
    *items = NULL;
    *count = 0;
    while (status == PGEM_EXIT_OK) {
        status = eval_next_line(&text, fields, max_fields, &fields_read);
        if (status != PGEM_EXIT_OK || fields_read == 0) {
            break;
        }
        memset(&item, 0, sizeof item);
        if (!parse(&text, fields, fields_read, &item)) {
            status = PGEM_EXIT_FAILURE;
            continue;
        }
        unsigned char *grown = eval_reserve(*items, &capacity, *count, size);
        if (grown == NULL) {
            fprintf(stderr, "pgem: out of memory\n");
            status = PGEM_EXIT_FAILURE;
        } else {
            memcpy(grown + *count * size, &item, size);
            *items = grown;
            ++*count;
        }
    }
    eval_close(&text);
    return status;
}

/* One outliers line (2 fields) into a pair indexed by its line. */
static int eval_parse_outlier(const eval_text_t *text, char **fields, size_t count, void *item)
{
    pgem_cli_pair_t *pair = item;
    if (count != 2u) {
        fprintf(stderr, "pgem: %s:%lu: expected 2 fields 'from to', got %s\n", text->path,
                text->number, count < 2u ? "1" : "more");
        return 0;
    }
    pair->index = text->number;
    return eval_parse_pair(text, fields, &pair->from, &pair->to);
}

/* One weights line (4 fields) into *loop; prints an error naming the line on failure. */
static int eval_parse_loop(const eval_text_t *text, char **fields, size_t count, void *item)
{
    eval_loop_t *loop = item;
    char *end = NULL;
    if (count != 4u) {
        fprintf(stderr, "pgem: %s:%lu: expected 4 fields 'from to weight state', got %s\n",
                text->path, text->number, count < 4u ? "fewer" : "more");
        return 0;
    }
    if (!eval_parse_pair(text, fields, &loop->from, &loop->to)) {
        return 0;
    }
    loop->weight = strtod(fields[2], &end);
    if (end == fields[2] || *end != '\0' || !isfinite(loop->weight)) {
        fprintf(stderr, "pgem: %s:%lu: field 3 (weight) is not a finite number: '%.40s'\n",
                text->path, text->number, fields[2]);
        return 0;
    }
    if (strcmp(fields[3], "accepted") != 0 && strcmp(fields[3], "pruned") != 0) {
        fprintf(stderr,
                "pgem: %s:%lu: field 4 (state) must be accepted or pruned, got '%.40s'\n",
                text->path, text->number, fields[3]);
        return 0;
    }
    loop->pruned = strcmp(fields[3], "pruned") == 0;
    loop->line = text->number;
    return 1;
}

int pgem_eval_read_weights(const char *weights, eval_loop_t **loops, size_t *count)
{
    void *items = NULL;
    int status = eval_read_items(weights, EVAL_MAX_FIELDS, eval_parse_loop, sizeof **loops,
                                 &items, count);
    *loops = items;
    return status;
}

/* The first key at or after `first` that is not ordered before (from, to). */
static size_t eval_skip_before(const pgem_cli_pair_t *keys, size_t count, size_t first,
                               pgem_id_t from, pgem_id_t to)
{
    while (first < count &&
           (keys[first].from < from || (keys[first].from == from && keys[first].to < to))) {
        first++;
    }
    return first;
}

/* The outliers line that found no weights line, and how often its pair occurs in each. */
typedef struct eval_missing {
    const pgem_cli_pair_t *outlier; /* NULL: none */
    size_t listed;               /* times in the outliers file */
    size_t found;                /* times in the weights file */
} eval_missing_t;

static int eval_report_missing(const char *outliers, const char *weights,
                               const eval_missing_t *missing)
{
    const pgem_cli_pair_t *key = missing->outlier;
    if (key == NULL) {
        return PGEM_EXIT_OK;
    }
    if (missing->found == 0) {
        fprintf(stderr, "pgem: %s:%zu: false loop %llu %llu is not in %s\n", outliers,
                key->index, (unsigned long long)key->from, (unsigned long long)key->to, weights);
    } else {
        fprintf(stderr, "pgem: %s:%zu: false loop %llu %llu is listed %zu times but %s has it "
                        "only %zu times\n", outliers, key->index, (unsigned long long)key->from,
                (unsigned long long)key->to, missing->listed, weights, missing->found);
    }
    return PGEM_EXIT_FAILURE;
}

/* Marks the false loops: for each ordered pair listed n times in the outliers, the last n
 * of its lines in the weights. An outlier without a weights line is an error, reported at
 * the earliest such outliers line. Sorts `outliers` by (pair, line). */
static int eval_mark_false(const char *outliers_path, const char *weights_path,
                           pgem_cli_pair_t *outliers, size_t outlier_count, eval_loop_t *loops,
                           size_t loop_count)
{
    pgem_cli_pair_t *keys = malloc((loop_count > 0 ? loop_count : 1u) * sizeof *keys);
    eval_missing_t missing = {NULL, 0u, 0u};
    if (keys == NULL) {
        fprintf(stderr, "pgem: out of memory\n");
        return PGEM_EXIT_FAILURE;
    }
    for (size_t k = 0; k < loop_count; k++) {
        keys[k] = (pgem_cli_pair_t){loops[k].from, loops[k].to, k};
    }
    pgem_cli_sort_pairs(keys, loop_count);
    pgem_cli_sort_pairs(outliers, outlier_count);
    for (size_t o = 0, w = 0; o < outlier_count;) {
        pgem_id_t from = outliers[o].from, to = outliers[o].to;
        size_t o_end = pgem_cli_pair_run_end(outliers, outlier_count, o, from, to);
        w = eval_skip_before(keys, loop_count, w, from, to);
        size_t w_end = pgem_cli_pair_run_end(keys, loop_count, w, from, to);
        size_t listed = o_end - o, found = w_end - w;
        if (listed > found) {
            const pgem_cli_pair_t *first_missing = &outliers[o + found];
            if (missing.outlier == NULL || first_missing->index < missing.outlier->index) {
                missing = (eval_missing_t){first_missing, listed, found};
            }
        } else {
            for (size_t k = found - listed; k < found; k++) {
                loops[keys[w + k].index].is_false = 1;
            }
        }
        o = o_end;
        w = w_end;
    }
    free(keys);
    return eval_report_missing(outliers_path, weights_path, &missing);
}

static double eval_ratio(size_t numerator, size_t denominator)
{
    return denominator > 0 ? (double)numerator / (double)denominator : 1.0;
}

void pgem_eval_mark_rejected(eval_loop_t *loops, size_t count, double reject_below)
{
    for (size_t k = 0; k < count; k++) {
        loops[k].rejected = loops[k].pruned || loops[k].weight < reject_below;
    }
}

static void eval_score(double reject_below, eval_loop_t *loops, size_t count, size_t outliers,
                       eval_scores_t *scores)
{
    size_t true_accepted = 0;
    memset(scores, 0, sizeof *scores);
    scores->loops = count;
    scores->outliers = outliers;
    pgem_eval_mark_rejected(loops, count, reject_below);
    for (size_t k = 0; k < count; k++) {
        const eval_loop_t *loop = &loops[k];
        scores->rejected += (size_t)loop->rejected;
        scores->true_positives += (size_t)(loop->rejected && loop->is_false);
        scores->false_positives += (size_t)(loop->rejected && !loop->is_false);
        scores->false_negatives += (size_t)(!loop->rejected && loop->is_false);
        true_accepted += (size_t)(!loop->rejected && !loop->is_false);
    }
    scores->precision = eval_ratio(scores->true_positives, scores->rejected);
    scores->recall = eval_ratio(scores->true_positives, outliers);
    scores->inlier_precision = eval_ratio(true_accepted, count - scores->rejected);
    scores->inlier_recall = eval_ratio(true_accepted, count - outliers);
}

/* Reads the outliers file, then (when weights_path is not NULL) the loops from the weights
 * file, and marks the false ones among the loops; loops_path names the loops in messages. */
static int eval_read_and_mark(const char *outliers_path, const char *weights_path,
                              const char *loops_path, eval_loop_t **loops, size_t *count,
                              size_t *outlier_count)
{
    void *outliers = NULL;
    int status = eval_read_items(outliers_path, 2u, eval_parse_outlier, sizeof(pgem_cli_pair_t),
                                 &outliers, outlier_count);
    if (status == PGEM_EXIT_OK && weights_path != NULL) {
        status = pgem_eval_read_weights(weights_path, loops, count);
    }
    if (status == PGEM_EXIT_OK) {
        status = eval_mark_false(outliers_path, loops_path, outliers, *outlier_count, *loops,
                                 *count);
    }
    free(outliers);
    return status;
}

int pgem_eval_loops(const char *outliers_path, const char *weights_path, double reject_below,
                    eval_loop_t **loops, eval_scores_t *scores)
{
    size_t outlier_count = 0, loop_count = 0;
    memset(scores, 0, sizeof *scores);
    *loops = NULL;
    int status = eval_read_and_mark(outliers_path, weights_path, weights_path, loops, &loop_count,
                                    &outlier_count);
    if (status == PGEM_EXIT_OK) {
        eval_score(reject_below, *loops, loop_count, outlier_count, scores);
    }
    return status;
}

int pgem_eval_mark_outliers(const char *outliers_path, const char *loops_path, eval_loop_t *loops,
                            size_t count, size_t *outlier_count)
{
    return eval_read_and_mark(outliers_path, NULL, loops_path, &loops, &count, outlier_count);
}
