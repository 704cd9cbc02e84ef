/* Allocation counters for the tests that prove a solve allocates nothing (C and C++): malloc,
 * calloc, realloc and free are interposed, counted and forwarded to glibc's own entry points.
 * AddressSanitizer owns malloc, so a sanitizer build (TEST_UNDER_SANITIZER 1) interposes nothing
 * and the counters stay 0. Include it in one translation unit of a test program. */
#ifndef PGEM_TEST_ALLOC_COUNTERS_H
#define PGEM_TEST_ALLOC_COUNTERS_H

#include <stddef.h>
#include <stdlib.h>

#if defined(__SANITIZE_ADDRESS__)
#define TEST_UNDER_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define TEST_UNDER_SANITIZER 1
#endif
#endif
#ifndef TEST_UNDER_SANITIZER
#define TEST_UNDER_SANITIZER 0
#endif

/* The C++ test reads the counters (as 0) in the sanitizer build too. */
#if !TEST_UNDER_SANITIZER || defined(__cplusplus)
/* volatile: the compiler treats malloc as a builtin that touches no program variable, so
 * without it clang keeps a counter read before a malloc call in a register across the call. */
static volatile long allocations; /* malloc + calloc + realloc calls of any kind */
static volatile long releases;    /* blocks handed back: free(p) and realloc(p, ...) count the
                                     block they end, so a balanced phase has allocations ==
                                     releases */
#endif

#if !TEST_UNDER_SANITIZER
#ifdef __cplusplus
#define TEST_NOEXCEPT noexcept
extern "C" {
#else
#define TEST_NOEXCEPT
#endif

extern void *__libc_malloc(size_t size) TEST_NOEXCEPT;
extern void *__libc_calloc(size_t count, size_t size) TEST_NOEXCEPT;
extern void *__libc_realloc(void *pointer, size_t size) TEST_NOEXCEPT;
extern void __libc_free(void *pointer) TEST_NOEXCEPT;

void *malloc(size_t size) TEST_NOEXCEPT
{
    allocations++;
    return __libc_malloc(size);
}

void *calloc(size_t count, size_t size) TEST_NOEXCEPT
{
    allocations++;
    return __libc_calloc(count, size);
}

void *realloc(void *pointer, size_t size) TEST_NOEXCEPT
{
    allocations++;
    releases += pointer != NULL;
    return __libc_realloc(pointer, size);
}

void free(void *pointer) TEST_NOEXCEPT
{
    releases += pointer != NULL;
    __libc_free(pointer);
}

#ifdef __cplusplus
}
#endif
#endif /* !TEST_UNDER_SANITIZER */

#endif /* PGEM_TEST_ALLOC_COUNTERS_H */
