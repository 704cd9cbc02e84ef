/* The solver layer's part of the block: the estimate copies of a solve and of LM. */
#include "solver/solver.h"

void pgem_solver_carve(pgem_solver_state_t *state, const pgem_config_t *config, int pose_size,
                       pgem_arena_t *arena)
{
    const size_t doubles = (size_t)config->max_poses * (size_t)pose_size;
    state->pose_saved = pgem_arena_take(arena, doubles, sizeof(double));
    state->pose_accepted = pgem_arena_take(arena, doubles, sizeof(double));
}
