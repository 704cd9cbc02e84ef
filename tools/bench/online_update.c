/* The online driver's library side: one instance sized for the whole stream, poses and edges
 * added as they arrive, and the update strategies --mode chooses from. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "online.h"

int online_state_init(online_state_t *state, const pgem_config_t *config, online_guess_t guess)
{
    char message[512];
    memset(state, 0, sizeof *state);
    state->config = *config;
    state->dimension = config->dimension;
    state->guess = guess;
    state->block_bytes = pgem_memory_size(config);
    size_t poses = config->max_poses;
    state->block = state->block_bytes > 0 ? malloc(state->block_bytes) : NULL;
    state->raw = calloc(poses * PGEM_POSE_SIZE(config->dimension), sizeof *state->raw);
    state->placed = calloc(poses, 1);
    if (state->block == NULL || state->raw == NULL || state->placed == NULL) {
        fprintf(stderr, "pgem-online-driver: out of memory for %u poses, %u edges and a factor "
                        "of %u nonzeros (%zu bytes)\n", (unsigned)config->max_poses,
                (unsigned)config->max_edges, (unsigned)config->fill_budget, state->block_bytes);
        return -1;
    }
    if (pgem_init_message(&state->core, config, state->block, state->block_bytes, message,
                          sizeof message) != PGEM_OK) {
        fprintf(stderr, "pgem-online-driver: cannot initialise the library: %s\n", message);
        return -1;
    }
    return 0;
}

void online_state_free(online_state_t *state)
{
    free(state->block);
    free(state->pass_block);
    free(state->raw);
    free(state->placed);
    memset(state, 0, sizeof *state);
}

int online_add_pose(online_state_t *state, const online_stream_t *stream, size_t pose)
{
    const pgem_io_pose_t *item = &stream->file->poses[pose];
    int status = pgem_add_pose(state->core, item->id, item->pose);
    if (status == PGEM_OK && stream->fixed[pose]) {
        status = pgem_fix_pose(state->core, item->id, 1);
    }
    if (status != PGEM_OK) {
        fprintf(stderr, "pgem-online-driver: %s: pose %llu (line %lu): %s\n",
                stream->file->source, (unsigned long long)item->id, item->line,
                pgem_last_error(state->core));
        return -1;
    }
    size_t size = (size_t)PGEM_POSE_SIZE(state->dimension);
    memcpy(state->raw + (pgem_pose_count(state->core) - 1u) * size, item->pose,
           size * sizeof(double));
    return 0;
}

/* A pose the next update starts from where it is: solved, placed since, or fixed. */
static int online_settled(const online_state_t *state, uint32_t index)
{
    int fixed = 0;
    pgem_pose_at(state->core, index, NULL, NULL, &fixed);
    return index < state->solved_poses || state->placed[index] || fixed;
}

/* The bridge's placement of a new pose: when an odometry edge joins a settled pose to one
 * that is not, the new pose goes where the measurement from the settled one puts it, so an
 * update starts near its optimum instead of in the front-end's drifting frame. */
static void online_place(online_state_t *state, const pgem_io_edge_t *edge)
{
    uint32_t from = 0, to = 0;
    if (state->solved_poses == 0u || pgem_pose_index(state->core, edge->from, &from) != PGEM_OK ||
        pgem_pose_index(state->core, edge->to, &to) != PGEM_OK) {
        return;
    }
    const int from_settled = online_settled(state, from), to_settled = online_settled(state, to);
    if (from_settled == to_settled) {
        return; /* both placed already, or neither can place the other */
    }
    double base[PGEM_POSE_SIZE_MAX], step[PGEM_POSE_SIZE_MAX], pose[PGEM_POSE_SIZE_MAX];
    const int forward = from_settled; /* place `to` from `from`, else `from` from `to` */
    const int three = state->dimension == 3;
    pgem_pose(state->core, forward ? edge->from : edge->to, base);
    if (forward) {
        memcpy(step, edge->measurement, (size_t)PGEM_POSE_SIZE(state->dimension) * sizeof(double));
    } else if (three) {
        pgem_se3_inverse(edge->measurement, step);
    } else {
        pgem_se2_inverse(edge->measurement, step);
    }
    if (three) {
        pgem_se3_compose(base, step, pose);
    } else {
        pgem_se2_compose(base, step, pose);
    }
    if (pgem_set_pose(state->core, forward ? edge->to : edge->from, pose) == PGEM_OK) {
        state->placed[forward ? to : from] = 1;
    }
}

