/* CSparse's allocator for the source-built CSparse (PGEM_CSPARSE_ARENA): cs_malloc, cs_calloc,
 * cs_realloc and cs_free draw from a region of the pgem block instead of the C heap.
 *
 * CSparse's routines take no allocator argument, so the core opens the instance's pool around
 * the calls that allocate (pgem_cs_open / pgem_cs_close, one thread at a time per pool; the
 * pointer to the open pool is thread-local on hosted builds). The pool is a stack: each slice
 * carries a header with its size and the previous top; freeing the top slice pops it (and any
 * slices under it already freed), freeing another slice marks it, and the next open empties
 * the pool.
 * The symbolic routines free in nearly LIFO order, so the peak stays near their true need;
 * pgem_cs_pool_bytes bounds it from above for the calls the core makes
 * (docs/design/csparse-and-exhaustion.md). */
#include <string.h>

#include "linalg/linear.h"

#ifdef PGEM_CSPARSE_ARENA

#if defined(PGEM_SINGLE_THREAD) || !defined(__GNUC__)
#define PGEM_THREAD_LOCAL
#else
#define PGEM_THREAD_LOCAL __thread
#endif

#define PGEM_POOL_ALIGN ((size_t)16)
#define PGEM_POOL_FREED ((size_t)1)

/* Sits in front of every slice; padded to the alignment. */
typedef struct pgem_pool_header {
    size_t bytes;     /* payload bytes asked for */
    size_t previous;  /* offset of the slice below, or (size_t)-1; bit 0 set once freed */
} pgem_pool_header_t;

#define PGEM_POOL_HEADER \
    ((sizeof(pgem_pool_header_t) + PGEM_POOL_ALIGN - 1u) & ~(PGEM_POOL_ALIGN - 1u))
#define PGEM_POOL_NONE ((size_t)-1 & ~PGEM_POOL_FREED)

static PGEM_THREAD_LOCAL pgem_cs_pool_t *pgem_pool_open;

static size_t pgem_pool_round(size_t bytes)
{
    return (bytes + PGEM_POOL_ALIGN - 1u) & ~(PGEM_POOL_ALIGN - 1u);
}

size_t pgem_cs_pool_bytes(uint32_t max_poses, uint32_t max_edges)
{
    /* The largest call is cs_amd on n = max_poses blocks and z <= max_edges upper-triangle
     * entries: A' (n+1+z), C = A+A' (n+1+2z) and C regrown to 1.2 cnz + 2n with cnz <= 2z,
     * the result (n+1), 8(n+1) workspace and two n-sized calloc'ed workspaces: at most
     * 14n + 6z + 12 ints even if nothing were ever given back, in under 16 slices.
     * etree + post + counts together need 12n + z + 4. */
    const size_t n = max_poses, z = max_edges;
    const size_t ints = 14u * n + 6u * z + 32u;
    return pgem_pool_round(ints * sizeof(int)) + 16u * (PGEM_POOL_HEADER + PGEM_POOL_ALIGN) +
           4u * pgem_pool_round(sizeof(cs_di));
}

void pgem_cs_open(pgem_cs_pool_t *pool)
{
    pool->used = 0; /* whatever the last analysis left is given back here */
    pool->top = PGEM_POOL_NONE;
    pgem_pool_open = pool;
}

void pgem_cs_close(pgem_cs_pool_t *pool)
{
    (void)pool;
    pgem_pool_open = NULL;
}

static pgem_pool_header_t *pgem_pool_header(pgem_cs_pool_t *pool, size_t offset)
{
    return (pgem_pool_header_t *)(void *)(pool->base + offset);
}

/* Offset of the header of slice p (which the open pool handed out). */
static size_t pgem_pool_offset(const pgem_cs_pool_t *pool, const void *p)
{
    return (size_t)((const unsigned char *)p - pool->base) - PGEM_POOL_HEADER;
}

/* Payload bytes of n items of size bytes (CSparse asks for max(n, 1)); 0 if it overflows. */
static int pgem_pool_request(int n, size_t size, size_t *bytes)
{
    const size_t count = n > 0 ? (size_t)n : 1u;
    if (size != 0 && count > ((size_t)-1 / 2u) / size) {
        return 0;
    }
    *bytes = count * size;
    return 1;
}

