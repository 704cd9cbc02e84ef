/* The one place the core takes memory: aligned slices carved from the caller's block. */
#include "internal.h"

#define PGEM_ARENA_ALIGN 16u

void *pgem_arena_take(pgem_arena_t *arena, size_t count, size_t item)
{
    size_t start = (arena->used + (PGEM_ARENA_ALIGN - 1u)) & ~(size_t)(PGEM_ARENA_ALIGN - 1u);
    size_t bytes = count * item;
    if (item != 0 && bytes / item != count) {
        arena->used = (size_t)-1; /* overflow: no block can hold this */
        return NULL;
    }
    if (start < arena->used || start + bytes < start) {
        arena->used = (size_t)-1;
        return NULL;
    }
    arena->used = start + bytes;
    if (arena->base == NULL || arena->used > arena->size) {
        return NULL;
    }
    return arena->base + start;
}
