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

/* A (from, to) pair with its position, for sorting. */
typedef struct eval_key {
    pgem_id_t from, to;
    size_t index;                /* weights: index of the loop; outliers: file line */
} eval_key_t;

/* A text file read line by line. */
typedef struct eval_text {
    FILE *file;
    const char *path;
    char *line;
    size_t capacity;
    unsigned long number;        /* 1-based number of the current line */
} eval_text_t;

static int eval_compare_keys(const void *a, const void *b)
{
    const eval_key_t *x = a, *y = b;
    if (x->from != y->from) {
        return (x->from > y->from) - (x->from < y->from);
    }
    if (x->to != y->to) {
        return (x->to > y->to) - (x->to < y->to);
    }
    return (x->index > y->index) - (x->index < y->index);
}

/* Sorts keys by (from, to, index); keys may be NULL when count is 0. */
static void eval_sort_keys(eval_key_t *keys, size_t count)
{
    if (count > 1u) {
        qsort(keys, count, sizeof *keys, eval_compare_keys);
    }
}

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

/* Reads the outliers file into keys (index = file line). */
static int eval_read_outliers(const char *path, eval_key_t **keys, size_t *count)
{
    eval_text_t text;
    char *fields[3] = {NULL};
    size_t fields_read = 0, capacity = 0;
    int status = eval_open(&text, path);
    *keys = NULL;
    *count = 0;
    while (status == PGEM_EXIT_OK) {
        status = eval_next_line(&text, fields, 2u, &fields_read);
        if (status != PGEM_EXIT_OK || fields_read == 0) {
            break;
        }
        eval_key_t key = {0u, 0u, text.number};
        if (fields_read != 2u) {
            fprintf(stderr, "pgem: %s:%lu: expected 2 fields 'from to', got %s\n", path,
                    text.number, fields_read < 2u ? "1" : "more");
            status = PGEM_EXIT_FAILURE;
        } else if (!eval_parse_pair(&text, fields, &key.from, &key.to)) {
            status = PGEM_EXIT_FAILURE;
        } else {
            eval_key_t *grown = eval_reserve(*keys, &capacity, *count, sizeof *grown);
            if (grown == NULL) {
                fprintf(stderr, "pgem: out of memory\n");
                status = PGEM_EXIT_FAILURE;
            } else {
                *keys = grown;
                (*keys)[(*count)++] = key;
            }
        }
    }
    eval_close(&text);
    return status;
}

