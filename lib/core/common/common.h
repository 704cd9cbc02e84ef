/* The common layer, private to lib/core: the arena every layer carves its part of the block
 * from, fault injection for the exhaustion test, and text and message building without stdio.
 * It knows no other layer. */
#ifndef PGEM_COMMON_LAYER_H
#define PGEM_COMMON_LAYER_H

#include <stddef.h>
#include <stdint.h>

#include "pgem/pgem.h"

#define PGEM_MESSAGE_SIZE 256

/* A bump allocator over the caller's block; with base == NULL it only measures. */
typedef struct pgem_arena {
    unsigned char *base;  /* start of the block (NULL: measuring pass) */
    size_t size;          /* bytes available */
    size_t used;          /* bytes carved so far, including alignment padding */
    size_t carves;        /* slices asked for from the block (not counted when measuring) */
    size_t failed;        /* number (1, 2, ...) of the first slice that could not be carved,
                             0 if none */
    size_t failed_bytes;  /* bytes that slice asked for */
} pgem_arena_t;

/* Returns an aligned slice (16 bytes) of count * item bytes, or NULL when measuring or out of
 * room (then used still grows, so a measuring pass yields the total, and a failed carve is
 * recorded in failed). */
void *pgem_arena_take(pgem_arena_t *arena, size_t count, size_t item);
/* The same for one struct of `bytes`, aligned to 8 bytes only (its members need no more): a
 * layer's state struct carved from the block packs as tightly as it did inside struct pgem. */
void *pgem_arena_take_struct(pgem_arena_t *arena, size_t bytes);

/* Fault injection for the memory-exhaustion test (tests/test_exhaustion.c), compiled only into
 * a test copy of the core (PGEM_FAULT_INJECTION; the released library never has it):
 * pgem_fault_next() is asked once per carve from the block and once per CSparse allocation
 * from its pool, and says 1 for the one the test chose. Without the define it is 0. */
#ifdef PGEM_FAULT_INJECTION
int pgem_fault_next(void);
/* From now on, request number `index` (0, 1, ...) fails; a negative index counts only. */
void pgem_fault_arm(long index);
/* Requests seen since pgem_fault_arm (the sweep is over once a run sees no more than index). */
long pgem_fault_seen(void);
/* The same for the incremental factor's downdates (online/factor.c): pgem_fault_downdate() is
 * asked once per downdate of a column and says 1 for the chosen one, which then fails as a
 * downdate that rounding broke (not positive definite) before it changes anything. */
int pgem_fault_downdate(void);
void pgem_fault_arm_downdate(long index);
long pgem_fault_downdates_seen(void);
#else
#define pgem_fault_next() 0
#define pgem_fault_downdate() 0
#endif

/* Text building without stdio (firmware-safe): appends to a NUL-terminated text of size
 * bytes, truncating. */
void pgem_text_append(char *text, size_t size, const char *piece);
void pgem_text_u64(char *text, size_t size, uint64_t value);
void pgem_text_i64(char *text, size_t size, int64_t value);
/* Sets message (PGEM_MESSAGE_SIZE bytes) to text and returns code (one-line error returns). */
int pgem_text_fail(char *message, int code, const char *text);
/* PGEM_OK if value is finite; else PGEM_ERR_INVALID_ARGUMENT with "option NAME is not a
 * finite number" in message (PGEM_MESSAGE_SIZE bytes): the layers' option checks. */
int pgem_text_option(char *message, double value, const char *name);

/* Small dense matrices, n <= PGEM_SMALL_MAX, row-major (common/small.c): every dense block the
 * core factors, solves or inverts outside the sparse factors. */
#define PGEM_SMALL_MAX 6
/* out = op(a) op(b), op the transpose where asked; out must not alias a or b. */
void pgem_small_product(const double *a, int transpose_a, const double *b, int transpose_b,
                        double *out, int n);
/* out = a v, or a' v when transpose (a n x n, v and out n). */
void pgem_small_apply(const double *a, int transpose, const double *v, double *out, int n);
/* out = a^-1 (Gauss-Jordan with partial pivoting); 0, out undefined, if a is singular. */
int pgem_small_inverse(const double *a, double *out, int n);
/* Cholesky of a symmetric n x n matrix in place (row-major), from its upper triangle: the
 * upper factor U with a = U^T U, row by row, the strictly lower triangle zeroed; read by
 * column, the array holds the lower factor L = U^T. A pivot (before its root) that is not
 * above `least`, or not finite, stops it when `strict` and its index is returned (the matrix
 * part factored); when not strict it is raised to `least` (a zero root zeroes the rest of
 * its row). Returns -1 when every pivot passed. */
int pgem_small_cholesky(double *a, int n, double least, int strict);
/* x = U^-1 x in place for an upper-triangular U (row-major) with a non-zero diagonal. */
void pgem_small_upper_solve(const double *u, double *x, int n);
/* e^T (U^T U)^-1 e = |U^-T e|^2 for U from pgem_small_cholesky (a's quadratic form). */
double pgem_small_form(const double *u, const double *e, int n);

#endif /* PGEM_COMMON_LAYER_H */
