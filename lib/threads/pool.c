/* A fixed pool of POSIX threads behind pgem_executor_t: the threads are created once, wait on a
 * condition variable between runs, and each run hands every one the same task with its own
 * worker number (the caller's thread is worker 0). */
#define _POSIX_C_SOURCE 200809L
#include <pthread.h>
#include <stdlib.h>
#include <unistd.h>

#include "pgem/threads.h"

struct pgem_thread_pool {
    pthread_mutex_t lock;
    pthread_cond_t start;     /* a run (or the stop) is posted */
    pthread_cond_t finished;  /* a worker is done with the run */
    pgem_task_fn task;        /* the run's task */
    void *context;            /* and its context */
    uint64_t generation;      /* runs posted so far */
    uint32_t busy;            /* workers still in the current run */
    int stopping;             /* 1: the threads leave */
    uint32_t threads;         /* workers, the caller's thread included */
    uint32_t started;         /* threads created */
    pthread_t *handles;       /* [threads - 1] */
};

/* What each created thread needs: the pool and its worker number. */
typedef struct pgem_thread_start {
    pgem_thread_pool_t *pool;
    uint32_t worker;
} pgem_thread_start_t;

static void *pgem_thread_main(void *argument)
{
    pgem_thread_start_t *start = argument;
    pgem_thread_pool_t *pool = start->pool;
    const uint32_t worker = start->worker;
    free(start);
    uint64_t seen = 0;
    pthread_mutex_lock(&pool->lock);
    for (;;) {
        while (!pool->stopping && pool->generation == seen) {
            pthread_cond_wait(&pool->start, &pool->lock);
        }
        if (pool->stopping) {
            break;
        }
        seen = pool->generation;
        pgem_task_fn task = pool->task;
        void *context = pool->context;
        pthread_mutex_unlock(&pool->lock);
        task(context, worker);
        pthread_mutex_lock(&pool->lock);
        if (--pool->busy == 0u) {
            pthread_cond_signal(&pool->finished);
        }
    }
    pthread_mutex_unlock(&pool->lock);
    return NULL;
}

static void pgem_thread_run(void *executor, pgem_task_fn task, void *context)
{
    pgem_thread_pool_t *pool = executor;
    pthread_mutex_lock(&pool->lock);
    pool->task = task;
    pool->context = context;
    pool->busy = pool->threads - 1u;
    pool->generation++;
    pthread_cond_broadcast(&pool->start);
    pthread_mutex_unlock(&pool->lock);
    task(context, 0u);
    pthread_mutex_lock(&pool->lock);
    while (pool->busy > 0u) {
        pthread_cond_wait(&pool->finished, &pool->lock);
    }
    pthread_mutex_unlock(&pool->lock);
}

void pgem_thread_pool_destroy(pgem_thread_pool_t *pool)
{
    if (pool == NULL) {
        return;
    }
    pthread_mutex_lock(&pool->lock);
    pool->stopping = 1;
    pthread_cond_broadcast(&pool->start);
    pthread_mutex_unlock(&pool->lock);
    for (uint32_t k = 0; k < pool->started; k++) {
        pthread_join(pool->handles[k], NULL);
    }
    pthread_cond_destroy(&pool->finished);
    pthread_cond_destroy(&pool->start);
    pthread_mutex_destroy(&pool->lock);
    free(pool->handles);
    free(pool);
}

int pgem_thread_pool_create(uint32_t threads, pgem_thread_pool_t **pool)
{
    if (pool == NULL || threads == 0u || threads > PGEM_MAX_THREADS) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    pgem_thread_pool_t *out = calloc(1, sizeof *out);
    if (out == NULL) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    out->threads = threads;
    out->handles = calloc(threads, sizeof *out->handles);
    if (out->handles == NULL || pthread_mutex_init(&out->lock, NULL) != 0) {
        free(out->handles);
        free(out);
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    pthread_cond_init(&out->start, NULL);
    pthread_cond_init(&out->finished, NULL);
    for (uint32_t w = 1; w < threads; w++) {
        pgem_thread_start_t *start = malloc(sizeof *start);
        if (start == NULL) {
            pgem_thread_pool_destroy(out);
            return PGEM_ERR_OUT_OF_MEMORY;
        }
        start->pool = out;
        start->worker = w;
        if (pthread_create(&out->handles[out->started], NULL, pgem_thread_main, start) != 0) {
            free(start);
            pgem_thread_pool_destroy(out);
            return PGEM_ERR_OUT_OF_MEMORY;
        }
        out->started++;
    }
    *pool = out;
    return PGEM_OK;
}

pgem_executor_t pgem_thread_pool_executor(pgem_thread_pool_t *pool)
{
    pgem_executor_t executor = {pgem_thread_run, pool, pool != NULL ? pool->threads : 1u};
    if (pool == NULL) {
        executor.run = NULL;
    }
    return executor;
}

uint32_t pgem_thread_count_online(void)
{
    const long online = sysconf(_SC_NPROCESSORS_ONLN);
    if (online < 1) {
        return 1u;
    }
    return online > (long)PGEM_MAX_THREADS ? PGEM_MAX_THREADS : (uint32_t)online;
}
