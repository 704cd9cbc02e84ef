/* Validation of an information matrix: finite, within the magnitude limit, symmetric and
 * positive definite. */
#include <float.h>
#include <math.h>

#include "graph/graph.h"

/* Which entry (row, column) breaks the check, for the message. */
typedef struct pgem_entry_ref {
    int row;     /* 0-based row */
    int column;  /* 0-based column */
} pgem_entry_ref_t;

static void pgem_note(char *message, const char *text)
{
    pgem_text_append(message, PGEM_MESSAGE_SIZE, text);
}

static void pgem_note_entry(char *message, pgem_entry_ref_t entry)
{
    pgem_note(message, "information(");
    pgem_text_i64(message, PGEM_MESSAGE_SIZE, entry.row);
    pgem_note(message, ",");
    pgem_text_i64(message, PGEM_MESSAGE_SIZE, entry.column);
    pgem_note(message, ")");
}

static double pgem_largest_magnitude(const double *matrix, int n)
{
    double largest = 0.0;
    for (int k = 0; k < n * n; k++) {
        largest = fmax(largest, fabs(matrix[k]));
    }
    return largest;
}

/* Cholesky on a copy, from the lower triangle (copied into the upper one); returns the first
 * pivot not above floor, or -1. */
static int pgem_first_bad_pivot(const double *matrix, int n, double floor)
{
    double work[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    for (int i = 0; i < n; i++) {
        for (int j = 0; j < n; j++) {
            work[j * n + i] = matrix[i * n + j];
        }
    }
    return pgem_small_cholesky(work, n, floor, 1);
}

int pgem_information_check(const double *information, int n, int *entry)
{
    int unused = -1;
    int *where = entry != NULL ? entry : &unused;
    if (information == NULL || (n != 3 && n != 6)) {
        *where = -1;
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    for (int k = 0; k < n * n; k++) {
        if (!isfinite(information[k])) {
            *where = k;
            return PGEM_ERR_NOT_FINITE;
        }
    }
    for (int k = 0; k < n * n; k++) {
        if (!(fabs(information[k]) <= PGEM_INFORMATION_LIMIT)) {
            *where = k;
            return PGEM_ERR_OUT_OF_RANGE;
        }
    }
    const double largest = pgem_largest_magnitude(information, n);
    for (int i = 0; i < n; i++) {
        for (int j = i + 1; j < n; j++) {
            if (fabs(information[i * n + j] - information[j * n + i]) > 1e-9 * largest) {
                *where = i * n + j;
                return PGEM_ERR_INFORMATION;
            }
        }
    }
    int bad = pgem_first_bad_pivot(information, n, (double)n * DBL_EPSILON * largest);
    *where = bad >= 0 ? bad * (n + 1) : -1;
    return bad >= 0 ? PGEM_ERR_INFORMATION : PGEM_OK;
}

int pgem_information_positive(const double *information, int n)
{
    if (information == NULL || (n != 3 && n != 6)) {
        return 0;
    }
    return pgem_first_bad_pivot(information, n, 0.0) < 0;
}

int pgem_check_information(char *message, int n, const double *information)
{
    int entry;
    int status = pgem_information_check(information, n, &entry);
    if (status == PGEM_OK) {
        return PGEM_OK;
    }
    const pgem_entry_ref_t at = {entry / n, entry % n};
    message[0] = '\0';
    if (status == PGEM_ERR_NOT_FINITE) {
        pgem_note_entry(message, at);
        pgem_note(message, " is not finite");
    } else if (status == PGEM_ERR_OUT_OF_RANGE) {
        pgem_note_entry(message, at);
        pgem_note(message, " is beyond the information limit (|entry| at most 1e15, "
                           "PGEM_INFORMATION_LIMIT)");
    } else if (at.row != at.column) {
        pgem_note_entry(message, at);
        pgem_note(message, " differs from ");
        pgem_note_entry(message, (pgem_entry_ref_t){at.column, at.row});
        pgem_note(message, ": information must be symmetric");
    } else if (pgem_information_positive(information, n)) {
        pgem_note(message, "information is positive definite but too badly conditioned "
                           "for double precision (pivot ");
        pgem_text_i64(message, PGEM_MESSAGE_SIZE, at.row);
        pgem_note(message, " below n * DBL_EPSILON of the largest entry: condition "
                           "number beyond about 1e15)");
    } else {
        pgem_note(message, "information is not positive definite (pivot ");
        pgem_text_i64(message, PGEM_MESSAGE_SIZE, at.row);
        pgem_note(message, " is not positive)");
    }
    return status;
}