int online_add_edge(online_state_t *state, const pgem_io_edge_t *edge)
{
    if (pgem_add_edge(state->core, edge->from, edge->to, edge->measurement, edge->information,
                      edge->kind, NULL) != PGEM_OK) {
        fprintf(stderr, "pgem-online-driver: edge %llu -> %llu (line %lu): %s\n",
                (unsigned long long)edge->from, (unsigned long long)edge->to, edge->line,
                pgem_last_error(state->core));
        return -1;
    }
    if (edge->kind == PGEM_EDGE_ODOMETRY && state->guess == ONLINE_GUESS_ANCHORED) {
        online_place(state, edge);
    }
    return 0;
}

/* After a failed update, as the bridge does: every pose back to the stream's guess and every
 * loop closure back in, so the next update is the solve an offline tool would run. */
static void online_restart(online_state_t *state)
{
    size_t size = (size_t)PGEM_POSE_SIZE(state->dimension);
    for (uint32_t i = 0; i < pgem_pose_count(state->core); i++) {
        pgem_id_t id = 0;
        pgem_pose_at(state->core, i, &id, NULL, NULL);
        pgem_set_pose(state->core, id, state->raw + i * size);
    }
    pgem_robust_reset(state->core);
    memset(state->placed, 0, pgem_pose_count(state->core));
    state->solved_poses = 0;
    state->restart_pending = 0;
    state->restarts++;
}

/* --mode full: what the LCM bridge does on every solve (bridge_graph_solve): EM with its
 * defaults on the whole graph, warm-started from the current estimate and the loops' weights
 * and states of the previous update; the core redoes its symbolic analysis by itself when
 * poses or edges were added. The bridge also fixes the smallest id of every part joined by
 * odometry; a stream whose poses arrive with their odometry is one part, whose smallest id is
 * the first pose, which the core holds by itself (or the file's FIX poses). */
static int online_update_full(online_state_t *state, pgem_robust_summary_t *summary,
                              double *seconds)
{
    pgem_robust_options_t robust;
    memset(&robust, 0, sizeof robust);
    robust.kernel = PGEM_KERNEL_EM;
    memset(summary, 0, sizeof *summary);
    if (state->restart_pending) {
        online_restart(state);
    }
    double start = pgem_cli_now();
    int status = pgem_robust_optimize(state->core, &robust, NULL, summary);
    *seconds = pgem_cli_now() - start;
    if (status == PGEM_OK) {
        state->solved_poses = pgem_pose_count(state->core);
        memset(state->placed, 0, state->solved_poses);
    } else {
        state->restart_pending = 1;
    }
    return status;
}

/* --mode incremental: pgem_update after every pose (the robust gate on new loop closures, with
 * --live-em loops that pass it only by the map's uncertainty pending for the pass, the core's
 * defaults otherwise); its counters go into the update line's fields. */
