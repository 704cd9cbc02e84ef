/* The stages of the nested dissection (linalg/analysis/nested.c), private to them: the graph
 * of one level, the region lent to the ordering, the pseudo-random sequence and the gain
 * heaps they share, and each stage's entry. The stages, bottom up: coarsening
 * (nested_coarsen.c), the edge bisection of the coarsest graph and its Fiduccia-Mattheyses
 * refinement (nested_bisect.c), the vertex separator from the cut and its refinement
 * (nested_separator.c), and the dissection itself, which recurses over the parts
 * (nested.c). Nothing of this is compiled for bare metal (PGEM_NO_NESTED). */
#ifndef PGEM_NESTED_H
#define PGEM_NESTED_H

#include <string.h>

#include "linalg/linear.h"

/* linalg/analysis/nested.c: nested dissection of the n-vertex graph whose upper pattern is
 * (colptr, rows): order[k] receives the k-th vertex. region (region_ints ints) is workspace;
 * CSparse's AMD orders the leaves (from linear's pool or the heap). PGEM_OK, or
 * PGEM_ERR_OUT_OF_MEMORY (region too small for the graph, or CSparse out of memory). */
int pgem_nested_order(pgem_linear_t *linear, int n, const int *colptr, const int *rows,
                      int *order, int *region, size_t region_ints);

#ifndef PGEM_NO_NESTED

#define PGEM_ND_LEAF 160        /* parts this small go to AMD */
#define PGEM_ND_COARSE 100      /* coarsen until this many vertices */
#define PGEM_ND_RUNS_LARGE 4    /* separators tried for parts of at least 2000 vertices */
#define PGEM_ND_RUNS_MEDIUM 2   /* and of at least 500 */
#define PGEM_ND_LEVELS 40       /* most coarsening levels */
#define PGEM_ND_TRIALS 6        /* greedy growings from different seeds on the coarsest graph */
#define PGEM_ND_PASSES 8        /* refinement passes per level */
#define PGEM_ND_STALL 64        /* fewest moves without improvement before a pass gives up */
#define PGEM_ND_IMBALANCE 0.10  /* a side may exceed half the weight by this fraction (as
                                   METIS's default for nested dissection) */
#define PGEM_ND_LOCKED (-2)    /* heap position of a vertex a refinement pass moved */

/* A graph in compressed rows, with vertex and edge weights. */
typedef struct pgem_nd_graph {
    int *xadj;    /* [n + 1] */
    int *adj;     /* [xadj[n]] neighbours */
    int *adjw;    /* [xadj[n]] edge weights (NULL: all 1) */
    int *vwgt;    /* [n] vertex weights (NULL: all 1) */
    int *cmap;    /* [n] vertex of the next coarser graph (NULL at the coarsest) */
    int n;        /* vertices */
    int total;    /* sum of vertex weights */
} pgem_nd_graph_t;

/* Edge q's and vertex v's weights (1 where the graph keeps none: the finest level). */
static inline int pgem_nd_ew(const pgem_nd_graph_t *g, int q)
{
    return g->adjw != NULL ? g->adjw[q] : 1;
}

static inline int pgem_nd_vw(const pgem_nd_graph_t *g, int v)
{
    return g->vwgt != NULL ? g->vwgt[v] : 1;
}

/* The lent region, handed out from the bottom; `mark` restores it. */
typedef struct pgem_nd_space {
    int *base;
    size_t size;   /* ints */
    size_t used;
    size_t peak;   /* most ever used */
} pgem_nd_space_t;

typedef struct pgem_nd {
    pgem_nd_space_t space;
    int n;            /* vertices of the whole graph */
    const int *xadj;  /* the whole graph (symmetric, no self loops) */
    const int *adj;
    int *local;       /* [n] whole-graph vertex -> vertex of the extracted part, -1 */
    uint64_t random;  /* xorshift state */
    pgem_cs_pool_t *pool; /* CSparse's workspace, for AMD on the leaves */
} pgem_nd_t;

static inline int *pgem_nd_take(pgem_nd_space_t *space, size_t count)
{
    if (count > space->size - space->used) {
        return NULL;
    }
    int *out = space->base + space->used;
    space->used += count;
    space->peak = space->used > space->peak ? space->used : space->peak;
    return out;
}