/* Makes the slice whose header is at offset, the top one, hold bytes; 0 if the region cannot. */
static int pgem_pool_fit(pgem_cs_pool_t *pool, size_t offset, size_t bytes)
{
    if (PGEM_POOL_HEADER + pgem_pool_round(bytes) > pool->size - offset) {
        return 0;
    }
    pgem_pool_header(pool, offset)->bytes = bytes;
    pool->used = offset + PGEM_POOL_HEADER + pgem_pool_round(bytes);
    if (pool->used > pool->peak) {
        pool->peak = pool->used;
    }
    return 1;
}

static void *pgem_pool_take(int n, size_t size)
{
    pgem_cs_pool_t *pool = pgem_pool_open;
    size_t bytes;
    if (pool == NULL || pool->base == NULL || !pgem_pool_request(n, size, &bytes)) {
        return NULL;
    }
    const size_t start = pool->used; /* aligned, and never past pool->size */
    if (!pgem_pool_fit(pool, start, bytes)) {
        return NULL;
    }
    pgem_pool_header(pool, start)->previous = pool->top;
    pool->top = start;
    return pool->base + start + PGEM_POOL_HEADER;
}

/* pgem_fault_next() is 0 except in the exhaustion test's copy of the core, which fails each
 * allocation in turn (common/common.h). */
void *cs_di_malloc(int n, size_t size)
{
    return pgem_fault_next() ? NULL : pgem_pool_take(n, size);
}

void *cs_di_calloc(int n, size_t size)
{
    void *p = pgem_fault_next() ? NULL : pgem_pool_take(n, size);
    if (p != NULL) {
        memset(p, 0, pgem_pool_header(pgem_pool_open, pgem_pool_offset(pgem_pool_open, p))->bytes);
    }
    return p;
}

void *cs_di_free(void *p)
{
    pgem_cs_pool_t *pool = pgem_pool_open;
    if (p == NULL || pool == NULL) {
        return NULL;
    }
    pgem_pool_header(pool, pgem_pool_offset(pool, p))->previous |= PGEM_POOL_FREED;
    /* pop every freed slice at the top */
    while (pool->top != PGEM_POOL_NONE &&
           (pgem_pool_header(pool, pool->top)->previous & PGEM_POOL_FREED) != 0) {
        pool->used = pool->top;
        pool->top = pgem_pool_header(pool, pool->top)->previous & ~PGEM_POOL_FREED;
    }
    return NULL;
}

void *cs_di_realloc(void *p, int n, size_t size, int *ok)
{
    pgem_cs_pool_t *pool = pgem_pool_open;
    size_t bytes;
    if (pgem_fault_next()) {
        *ok = 0;
        return p;
    }
    if (p == NULL) {
        void *fresh = pgem_pool_take(n, size);
        *ok = fresh != NULL;
        return fresh;
    }
    if (pool == NULL || !pgem_pool_request(n, size, &bytes)) {
        *ok = 0;
        return p;
    }
    const size_t offset = pgem_pool_offset(pool, p);
    pgem_pool_header_t *header = pgem_pool_header(pool, offset);
    if (offset == pool->top) { /* the top slice grows or shrinks in place */
        *ok = pgem_pool_fit(pool, offset, bytes);
        return p;
    }
    if (bytes <= header->bytes) { /* shrinking a slice below the top: keep it where it is */
        header->bytes = bytes;
        *ok = 1;
        return p;
    }
    void *fresh = pgem_pool_take(n, size);
    if (fresh == NULL) {
        *ok = 0;
        return p;
    }
    memcpy(fresh, p, header->bytes);
    (void)cs_di_free(p);
    *ok = 1;
    return fresh;
}

#else /* CSparse from the system library: it uses the C heap, and the pool is empty. */

size_t pgem_cs_pool_bytes(uint32_t max_poses, uint32_t max_edges)
{
    (void)max_poses;
    (void)max_edges;
    return 0;
}

void pgem_cs_open(pgem_cs_pool_t *pool)
{
    (void)pool;
}

void pgem_cs_close(pgem_cs_pool_t *pool)
{
    (void)pool;
}

#endif