/* One weights line (4 fields) into *loop; prints an error naming the line on failure. */
static int eval_parse_loop(const eval_text_t *text, char **fields, size_t count, eval_loop_t *loop)
{
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

static int eval_read_weights(const char *path, eval_loop_t **loops, size_t *count)
{
    eval_text_t text;
    char *fields[EVAL_MAX_FIELDS + 1] = {NULL};
    size_t fields_read = 0, capacity = 0;
    int status = eval_open(&text, path);
    *loops = NULL;
    *count = 0;
    while (status == PGEM_EXIT_OK) {
        status = eval_next_line(&text, fields, EVAL_MAX_FIELDS, &fields_read);
        if (status != PGEM_EXIT_OK || fields_read == 0) {
            break;
        }
        eval_loop_t loop = {0};
        if (!eval_parse_loop(&text, fields, fields_read, &loop)) {
            status = PGEM_EXIT_FAILURE;
        } else {
            eval_loop_t *grown = eval_reserve(*loops, &capacity, *count, sizeof *grown);
            if (grown == NULL) {
                fprintf(stderr, "pgem: out of memory\n");
                status = PGEM_EXIT_FAILURE;
            } else {
                *loops = grown;
                (*loops)[(*count)++] = loop;
            }
        }
    }
    eval_close(&text);
    return status;
}

/* The end of the run of keys equal to (from, to) that starts at `first`. */
static size_t eval_run_end(const eval_key_t *keys, size_t count, size_t first, pgem_id_t from,
                           pgem_id_t to)
{
    while (first < count && keys[first].from == from && keys[first].to == to) {
        first++;
    }
    return first;
}

/* The first key at or after `first` that is not ordered before (from, to). */
static size_t eval_skip_before(const eval_key_t *keys, size_t count, size_t first, pgem_id_t from,
                               pgem_id_t to)
{
    while (first < count &&
           (keys[first].from < from || (keys[first].from == from && keys[first].to < to))) {
        first++;
    }
    return first;
}

/* The outliers line that found no weights line, and how often its pair occurs in each. */
typedef struct eval_missing {
    const eval_key_t *outlier;   /* NULL: none */
    size_t listed;               /* times in the outliers file */
    size_t found;                /* times in the weights file */
} eval_missing_t;

static int eval_report_missing(const char *outliers, const char *weights,
                               const eval_missing_t *missing)
{
    const eval_key_t *key = missing->outlier;
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
 * the earliest such outliers line. `outliers` is sorted by (pair, line). */
static int eval_mark_false(const char *outliers_path, const char *weights_path,
                           const eval_key_t *outliers, size_t outlier_count, eval_loop_t *loops,
                           size_t loop_count)
{
    eval_key_t *keys = malloc((loop_count > 0 ? loop_count : 1u) * sizeof *keys);
    eval_missing_t missing = {NULL, 0u, 0u};
    if (keys == NULL) {
        fprintf(stderr, "pgem: out of memory\n");
        return PGEM_EXIT_FAILURE;
    }
    for (size_t k = 0; k < loop_count; k++) {
        keys[k] = (eval_key_t){loops[k].from, loops[k].to, k};
    }
    eval_sort_keys(keys, loop_count);
    for (size_t o = 0, w = 0; o < outlier_count;) {
        pgem_id_t from = outliers[o].from, to = outliers[o].to;
        size_t o_end = eval_run_end(outliers, outlier_count, o, from, to);
        w = eval_skip_before(keys, loop_count, w, from, to);
        size_t w_end = eval_run_end(keys, loop_count, w, from, to);
        size_t listed = o_end - o, found = w_end - w;
        if (listed > found) {
            const eval_key_t *first_missing = &outliers[o + found];
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

static void eval_score(double reject_below, eval_loop_t *loops, size_t count, size_t outliers,
                       eval_scores_t *scores)
{
    size_t true_accepted = 0;
    memset(scores, 0, sizeof *scores);
    scores->loops = count;
    scores->outliers = outliers;
    for (size_t k = 0; k < count; k++) {
        eval_loop_t *loop = &loops[k];
        loop->rejected = loop->pruned || loop->weight < reject_below;
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

int pgem_eval_loops(const char *outliers_path, const char *weights_path, double reject_below,
                    eval_loop_t **loops, eval_scores_t *scores)
{
    eval_key_t *outliers = NULL;
    size_t outlier_count = 0, loop_count = 0;
    memset(scores, 0, sizeof *scores);
    *loops = NULL;
    int status = eval_read_outliers(outliers_path, &outliers, &outlier_count);
    if (status == PGEM_EXIT_OK) {
        status = eval_read_weights(weights_path, loops, &loop_count);
    }
    if (status == PGEM_EXIT_OK) {
        eval_sort_keys(outliers, outlier_count);
        status = eval_mark_false(outliers_path, weights_path, outliers, outlier_count, *loops,
                                 loop_count);
    }
    if (status == PGEM_EXIT_OK) {
        eval_score(reject_below, *loops, loop_count, outlier_count, scores);
    }
    free(outliers);
    return status;
}

int pgem_eval_read_weights(const char *weights_path, eval_loop_t **loops, size_t *count)
{
    return eval_read_weights(weights_path, loops, count);
}

int pgem_eval_mark_outliers(const char *outliers_path, const char *loops_path, eval_loop_t *loops,
                            size_t count, size_t *outlier_count)
{
    eval_key_t *outliers = NULL;
    int status = eval_read_outliers(outliers_path, &outliers, outlier_count);
    if (status == PGEM_EXIT_OK) {
        eval_sort_keys(outliers, *outlier_count);
        status = eval_mark_false(outliers_path, loops_path, outliers, *outlier_count, loops, count);
    }
    free(outliers);
    return status;
}
