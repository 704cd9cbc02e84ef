/* The linalg layer's part of the block: its state struct and arrays, and the calls that hand
 * its figures and vectors to the layers above without showing them its layout. */
#include <math.h>
#include <string.h>

#include "linalg/linear.h"

static void pgem_carve_factor(const pgem_config_t *config, int tangent, pgem_factor_t *factor,
                              pgem_arena_t *arena)
{
    const size_t poses = config->max_poses;
    const size_t block = (size_t)tangent;
    factor->super_first = pgem_arena_take(arena, poses + 1u, sizeof(int));
    factor->block_super = pgem_arena_take(arena, poses, sizeof(int));
    factor->row_start = pgem_arena_take(arena, poses + 1u, sizeof(int));
    factor->rows = pgem_arena_take(arena, config->fill_budget / (block * block) + 1u, sizeof(int));
    factor->value_start = pgem_arena_take(arena, poses + 1u, sizeof(int));
    factor->values = pgem_arena_take(arena, config->fill_budget, sizeof(double));
    factor->order = pgem_arena_take(arena, poses, sizeof(int));
    factor->task_first = pgem_arena_take(arena, poses + 1u, sizeof(int));
    factor->task_worker = pgem_arena_take(arena, poses, sizeof(int));
    factor->head = pgem_arena_take(arena, poses, sizeof(int));
    factor->next = pgem_arena_take(arena, poses, sizeof(int));
    factor->position = pgem_arena_take(arena, poses, sizeof(int));
    factor->worker_count = (int)config->threads;
    factor->workers = pgem_arena_take(arena, config->threads, sizeof(pgem_factor_worker_t));
    for (uint32_t w = 0; w < config->threads; w++) {
        const size_t work = pgem_factor_work_doubles(config->max_poses, tangent, (int)w);
        int *map = pgem_arena_take(arena, poses, sizeof(int));
        double *doubles = w == 0u ? factor->shared : pgem_arena_take(arena, work, sizeof(double));
        if (factor->workers != NULL) {
            factor->workers[w].map = map;
            factor->workers[w].work = doubles;
            factor->workers[w].work_doubles = work;
        }
    }
}

static void pgem_carve_arrays(const pgem_config_t *config, int tangent, pgem_linear_t *linear,
                              pgem_arena_t *arena)
{
    const size_t poses = config->max_poses;
    const size_t edges = config->max_edges;
    const size_t block = (size_t)tangent;
    const size_t scalars = poses * block;
    const size_t lower = edges * block * block + poses * block * (block + 1u) / 2u;
    linear->block = (int)block;
    linear->pose_block = pgem_arena_take(arena, poses, sizeof(int));
    linear->edge_offset = pgem_arena_take(arena, edges, sizeof(int));
    linear->edge_transposed = pgem_arena_take(arena, edges, 1);
    linear->block_colptr = pgem_arena_take(arena, poses + 1u, sizeof(int));
    linear->block_rows = pgem_arena_take(arena, edges, sizeof(int));
    linear->block_parent = pgem_arena_take(arena, poses, sizeof(int));
    /* the analysis's scratch, worker 0's dense workspace and the solves' vectors in turn */
    linear->factor.shared_doubles = pgem_factor_shared_doubles(config->max_poses,
                                                               config->max_edges, (int)block);
    linear->factor.shared = pgem_arena_take(arena, linear->factor.shared_doubles, sizeof(double));
    linear->lower_start = pgem_arena_take(arena, poses + 1u, sizeof(int));
    linear->lower_values = pgem_arena_take(arena, lower, sizeof(double));
    pgem_carve_factor(config, tangent, &linear->factor, arena);
    linear->rhs = pgem_arena_take(arena, scalars, sizeof(double));
    linear->diagonal = pgem_arena_take(arena, scalars, sizeof(double));
    linear->gradient = pgem_arena_take(arena, scalars, sizeof(double));
    linear->cs_pool.size = pgem_cs_pool_bytes(config->max_poses, config->max_edges);
    linear->cs_pool.base = pgem_arena_take(arena, linear->cs_pool.size, 1);
}

