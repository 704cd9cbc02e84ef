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
/* A test that sweeps allocation failures defines TEST_ALLOC_FAULTS before the include: after
 * alloc_fault_arm(k) the k-th malloc, calloc or realloc call (0, 1, ...) returns NULL. A failed
 * call counts in neither counter (realloc then keeps its block). */
#ifdef TEST_ALLOC_FAULTS
static long alloc_fault_at = -1; /* call to fail; negative: disarmed, nothing counted */
static long alloc_fault_seen;    /* calls since arming */

static void alloc_fault_arm(long index)
{
    alloc_fault_at = index;
    alloc_fault_seen = 0;
}

static int alloc_fault_next(void)
{
    return alloc_fault_at >= 0 && alloc_fault_seen++ == alloc_fault_at;
}
#else
#define alloc_fault_next() 0
#endif

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
    if (alloc_fault_next()) {
        return NULL;
    }
    allocations++;
    return __libc_malloc(size);
}

void *calloc(size_t count, size_t size) TEST_NOEXCEPT
{
    if (alloc_fault_next()) {
        return NULL;
    }
    allocations++;
    return __libc_calloc(count, size);
}

void *realloc(void *pointer, size_t size) TEST_NOEXCEPT
{
    if (alloc_fault_next()) {
        return NULL;
    }
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
