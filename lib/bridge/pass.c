/* The live EM pass's thread and its copy of the graph (see pass.h). */
#define _GNU_SOURCE /* syscall */
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>
#include <stdlib.h>
#include <string.h>

#include "bridge_internal.h"

/* Stops the solve after a round when the bridge stops or the graph it copied is gone. */
static int pass_keep_going(const pgem_robust_progress_t *progress, void *user)
{
    (void)progress;
    const bridge_pass_t *pass = user;
    return pass->cancel;
}

static void *pass_main(void *user)
{
    bridge_pass_t *pass = user;
    /* Below the solver and reception threads (nice 10: about a tenth of a core's share when
     * they compete for it, all of it when they wait), so updates keep their latency; not
     * SCHED_IDLE, which starved the passes whenever anything else ran on the machine. */
    (void)setpriority(PRIO_PROCESS, (id_t)syscall(SYS_gettid), 10);
    pthread_mutex_lock(pass->lock);
    for (;;) {
        while (!pass->quit && pass->state != BRIDGE_PASS_RUNNING) {
            pthread_cond_wait(&pass->wake, pass->lock);
        }
        if (pass->quit) {
            break;
        }
        pthread_mutex_unlock(pass->lock);
        const double start = bridge_now();
        pgem_robust_options_t robust = pass->robust;
        robust.on_round = pass_keep_going;
        robust.user = pass;
        memset(&pass->summary, 0, sizeof pass->summary);
        pgem_robust_reset(pass->core);
        pass->status = pgem_robust_optimize(pass->core, &robust, NULL, &pass->summary);
        const double end = bridge_now();
        pthread_mutex_lock(pass->lock);
        pass->solve_took = end - start;
        pass->took = end - pass->started;
        pass->state = BRIDGE_PASS_DONE;
        pthread_cond_broadcast(pass->done_wake);
    }
    pthread_mutex_unlock(pass->lock);
    return NULL;
}

int bridge_pass_init(bridge_pass_t *pass, const pgem_config_t *live, const pgem_robust_options_t *robust,
                     pthread_mutex_t *lock, pthread_cond_t *done_wake, char *message,
                     size_t message_size)
{
    memset(pass, 0, sizeof *pass);
    pass->config = *live;
    pass->config.online_fill = 0;
    pass->robust = *robust;
    pass->lock = lock;
    pass->done_wake = done_wake;
    pass->block_size = pgem_memory_size(&pass->config);
    pass->block = pass->block_size > 0 ? malloc(pass->block_size) : NULL;
    pass->has_edge = malloc(live->max_poses + 1u);
    if (pass->block == NULL || pass->has_edge == NULL) {
        snprintf(message, message_size, "out of memory for the live EM pass's copy (%.1f MiB)",
                 (double)pass->block_size / 1048576.0);
        return -1;
    }
    const int status = pgem_init(&pass->core, &pass->config, pass->block, pass->block_size);
    if (status != PGEM_OK) {
        snprintf(message, message_size, "cannot initialise the live EM pass's copy: %s",
                 pgem_error_name(status));
        return -1;
    }
    if (pthread_cond_init(&pass->wake, NULL) != 0) {
        snprintf(message, message_size, "cannot create the live EM pass's condition");
        return -1;
    }
    if (pthread_create(&pass->thread, NULL, pass_main, pass) != 0) {
        pthread_cond_destroy(&pass->wake);
        snprintf(message, message_size, "cannot start the live EM pass's thread");
        return -1;
    }
    pass->thread_started = 1;
    return 0;
}

void bridge_pass_free(bridge_pass_t *pass)
{
    if (pass->thread_started) {
        pthread_mutex_lock(pass->lock);
        pass->quit = 1;
        pass->cancel = 1;
        pthread_cond_broadcast(&pass->wake);
        pthread_mutex_unlock(pass->lock);
        pthread_join(pass->thread, NULL);
        pthread_cond_destroy(&pass->wake);
        pass->thread_started = 0;
    }
    free(pass->block);
    free(pass->has_edge);
    pass->block = NULL;
    pass->has_edge = NULL;
    pass->core = NULL;
}

int bridge_pass_state(bridge_pass_t *pass)
{
    pthread_mutex_lock(pass->lock);
    const int state = pass->state;
    pthread_mutex_unlock(pass->lock);
    return state;
}

int bridge_pass_start(bridge_pass_t *pass, const pgem_t *live, const double *raw,
                      uint64_t generation, double now)
{
    int status = pgem_init(&pass->core, &pass->config, pass->block, pass->block_size);
    if (status == PGEM_OK) {
        status = pgem_copy(pass->core, live);
    }
    if (status != PGEM_OK) {
        return -1;
    }
    const uint32_t poses = pgem_pose_count(pass->core);
    const size_t size = (size_t)PGEM_POSE_SIZE(pgem_dimension(pass->core));
    uint32_t loops = 0;
    memset(pass->has_edge, 0, poses);
    for (uint32_t k = 0; k < pgem_edge_count(pass->core); ++k) {
        pgem_edge_view_t view;
        uint32_t from = 0, to = 0;
        pgem_edge_at(pass->core, k, &view);
        loops += view.kind == PGEM_EDGE_LOOP;
        if (pgem_pose_index(pass->core, view.from, &from) == PGEM_OK &&
            pgem_pose_index(pass->core, view.to, &to) == PGEM_OK) {
            pass->has_edge[from] = pass->has_edge[to] = 1;
        }
    }
    for (uint32_t i = 0; i < poses; ++i) { /* batch EM's start; held: edges still on their way */
        pgem_id_t id = 0;
        pgem_pose_at(pass->core, i, &id, NULL, NULL);
        if (raw != NULL) {
            pgem_set_pose(pass->core, id, raw + i * size);
        }
        if (!pass->has_edge[i]) {
            pgem_fix_pose(pass->core, id, 1);
        }
    }
    pthread_mutex_lock(pass->lock);
    pass->generation = generation;
    pass->started = now;
    pass->loops_at_copy = loops;
    pass->cancel = 0;
    pass->state = BRIDGE_PASS_RUNNING;
    pthread_cond_broadcast(&pass->wake);
    pthread_mutex_unlock(pass->lock);
    return 0;
}

void bridge_pass_release(bridge_pass_t *pass)
{
    pthread_mutex_lock(pass->lock);
    pass->state = BRIDGE_PASS_IDLE;
    pthread_mutex_unlock(pass->lock);
}