pgem_linear_t *pgem_linear_carve(const pgem_config_t *config, int tangent, pgem_arena_t *arena)
{
    pgem_linear_t probe; /* what a measuring pass (or a failed carve) fills instead */
    pgem_linear_t *carved = pgem_arena_take_struct(arena, sizeof(pgem_linear_t));
    pgem_linear_t *linear = carved;
    if (linear == NULL) {
        linear = &probe;
    }
    memset(linear, 0, sizeof *linear);
    pgem_carve_arrays(config, tangent, linear, arena);
    return carved;
}

void pgem_linear_start(pgem_linear_t *linear)
{
    linear->dense = pgem_dense_select();
}

void pgem_linear_copy_ordering(pgem_linear_t *to, const pgem_store_t *to_store,
                               const pgem_linear_t *from, const pgem_store_t *from_store)
{
    if (from->topology == from_store->topology && from->ordered && !from->all_edges) {
        /* the ordering of this very graph: the analysis reuses it (not the every-edge
         * fallback's, which a larger budget might not need) */
        memcpy(to->pose_block, from->pose_block, from_store->pose_count * sizeof(int));
        to->valid = 0;
        to->ordered = 1;
        to->topology = to_store->topology;
    }
}

/* Bytes of a slice of count * item bytes, padded to the arena's 16-byte alignment. */
static size_t pgem_slice_bytes(size_t count, size_t item)
{
    return (count * item + 15u) & ~(size_t)15u;
}

void pgem_linear_memory_parts(const pgem_config_t *config, pgem_memory_parts_t *parts)
{
    const size_t block = (size_t)PGEM_TANGENT_SIZE(config->dimension);
    parts->factor = pgem_slice_bytes(config->fill_budget, sizeof(double)) +
                    pgem_slice_bytes(config->fill_budget / (block * block) + 1u, sizeof(int));
    parts->csparse_pool = pgem_cs_pool_bytes(config->max_poses, config->max_edges);
}

void pgem_linear_memory_stats(const pgem_linear_t *linear, pgem_memory_stats_t *stats)
{
    stats->factor_nonzeros = (uint32_t)linear->factor.nonzeros;
    stats->analyses = linear->analyses;
    stats->csparse_pool_bytes = linear->cs_pool.size;
    stats->csparse_pool_peak = linear->cs_pool.peak;
}

double *pgem_linear_step(const pgem_linear_t *linear)
{
    return linear->rhs;
}

int pgem_linear_unknowns(const pgem_linear_t *linear)
{
    return linear->scalar_count;
}

const double *pgem_linear_pose_delta(const pgem_linear_t *linear, const double *vector, uint32_t p)
{
    const int block = linear->pose_block[p];
    return block < 0 ? NULL : vector + (size_t)block * (size_t)linear->block;
}

void pgem_linear_keep_gradient(pgem_linear_t *linear)
{
    memcpy(linear->gradient, linear->rhs, (size_t)linear->scalar_count * sizeof(double));
}

void pgem_linear_restore_gradient(pgem_linear_t *linear)
{
    memcpy(linear->rhs, linear->gradient, (size_t)linear->scalar_count * sizeof(double));
}

double pgem_linear_largest_diagonal(const pgem_linear_t *linear)
{
    double largest = 0.0;
    for (int j = 0; j < linear->scalar_count; j++) {
        largest = fmax(largest, fabs(linear->diagonal[j]));
    }
    return largest;
}

double pgem_linear_predicted_gain(const pgem_linear_t *linear, double lambda)
{
    const double *step = linear->rhs;
    double gain = 0.0;
    for (int j = 0; j < linear->scalar_count; j++) {
        gain += step[j] * (linear->gradient[j] + lambda * step[j]);
    }
    return gain;
}

void pgem_linear_progress(pgem_linear_t *linear, const pgem_solve_options_t *options)
{
    linear->progress = options;
}

void pgem_linear_progress_iteration(pgem_linear_t *linear, uint32_t iteration)
{
    linear->progress_iteration = iteration;
}

uint32_t pgem_linear_nonzeros(const pgem_linear_t *linear)
{
    return (uint32_t)linear->factor.nonzeros;
}

void *pgem_linear_shared_region(pgem_linear_t *linear, size_t *bytes)
{
    *bytes = linear->factor.shared_doubles * sizeof(double);
    return linear->factor.shared;
}
