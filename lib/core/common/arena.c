/* The one place the core takes memory: aligned slices carved from the caller's block. */
#include "common/common.h"

#define PGEM_ARENA_ALIGN 16u
#define PGEM_ARENA_STRUCT_ALIGN 8u

static void *pgem_arena_slice(pgem_arena_t *arena, size_t count, size_t item, size_t align)
{
    size_t start = (arena->used + (align - 1u)) & ~(size_t)(align - 1u);
    size_t bytes = count * item;
    if ((item != 0 && bytes / item != count) || start < arena->used || start + bytes < start) {
        arena->used = (size_t)-1; /* overflow: no block can hold this */
    } else {
        arena->used = start + bytes;
    }
    if (arena->base == NULL) {
        return NULL; /* measuring */
    }
    arena->carves++;
    if (arena->used > arena->size || pgem_fault_next()) {
        if (arena->failed == 0) {
            arena->failed = arena->carves;
            arena->failed_bytes = bytes;
        }
        return NULL;
    }
    return arena->base + start;
}

void *pgem_arena_take(pgem_arena_t *arena, size_t count, size_t item)
{
    return pgem_arena_slice(arena, count, item, PGEM_ARENA_ALIGN);
}

void *pgem_arena_take_struct(pgem_arena_t *arena, size_t bytes)
{
    return pgem_arena_slice(arena, 1, bytes, PGEM_ARENA_STRUCT_ALIGN);
}
