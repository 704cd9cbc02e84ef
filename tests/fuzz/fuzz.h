/* What every fuzz target provides: libFuzzer's entry point, and its built-in seeds for the
 * replay program (which runs them in the ordinary test suite and writes them into a corpus).
 * A target reports a broken invariant with FUZZ_CHECK, which aborts: libFuzzer then saves the
 * input, and the replay program fails its test. */
#ifndef PGEM_FUZZ_H
#define PGEM_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/* Writes built-in seed number index into buffer (at most capacity bytes) and returns its size;
 * 0 when there is no such seed. */
size_t fuzz_seed(unsigned index, uint8_t *buffer, size_t capacity);

/* Largest seed a target writes. */
#define FUZZ_SEED_MAX 8192u

/* Aborts with the broken invariant's text and place; never compiled out. */
#define FUZZ_CHECK(condition)                                                              \
    do {                                                                                   \
        if (!(condition)) {                                                                \
            fprintf(stderr, "%s:%d: invariant broken: %s\n", __FILE__, __LINE__, #condition); \
            abort();                                                                       \
        }                                                                                  \
    } while (0)

#endif /* PGEM_FUZZ_H */