static inline uint32_t pgem_nd_random(pgem_nd_t *nd)
{
    uint64_t x = nd->random;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    nd->random = x;
    return (uint32_t)(x >> 32);
}

/* ---- a binary max-heap of vertices keyed by gain ------------------------------------------ */

typedef struct pgem_nd_heap {
    int *vertex;      /* [capacity] */
    int *where;       /* [n] position in vertex, -1 if absent (shared by both heaps) */
    const int *gain;  /* [n] keys */
    int count;
} pgem_nd_heap_t;

static inline void pgem_nd_heap_swap(pgem_nd_heap_t *heap, int a, int b)
{
    const int va = heap->vertex[a], vb = heap->vertex[b];
    heap->vertex[a] = vb;
    heap->vertex[b] = va;
    heap->where[vb] = a;
    heap->where[va] = b;
}

static inline void pgem_nd_heap_up(pgem_nd_heap_t *heap, int at)
{
    while (at > 0) {
        const int up = (at - 1) / 2;
        if (heap->gain[heap->vertex[up]] >= heap->gain[heap->vertex[at]]) {
            return;
        }
        pgem_nd_heap_swap(heap, at, up);
        at = up;
    }
}

static inline void pgem_nd_heap_down(pgem_nd_heap_t *heap, int at)
{
    for (;;) {
        int best = at;
        const int left = 2 * at + 1, right = left + 1;
        if (left < heap->count && heap->gain[heap->vertex[left]] > heap->gain[heap->vertex[best]]) {
            best = left;
        }
        if (right < heap->count && heap->gain[heap->vertex[right]] > heap->gain[heap->vertex[best]]) {
            best = right;
        }
        if (best == at) {
            return;
        }
        pgem_nd_heap_swap(heap, at, best);
        at = best;
    }
}

static inline void pgem_nd_heap_push(pgem_nd_heap_t *heap, int v)
{
    heap->vertex[heap->count] = v;
    heap->where[v] = heap->count++;
    pgem_nd_heap_up(heap, heap->count - 1);
}

static inline void pgem_nd_heap_remove(pgem_nd_heap_t *heap, int v)
{
    const int at = heap->where[v];
    heap->count--;
    if (at != heap->count) {
        pgem_nd_heap_swap(heap, at, heap->count);
        heap->where[v] = -1;
        pgem_nd_heap_up(heap, at);
        pgem_nd_heap_down(heap, at);
    } else {
        heap->where[v] = -1;
    }
}

/* v's key changed. */
static inline void pgem_nd_heap_update(pgem_nd_heap_t *heap, int v)
{
    pgem_nd_heap_up(heap, heap->where[v]);
    pgem_nd_heap_down(heap, heap->where[v]);
}

/* nested_coarsen.c: heavy-edge matching of g and the coarser graph it gives (in c); 0 if the
 * region is short or the graph hardly shrinks. match and visit hold g->n ints each. */
int pgem_nd_coarsen(pgem_nd_t *nd, pgem_nd_graph_t *g, pgem_nd_graph_t *c, int *match,
                    int *visit);

/* nested_bisect.c: how far the heavier side of a bisection is past the allowed share (0 if
 * within it); Fiduccia-Mattheyses refinement of the bisection part (0, 1) of g; side 0 grown
 * from seed, breadth first, until it holds half the weight (queue: g->n ints). */
int pgem_nd_excess(const pgem_nd_graph_t *g, const int *weight);
void pgem_nd_refine(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part);
void pgem_nd_grow(const pgem_nd_graph_t *g, int seed, int *part, int *queue);

/* nested_separator.c: the separator weight of a node partition (0, 1, 2 the separator) plus a
 * penalty past the allowed balance; a separator of the coarsest graph (0: no room); the
 * refinement of a separator. */
int64_t pgem_nd_node_score(const pgem_nd_graph_t *g, const int *part);
int pgem_nd_initial(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part);
void pgem_nd_node_refine(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part);

#endif /* PGEM_NO_NESTED */

#endif /* PGEM_NESTED_H */
