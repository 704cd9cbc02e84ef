/** @file
 * pgem thread pool (hosted only, POSIX threads): a fixed set of threads, created once, that
 * runs an instance's factorisations (pgem_set_executor). The core itself never creates a
 * thread; firmware runs on one. */
#ifndef PGEM_THREADS_H
#define PGEM_THREADS_H

#include <stdint.h>

#include "pgem/core.h"

#ifdef __cplusplus
extern "C" {
#endif

/** A pool of threads; opaque. */
typedef struct pgem_thread_pool pgem_thread_pool_t;

/** Starts threads - 1 threads (the caller's thread is the first worker) and waits for them to
 * be ready. threads 1 .. PGEM_MAX_THREADS. Errors: INVALID_ARGUMENT, OUT_OF_MEMORY (no
 * memory, or the system refused a thread; nothing is left running). */
int pgem_thread_pool_create(uint32_t threads, pgem_thread_pool_t **pool);

/** Stops and joins the threads and frees the pool (NULL: nothing). No run may be in progress,
 * and no instance may use it afterwards (pgem_set_executor(instance, NULL) first). */
void pgem_thread_pool_destroy(pgem_thread_pool_t *pool);

/** The pool as an executor for pgem_set_executor, with all its threads as workers. One pool
 * serves one factorisation at a time: instances solving concurrently need a pool each. */
pgem_executor_t pgem_thread_pool_executor(pgem_thread_pool_t *pool);

/** Threads the machine has online (sysconf), at least 1 and at most PGEM_MAX_THREADS. */
uint32_t pgem_thread_count_online(void);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_THREADS_H */
