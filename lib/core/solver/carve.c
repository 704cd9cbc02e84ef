/* The solver layer's part of the block: the estimate copies of a solve and of LM. */
#include "instance.h"
#include "solver/solver.h"

void pgem_solver_carve(pgem_t *graph, pgem_arena_t *arena)
{
    const size_t doubles = (size_t)graph->config.max_poses * (size_t)graph->pose_size;
    graph->solver.pose_saved = pgem_arena_take(arena, doubles, sizeof(double));
    graph->solver.pose_accepted = pgem_arena_take(arena, doubles, sizeof(double));
}