static int online_update_incremental(online_state_t *state, pgem_robust_summary_t *summary,
                                     double *seconds)
{
    pgem_update_options_t options;
    memset(&options, 0, sizeof options);
    options.robust = 1;
    options.pending = state->pending ? 10.0 : 0.0; /* the LCM bridge's factor with its passes */
    memset(summary, 0, sizeof *summary);
    memset(&state->step, 0, sizeof state->step);
    double start = pgem_cli_now();
    int status;
    if (state->restart_pending) { /* as the bridge: after a failure, EM from the stream's guesses */
        online_restart(state);
        pgem_robust_options_t robust;
        memset(&robust, 0, sizeof robust);
        robust.kernel = PGEM_KERNEL_EM;
        status = pgem_update_settle(state->core, &robust, summary);
    } else {
        status = pgem_update(state->core, &options, &state->step);
    }
    *seconds = pgem_cli_now() - start;
    state->restart_pending = status != PGEM_OK;
    if (status == PGEM_OK) { /* new poses are placed from solved ones, as after a full solve */
        state->solved_poses = pgem_pose_count(state->core);
        memset(state->placed, 0, state->solved_poses);
    }
    summary->initial_chi2 = (double)NAN;
    summary->final_chi2 = (double)NAN;
    summary->final_chi2_all = (double)NAN;
    summary->usable = status == PGEM_OK;
    return status;
}

/* --mode incremental's end of stream: the settle solve (EM as offline, from the incremental
 * estimate and the gate's decisions). */
static int online_settle_incremental(online_state_t *state, pgem_robust_summary_t *summary,
                                     double *seconds)
{
    pgem_robust_options_t robust;
    memset(&robust, 0, sizeof robust);
    robust.kernel = PGEM_KERNEL_EM;
    double start = pgem_cli_now();
    int status = pgem_update_settle(state->core, &robust, summary);
    *seconds = pgem_cli_now() - start;
    return status;
}

int online_pass_init(online_state_t *state)
{
    pgem_config_t config = state->config;
    config.online_fill = 0u; /* the pass only solves: no incremental factor */
    state->pass_bytes = pgem_memory_size(&config);
    state->pass_block = state->pass_bytes > 0 ? malloc(state->pass_bytes) : NULL;
    if (state->pass_block == NULL) {
        fprintf(stderr, "pgem-online-driver: out of memory for the pass's block (%zu bytes)\n",
                state->pass_bytes);
        return -1;
    }
    return 0;
}

int online_pass_run(online_state_t *state, pgem_robust_summary_t *summary, double *seconds)
{
    pgem_config_t config = state->config;
    config.online_fill = 0u;
    pgem_robust_options_t robust;
    memset(&robust, 0, sizeof robust);
    robust.kernel = PGEM_KERNEL_EM;
    memset(summary, 0, sizeof *summary);
    state->pass_pending = 0;
    const double start = pgem_cli_now();
    /* Re-initialising empties the instance: the copy below is the graph as it is now. */
    int status = pgem_init(&state->pass, &config, state->pass_block, state->pass_bytes);
    if (status == PGEM_OK) {
        status = pgem_copy(state->pass, state->core);
    }
    const size_t size = (size_t)PGEM_POSE_SIZE(state->dimension);
    for (uint32_t i = 0; status == PGEM_OK && i < pgem_pose_count(state->pass); i++) {
        pgem_id_t id = 0;
        pgem_pose_at(state->pass, i, &id, NULL, NULL);
        status = pgem_set_pose(state->pass, id, state->raw + i * size);
    }
    if (status == PGEM_OK) {
        pgem_robust_reset(state->pass);
        status = pgem_robust_optimize(state->pass, &robust, NULL, summary);
    }
    *seconds = pgem_cli_now() - start;
    state->pass_pending = status == PGEM_OK && summary->usable;
    return status;
}

int online_pass_adopt(online_state_t *state, pgem_adopt_summary_t *summary, double *seconds)
{
    const double start = pgem_cli_now();
    int status = pgem_update_adopt(state->core, state->pass, summary);
    *seconds = pgem_cli_now() - start;
    state->pass_pending = 0;
    if (status == PGEM_OK) { /* every pose placed: new ones are placed from them */
        state->solved_poses = pgem_pose_count(state->core);
        memset(state->placed, 0, state->solved_poses);
    }
    return status;
}

const online_mode_t online_modes[] = {
    {"full", online_update_full, NULL, NULL},
    {"incremental", online_update_incremental, NULL, online_settle_incremental},
    {NULL, NULL, NULL, NULL},
};
