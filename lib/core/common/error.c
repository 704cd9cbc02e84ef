/* Names and descriptions of the error codes. */
#include <stddef.h>

#include "pgem/error.h"

typedef struct pgem_error_entry {
    int code;                 /* pgem_error_t value */
    const char *name;         /* constant name */
    const char *description;  /* one sentence */
} pgem_error_entry_t;

static const pgem_error_entry_t pgem_errors[] = {
    {PGEM_OK, "PGEM_OK", "success"},
    {PGEM_ERR_INVALID_ARGUMENT, "PGEM_ERR_INVALID_ARGUMENT", "a NULL pointer or an argument out of range"},
    {PGEM_ERR_CONFIG, "PGEM_ERR_CONFIG", "a configuration field is out of range"},
    {PGEM_ERR_BUFFER_TOO_SMALL, "PGEM_ERR_BUFFER_TOO_SMALL", "the memory block is smaller than pgem_memory_size()"},
    {PGEM_ERR_CAPACITY, "PGEM_ERR_CAPACITY", "the pose or edge capacity is reached"},
    {PGEM_ERR_DUPLICATE_ID, "PGEM_ERR_DUPLICATE_ID", "a pose with this id already exists"},
    {PGEM_ERR_UNKNOWN_ID, "PGEM_ERR_UNKNOWN_ID", "no pose has this id"},
    {PGEM_ERR_SELF_LOOP, "PGEM_ERR_SELF_LOOP", "an edge joins a pose to itself"},
    {PGEM_ERR_NOT_FINITE, "PGEM_ERR_NOT_FINITE", "a value is NaN or infinite"},
    {PGEM_ERR_INFORMATION, "PGEM_ERR_INFORMATION", "an information matrix is not symmetric positive definite"},
    {PGEM_ERR_ROTATION, "PGEM_ERR_ROTATION", "a quaternion is far from unit length"},
    {PGEM_ERR_FILL_BUDGET, "PGEM_ERR_FILL_BUDGET", "the Cholesky factor needs more than the fill budget"},
    {PGEM_ERR_NOT_POSITIVE_DEFINITE, "PGEM_ERR_NOT_POSITIVE_DEFINITE", "the normal equations are singular (is every component held by a fixed pose?)"},
    {PGEM_ERR_NUMERIC, "PGEM_ERR_NUMERIC", "the solve produced NaN or Inf"},
    {PGEM_ERR_EMPTY, "PGEM_ERR_EMPTY", "there is nothing to optimize"},
    {PGEM_ERR_OUT_OF_MEMORY, "PGEM_ERR_OUT_OF_MEMORY", "the symbolic analysis could not get workspace"},
    {PGEM_ERR_WRONG_KIND, "PGEM_ERR_WRONG_KIND", "the value is of the wrong kind for this call"},
    {PGEM_ERR_DIMENSION, "PGEM_ERR_DIMENSION", "2D and 3D are mixed, or the dimension is wrong for the call"},
    {PGEM_ERR_OUT_OF_RANGE, "PGEM_ERR_OUT_OF_RANGE", "a translation or information entry is beyond pgem's magnitude limits"},
    {PGEM_ERR_NO_FACTOR, "PGEM_ERR_NO_FACTOR", "no factor is current for the covariance calls (call pgem_covariance_prepare after the last change)"},
};

static const pgem_error_entry_t *pgem_error_find(int code)
{
    for (size_t k = 0; k < sizeof pgem_errors / sizeof pgem_errors[0]; k++) {
        if (pgem_errors[k].code == code) {
            return &pgem_errors[k];
        }
    }
    return NULL;
}

const char *pgem_error_name(int code)
{
    const pgem_error_entry_t *entry = pgem_error_find(code);
    return entry != NULL ? entry->name : "PGEM_ERR_UNKNOWN_CODE";
}

const char *pgem_error_description(int code)
{
    const pgem_error_entry_t *entry = pgem_error_find(code);
    return entry != NULL ? entry->description : "unknown error code";
}
