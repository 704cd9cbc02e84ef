/* Nested dissection of the block graph: the graph is split by a small vertex separator into
 * two parts with no edge between them, each part is ordered the same way, the separator last;
 * parts of at most PGEM_ND_LEAF poses are ordered by CSparse's AMD. A separator comes from a
 * multilevel edge bisection (heavy-edge matching down to a small graph, greedy growing there,
 * Fiduccia-Mattheyses refinement on the way back up) turned into a vertex separator by a
 * minimum vertex cover of the cut edges (Konig's theorem on the bipartite cut). Everything is
 * deterministic (a fixed pseudo-random sequence) and works in a region of ints the caller
 * lends (the analysis passes the part of the block H's values will later use); when the region
 * is short the coarsening simply stops earlier. */
#include <string.h>

#include "linalg/linear.h"

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

static int *pgem_nd_take(pgem_nd_space_t *space, size_t count)
{
    if (count > space->size - space->used) {
        return NULL;
    }
    int *out = space->base + space->used;
    space->used += count;
    space->peak = space->used > space->peak ? space->used : space->peak;
    return out;
}

static uint32_t pgem_nd_random(pgem_nd_t *nd)
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

static void pgem_nd_heap_swap(pgem_nd_heap_t *heap, int a, int b)
{
    const int va = heap->vertex[a], vb = heap->vertex[b];
    heap->vertex[a] = vb;
    heap->vertex[b] = va;
    heap->where[vb] = a;
    heap->where[va] = b;
}

static void pgem_nd_heap_up(pgem_nd_heap_t *heap, int at)
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

static void pgem_nd_heap_down(pgem_nd_heap_t *heap, int at)
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

static void pgem_nd_heap_push(pgem_nd_heap_t *heap, int v)
{
    heap->vertex[heap->count] = v;
    heap->where[v] = heap->count++;
    pgem_nd_heap_up(heap, heap->count - 1);
}

static void pgem_nd_heap_remove(pgem_nd_heap_t *heap, int v)
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
static void pgem_nd_heap_update(pgem_nd_heap_t *heap, int v)
{
    pgem_nd_heap_up(heap, heap->where[v]);
    pgem_nd_heap_down(heap, heap->where[v]);
}

/* ---- coarsening ---------------------------------------------------------------------------- */

/* Heavy-edge matching of g and the coarser graph it gives (in c); 0 if the region is short or
 * the graph hardly shrinks. match and visit hold g->n ints each. */
static int pgem_nd_coarsen(pgem_nd_t *nd, pgem_nd_graph_t *g, pgem_nd_graph_t *c, int *match,
                           int *visit)
{
    const size_t mark = nd->space.used;
    g->cmap = pgem_nd_take(&nd->space, (size_t)g->n);
    if (g->cmap == NULL) {
        return 0;
    }
    /* vertices visited by increasing degree, in a fixed pseudo-random order within a degree
     * (METIS's sorted heavy-edge matching: low-degree vertices find a partner first); a
     * pair heavier than 1.5 times the coarsest graph's average vertex is not formed */
    int largest = 0;
    for (int v = 0; v < g->n; v++) {
        const int degree = g->xadj[v + 1] - g->xadj[v];
        largest = degree > largest ? degree : largest;
    }
    /* counting sort by degree (capped so the buckets fit in cmap, free until the numbering
     * below) */
    int *bucket = g->cmap;
    const int cap = largest < g->n - 2 ? largest : g->n - 2;
    for (int d = 0; d <= cap + 1; d++) {
        bucket[d] = 0;
    }
    for (int v = 0; v < g->n; v++) {
        const int degree = g->xadj[v + 1] - g->xadj[v];
        bucket[(degree < cap ? degree : cap) + 1]++;
    }
    for (int d = 0; d < cap; d++) {
        bucket[d + 1] += bucket[d];
    }
    for (int v = 0; v < g->n; v++) {
        const int degree = g->xadj[v + 1] - g->xadj[v];
        visit[bucket[degree < cap ? degree : cap]++] = v;
    }
    for (int start = 0; start < g->n;) { /* shuffle within each degree */
        const int degree = g->xadj[visit[start] + 1] - g->xadj[visit[start]];
        int end = start + 1;
        while (end < g->n && g->xadj[visit[end] + 1] - g->xadj[visit[end]] == degree) {
            end++;
        }
        for (int k = end - 1; k > start; k--) {
            const int w = start + (int)(pgem_nd_random(nd) % (uint32_t)(k - start + 1));
            const int swap = visit[k];
            visit[k] = visit[w];
            visit[w] = swap;
        }
        start = end;
    }
    for (int v = 0; v < g->n; v++) {
        match[v] = -1;
    }
    const int heaviest = (int)(1.5 * (double)g->total / PGEM_ND_COARSE) + 1;
    for (int k = 0; k < g->n; k++) {
        const int u = visit[k];
        if (match[u] >= 0) {
            continue;
        }
        int best = u, weight = -1;
        for (int q = g->xadj[u]; q < g->xadj[u + 1]; q++) {
            const int v = g->adj[q];
            if (match[v] < 0 && pgem_nd_ew(g, q) > weight &&
                pgem_nd_vw(g, u) + pgem_nd_vw(g, v) <= heaviest) {
                best = v;
                weight = pgem_nd_ew(g, q);
            }
        }
        match[u] = best;
        match[best] = u;
    }
    int count = 0;
    for (int v = 0; v < g->n; v++) {
        g->cmap[v] = -1;
    }
    for (int v = 0; v < g->n; v++) {
        if (g->cmap[v] < 0) {
            g->cmap[v] = count;
            g->cmap[match[v]] = count;
            count++;
        }
    }
    const size_t entries_max = (size_t)g->xadj[g->n];
    c->n = count;
    c->total = g->total;
    c->cmap = NULL;
    c->xadj = pgem_nd_take(&nd->space, (size_t)count + 1u);
    c->vwgt = pgem_nd_take(&nd->space, (size_t)count);
    c->adj = pgem_nd_take(&nd->space, entries_max);
    c->adjw = pgem_nd_take(&nd->space, entries_max);
    if (count > g->n - g->n / 8 || c->adjw == NULL) { /* little shrinkage, or no room */
        nd->space.used = mark;
        g->cmap = NULL;
        return 0;
    }
    /* the coarse vertices in the order of their first fine vertex; visit[] becomes each coarse
     * vertex's entry in the list being built */
    int *slot = visit;
    for (int v = 0; v < count; v++) {
        slot[v] = -1;
    }
    int entries = 0, built = 0;
    for (int v = 0; v < g->n; v++) {
        const int cv = g->cmap[v];
        if (cv != built) {
            continue; /* cv's list was built from its first fine vertex */
        }
        const int pair[2] = {v, match[v]};
        const int start = entries;
        c->xadj[cv] = start;
        c->vwgt[cv] = pgem_nd_vw(g, v) + (match[v] != v ? pgem_nd_vw(g, match[v]) : 0);
        for (int side = 0; side < (match[v] != v ? 2 : 1); side++) {
            const int u = pair[side];
            for (int q = g->xadj[u]; q < g->xadj[u + 1]; q++) {
                const int cw = g->cmap[g->adj[q]];
                if (cw == cv) {
                    continue;
                }
                if (slot[cw] < start) {
                    slot[cw] = entries;
                    c->adj[entries] = cw;
                    c->adjw[entries++] = pgem_nd_ew(g, q);
                } else {
                    c->adjw[slot[cw]] += pgem_nd_ew(g, q);
                }
            }
        }
        built++;
    }
    c->xadj[count] = entries;
    /* give back what the lists did not use: the weights move down behind the neighbours */
    memmove(c->adj + entries, c->adjw, (size_t)entries * sizeof *c->adjw);
    c->adjw = c->adj + entries;
    nd->space.used = (size_t)(c->adjw + entries - nd->space.base);
    return 1;
}

/* ---- two-way refinement (Fiduccia-Mattheyses on the edge cut) ---------------------------- */

/* Edge weight of g's cut under part. */
static int64_t pgem_nd_cut(const pgem_nd_graph_t *g, const int *part)
{
    int64_t cut = 0;
    for (int v = 0; v < g->n; v++) {
        for (int q = g->xadj[v]; q < g->xadj[v + 1]; q++) {
            cut += part[g->adj[q]] != part[v] ? pgem_nd_ew(g, q) : 0;
        }
    }
    return cut / 2;
}

/* How far the heavier side is past the allowed share, 0 if within it. */
static int pgem_nd_excess(const pgem_nd_graph_t *g, const int *weight)
{
    const int allowed = (int)((double)g->total * (0.5 + PGEM_ND_IMBALANCE)) + 1;
    const int heavier = weight[0] > weight[1] ? weight[0] : weight[1];
    return heavier > allowed ? heavier - allowed : 0;
}

/* Workspace of a refinement on g: gains, heap positions (-2: locked), the heaps of both
 * sides in one array (side 1's after side 0's: heaps only shrink during a pass) and a move
 * log. */
typedef struct pgem_nd_refine {
    int *gain;   /* [n] external minus internal edge weight */
    int *where;  /* [n] */
    int *heaps;  /* [n] */
    int *log;    /* [n] vertices moved in this pass, in order */
} pgem_nd_refine_t;

#define PGEM_ND_LOCKED (-2)

static int pgem_nd_refine_take(pgem_nd_t *nd, int n, pgem_nd_refine_t *r)
{
    r->gain = pgem_nd_take(&nd->space, (size_t)n);
    r->where = pgem_nd_take(&nd->space, (size_t)n);
    r->heaps = pgem_nd_take(&nd->space, (size_t)n);
    r->log = pgem_nd_take(&nd->space, (size_t)n);
    return r->log != NULL;
}

/* Moves v to the other side, updating the weights, gains and heap places of its
 * neighbours. */
static void pgem_nd_move(const pgem_nd_graph_t *g, int *part, int *weight, pgem_nd_refine_t *r,
                         pgem_nd_heap_t *heaps, int v)
{
    const int from = part[v], to = 1 - from;
    part[v] = to;
    weight[from] -= pgem_nd_vw(g, v);
    weight[to] += pgem_nd_vw(g, v);
    r->gain[v] = -r->gain[v];
    for (int q = g->xadj[v]; q < g->xadj[v + 1]; q++) {
        const int u = g->adj[q];
        r->gain[u] += part[u] == from ? 2 * pgem_nd_ew(g, q) : -2 * pgem_nd_ew(g, q);
        if (r->where[u] >= 0) {
            pgem_nd_heap_update(&heaps[part[u]], u);
        }
    }
}

/* One pass: moves from the heavier side (or the better gain when balanced), keeping the best
 * balanced cut seen; returns 1 if it improved the cut or the balance. */
static int pgem_nd_pass(const pgem_nd_graph_t *g, int *part, int *weight, pgem_nd_refine_t *r)
{
    int sides = 0;
    for (int v = 0; v < g->n; v++) {
        sides += part[v] == 0;
    }
    pgem_nd_heap_t heaps[2] = {{r->heaps, r->where, r->gain, 0},
                               {r->heaps + sides, r->where, r->gain, 0}};
    int64_t cut = pgem_nd_cut(g, part);
    int64_t best_cut = cut;
    int best_excess = pgem_nd_excess(g, weight);
    int moves = 0, best_moves = 0;
    for (int v = 0; v < g->n; v++) {
        int gain = 0;
        for (int q = g->xadj[v]; q < g->xadj[v + 1]; q++) {
            gain += part[g->adj[q]] != part[v] ? pgem_nd_ew(g, q) : -pgem_nd_ew(g, q);
        }
        r->gain[v] = gain;
        r->where[v] = -1;
    }
    for (int v = 0; v < g->n; v++) { /* every vertex is a candidate: the cut may be empty */
        pgem_nd_heap_push(&heaps[part[v]], v);
    }
    while (moves - best_moves < PGEM_ND_STALL && (heaps[0].count > 0 || heaps[1].count > 0)) {
        int side;
        if (pgem_nd_excess(g, weight) > 0) {
            side = weight[0] > weight[1] ? 0 : 1;
        } else if (heaps[0].count == 0 || heaps[1].count == 0) {
            side = heaps[0].count > 0 ? 0 : 1;
        } else {
            side = r->gain[heaps[0].vertex[0]] >= r->gain[heaps[1].vertex[0]] ? 0 : 1;
        }
        if (heaps[side].count == 0) {
            break;
        }
        const int v = heaps[side].vertex[0];
        pgem_nd_heap_remove(&heaps[side], v);
        r->where[v] = PGEM_ND_LOCKED;
        /* a move that would unbalance a balanced bisection is skipped (v stays locked) */
        int after[2] = {weight[0], weight[1]};
        after[side] -= pgem_nd_vw(g, v);
        after[1 - side] += pgem_nd_vw(g, v);
        if (pgem_nd_excess(g, weight) == 0 && pgem_nd_excess(g, after) > 0) {
            continue;
        }
        cut -= r->gain[v];
        pgem_nd_move(g, part, weight, r, heaps, v);
        r->log[moves++] = v;
        const int excess = pgem_nd_excess(g, weight);
        if (excess < best_excess || (excess == best_excess && cut < best_cut)) {
            best_cut = cut;
            best_excess = excess;
            best_moves = moves;
        }
    }
    while (moves > best_moves) { /* undo the moves after the best point */
        const int v = r->log[--moves];
        const int from = part[v];
        part[v] = 1 - from;
        weight[from] -= pgem_nd_vw(g, v);
        weight[1 - from] += pgem_nd_vw(g, v);
    }
    return best_moves > 0;
}

static void pgem_nd_refine(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part)
{
    const size_t mark = nd->space.used;
    pgem_nd_refine_t r;
    if (!pgem_nd_refine_take(nd, g->n, &r)) {
        nd->space.used = mark;
        return;
    }
    int weight[2] = {0, 0};
    for (int v = 0; v < g->n; v++) {
        weight[part[v]] += pgem_nd_vw(g, v);
    }
    for (int pass = 0; pass < PGEM_ND_PASSES && pgem_nd_pass(g, part, weight, &r); pass++) {
    }
    nd->space.used = mark;
}

/* ---- the initial bisection of the coarsest graph ----------------------------------------- */

/* Grows side 0 from seed, breadth first, until it holds half the weight. */
static void pgem_nd_grow(const pgem_nd_graph_t *g, int seed, int *part, int *queue)
{
    for (int v = 0; v < g->n; v++) {
        part[v] = 1;
    }
    int head = 0, tail = 0;
    queue[tail++] = seed;
    part[seed] = 0;
    int weight = pgem_nd_vw(g, seed);
    while (weight < g->total / 2) {
        if (head == tail) { /* disconnected: start again from any vertex left */
            int v = 0;
            while (v < g->n && part[v] == 0) {
                v++;
            }
            if (v == g->n) {
                break;
            }
            part[v] = 0;
            weight += pgem_nd_vw(g, v);
            queue[tail++] = v;
            continue;
        }
        const int u = queue[head++];
        for (int q = g->xadj[u]; q < g->xadj[u + 1] && weight < g->total / 2; q++) {
            const int v = g->adj[q];
            if (part[v] == 1) {
                part[v] = 0;
                weight += pgem_nd_vw(g, v);
                queue[tail++] = v;
            }
        }
    }
}

static int pgem_nd_cover(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part);
static void pgem_nd_node_refine(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part);

/* Separator weight of a node partition, plus a penalty past the allowed balance. */
static int64_t pgem_nd_node_score(const pgem_nd_graph_t *g, const int *part)
{
    int64_t weight[3] = {0, 0, 0};
    for (int v = 0; v < g->n; v++) {
        weight[part[v]] += pgem_nd_vw(g, v);
    }
    const int64_t allowed = (int64_t)((double)g->total * (0.5 + PGEM_ND_IMBALANCE)) + 1;
    const int64_t heavier = weight[0] > weight[1] ? weight[0] : weight[1];
    return weight[2] + (heavier > allowed ? 4 * (heavier - allowed) : 0);
}

/* A vertex separator of the coarsest graph into part (0, 1, 2): the lightest of several
 * greedy growings, each refined as an edge bisection, covered, and refined as a separator. */
static int pgem_nd_initial(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part)
{
    const size_t mark = nd->space.used;
    int *trial = pgem_nd_take(&nd->space, (size_t)g->n);
    int *queue = pgem_nd_take(&nd->space, (size_t)g->n);
    int64_t best = -1;
    for (int t = 0; queue != NULL && t < PGEM_ND_TRIALS; t++) {
        pgem_nd_grow(g, (int)(pgem_nd_random(nd) % (uint32_t)g->n), trial, queue);
        pgem_nd_refine(nd, g, trial);
        if (!pgem_nd_cover(nd, g, trial)) {
            break;
        }
        pgem_nd_node_refine(nd, g, trial);
        const int64_t score = pgem_nd_node_score(g, trial);
        if (best < 0 || score < best) {
            best = score;
            memcpy(part, trial, (size_t)g->n * sizeof *part);
        }
    }
    nd->space.used = mark;
    return best >= 0; /* 0: no room */
}

/* ---- a vertex separator from the edge cut -------------------------------------------------- */

/* Marks a minimum vertex cover of g's cut edges as the separator (part 2): a maximum matching
 * of the bipartite cut (augmenting paths), then Konig's construction from the unmatched
 * vertices of side 0. Returns 0 if the region is short (part then unchanged). */
static int pgem_nd_cover(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part)
{
    const size_t mark = nd->space.used;
    int *mate = pgem_nd_take(&nd->space, (size_t)g->n);
    int *seen = pgem_nd_take(&nd->space, (size_t)g->n);
    int *stack = pgem_nd_take(&nd->space, (size_t)g->n);
    int *edge = pgem_nd_take(&nd->space, (size_t)g->n);
    if (edge == NULL) {
        nd->space.used = mark;
        return 0;
    }
    for (int v = 0; v < g->n; v++) {
        mate[v] = -1;
        seen[v] = -1;
    }
    /* augmenting paths from each side-0 vertex of the cut, depth first, iteratively */
    for (int root = 0; root < g->n; root++) {
        if (part[root] != 0 || mate[root] >= 0) {
            continue;
        }
        int top = 0;
        stack[top] = root;
        edge[top] = g->xadj[root];
        seen[root] = root;
        int found = -1;
        while (top >= 0 && found < 0) {
            const int u = stack[top];
            if (edge[top] == g->xadj[u + 1]) {
                top--;
                continue;
            }
            const int v = g->adj[edge[top]++];
            if (part[v] != 1 || seen[v] == root) {
                continue;
            }
            seen[v] = root;
            if (mate[v] < 0) {
                found = v;
            } else {
                stack[++top] = mate[v];
                edge[top] = g->xadj[mate[v]];
            }
        }
        for (int v = found; top >= 0 && v >= 0; top--) { /* flip the path */
            const int u = stack[top];
            const int previous = mate[u];
            mate[u] = v;
            mate[v] = u;
            v = previous;
        }
    }
    /* Z: reachable from unmatched side-0 cut vertices by alternating paths */
    for (int v = 0; v < g->n; v++) {
        seen[v] = 0;
    }
    int top = 0;
    for (int v = 0; v < g->n; v++) {
        if (part[v] == 0 && mate[v] < 0) {
            seen[v] = 1;
            stack[top++] = v;
        }
    }
    while (top > 0) {
        const int u = stack[--top];
        for (int q = g->xadj[u]; q < g->xadj[u + 1]; q++) {
            const int v = g->adj[q];
            if (part[v] == 1 && !seen[v]) {
                seen[v] = 1;
                if (mate[v] >= 0 && !seen[mate[v]]) {
                    seen[mate[v]] = 1;
                    stack[top++] = mate[v];
                }
            }
        }
    }
    /* cover: matched side-0 vertices outside Z, side-1 cut vertices inside Z */
    for (int v = 0; v < g->n; v++) {
        const int cut = part[v] == 0 ? mate[v] >= 0 && !seen[v] : part[v] == 1 && seen[v];
        stack[v] = cut;
    }
    for (int v = 0; v < g->n; v++) {
        if (stack[v]) {
            part[v] = 2;
        }
    }
    nd->space.used = mark;
    return 1;
}

/* ---- refinement of a vertex separator (part 2) -------------------------------------------- */

/* Workspace of a separator refinement: per side, the gain of moving a separator vertex into
 * it (its weight minus the weight of its neighbours on the other side, which join the
 * separator), a heap of those moves, and a log of the moves for the undo. */
typedef struct pgem_nd_node {
    int *gain[2];  /* [n] */
    int *where[2]; /* [n] heap positions, -1 absent; where[0] == PGEM_ND_LOCKED: moved */
    int *heap[2];  /* [n] */
    int *log;      /* [log_size] per move: the vertices it pulled in, their count, side, vertex */
    int log_size;
} pgem_nd_node_t;

/* vertex v's gain of moving into side `to` (v in the separator). */
static int pgem_nd_node_gain(const pgem_nd_graph_t *g, const int *part, int v, int to)
{
    int gain = pgem_nd_vw(g, v);
    for (int q = g->xadj[v]; q < g->xadj[v + 1]; q++) {
        gain -= part[g->adj[q]] == 1 - to ? pgem_nd_vw(g, g->adj[q]) : 0;
    }
    return gain;
}

static void pgem_nd_node_key(pgem_nd_heap_t *heaps, int side, int v)
{
    if (heaps[side].where[v] >= 0) {
        pgem_nd_heap_update(&heaps[side], v);
    }
}

/* Moves separator vertex s into side `to`, pulling its neighbours on the other side into the
 * separator, with the gains and the log kept up; returns 0 if the log is full (nothing
 * done). */
static int pgem_nd_node_move(const pgem_nd_graph_t *g, int *part, int *weight, pgem_nd_node_t *r,
                             pgem_nd_heap_t *heaps, int s, int to, int *logged)
{
    const int other = 1 - to;
    int pulled = 0;
    for (int q = g->xadj[s]; q < g->xadj[s + 1]; q++) {
        pulled += part[g->adj[q]] == other;
    }
    if (*logged + pulled + 3 > r->log_size) {
        return 0;
    }
    part[s] = to;
    weight[to] += pgem_nd_vw(g, s);
    weight[2] -= pgem_nd_vw(g, s);
    for (int q = g->xadj[s]; q < g->xadj[s + 1]; q++) {
        const int u = g->adj[q];
        if (part[u] == 2) { /* u into `other` now also pulls s */
            r->gain[other][u] -= pgem_nd_vw(g, s);
            pgem_nd_node_key(heaps, other, u);
        } else if (part[u] == other) {
            part[u] = 2;
            weight[other] -= pgem_nd_vw(g, u);
            weight[2] += pgem_nd_vw(g, u);
            r->log[(*logged)++] = u;
            for (int e = g->xadj[u]; e < g->xadj[u + 1]; e++) {
                const int w = g->adj[e];
                if (part[w] == 2 && w != u) { /* w into `to` no longer pulls u */
                    r->gain[to][w] += pgem_nd_vw(g, u);
                    pgem_nd_node_key(heaps, to, w);
                }
            }
            if (r->where[0][u] != PGEM_ND_LOCKED) {
                for (int side = 0; side < 2; side++) {
                    r->gain[side][u] = pgem_nd_node_gain(g, part, u, side);
                    if (heaps[side].where[u] >= 0) {
                        pgem_nd_heap_update(&heaps[side], u);
                    } else {
                        pgem_nd_heap_push(&heaps[side], u);
                    }
                }
            }
        }
    }
    r->log[(*logged)++] = pulled;
    r->log[(*logged)++] = to;
    r->log[(*logged)++] = s;
    return 1;
}

/* The heaviest side allowed. */
static int pgem_nd_node_allowed(const pgem_nd_graph_t *g)
{
    return (int)((double)g->total * (0.5 + PGEM_ND_IMBALANCE)) + 1;
}

/* One pass of separator refinement (moves into the lighter side first); keeps the lightest
 * balanced separator seen. Returns 1 if it got lighter. */
static int pgem_nd_node_pass(const pgem_nd_graph_t *g, int *part, int *weight, pgem_nd_node_t *r)
{
    pgem_nd_heap_t heaps[2] = {{r->heap[0], r->where[0], r->gain[0], 0},
                               {r->heap[1], r->where[1], r->gain[1], 0}};
    const int allowed = pgem_nd_node_allowed(g);
    for (int v = 0; v < g->n; v++) {
        r->where[0][v] = -1;
        r->where[1][v] = -1;
    }
    for (int v = 0; v < g->n; v++) {
        if (part[v] == 2) {
            for (int side = 0; side < 2; side++) {
                r->gain[side][v] = pgem_nd_node_gain(g, part, v, side);
                pgem_nd_heap_push(&heaps[side], v);
            }
        }
    }
    const int start = weight[2];
    int separator = 0;
    for (int v = 0; v < g->n; v++) {
        separator += part[v] == 2;
    }
    /* as METIS: a pass may wander twice the separator's size (at most 300) past its best */
    int stall = 2 * separator;
    stall = stall < PGEM_ND_STALL ? PGEM_ND_STALL : stall > 300 ? 300 : stall;
    int best = weight[2], moves = 0, best_moves = 0, logged = 0, best_logged = 0;
    int best_excess = weight[0] > allowed || weight[1] > allowed;
    while (moves - best_moves < stall) {
        /* the better of the two sides' best moves that keeps the balance (the lighter side
         * on a tie; into the lighter side when out of balance) */
        int to = -1;
        const int lighter = weight[0] <= weight[1] ? 0 : 1;
        for (int pick = 0; pick < 2; pick++) {
            const int side = pick == 0 ? lighter : 1 - lighter;
            if (heaps[side].count == 0) {
                continue;
            }
            const int v = heaps[side].vertex[0];
            const int fits = weight[side] + pgem_nd_vw(g, v) <= allowed;
            if (!fits && !(best_excess && side == lighter)) {
                continue;
            }
            if (to < 0 || (!best_excess && r->gain[side][v] > r->gain[to][heaps[to].vertex[0]])) {
                to = side;
            }
        }
        if (to < 0) {
            break;
        }
        const int s = heaps[to].vertex[0];
        pgem_nd_heap_remove(&heaps[0], s);
        pgem_nd_heap_remove(&heaps[1], s);
        r->where[0][s] = PGEM_ND_LOCKED;
        if (!pgem_nd_node_move(g, part, weight, r, heaps, s, to, &logged)) {
            part[s] = 2; /* the log is full: the pass ends here */
            break;
        }
        moves++;
        const int excess = weight[0] > allowed || weight[1] > allowed;
        if ((excess < best_excess) || (excess == best_excess && weight[2] < best)) {
            best = weight[2];
            best_excess = excess;
            best_moves = moves;
            best_logged = logged;
        }
    }
    while (logged > best_logged) { /* undo, last move first */
        const int s = r->log[--logged];
        const int to = r->log[--logged];
        const int pulled = r->log[--logged];
        part[s] = 2;
        weight[to] -= pgem_nd_vw(g, s);
        weight[2] += pgem_nd_vw(g, s);
        for (int k = 0; k < pulled; k++) {
            const int u = r->log[--logged];
            part[u] = 1 - to;
            weight[1 - to] += pgem_nd_vw(g, u);
            weight[2] -= pgem_nd_vw(g, u);
        }
    }
    return best < start;
}

static void pgem_nd_node_refine(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part)
{
    const size_t mark = nd->space.used;
    pgem_nd_node_t r;
    for (int side = 0; side < 2; side++) {
        r.gain[side] = pgem_nd_take(&nd->space, (size_t)g->n);
        r.where[side] = pgem_nd_take(&nd->space, (size_t)g->n);
        r.heap[side] = pgem_nd_take(&nd->space, (size_t)g->n);
    }
    r.log_size = 2 * g->n + 16;
    r.log = pgem_nd_take(&nd->space, (size_t)r.log_size);
    if (r.log == NULL) {
        nd->space.used = mark;
        return;
    }
    int weight[3] = {0, 0, 0};
    for (int v = 0; v < g->n; v++) {
        weight[part[v]] += pgem_nd_vw(g, v);
    }
    for (int pass = 0; pass < PGEM_ND_PASSES && pgem_nd_node_pass(g, part, weight, &r); pass++) {
    }
    nd->space.used = mark;
}

/* ---- one dissection step ------------------------------------------------------------------- */

/* The part of the whole graph on vertices[0 .. count), renumbered 0 .., as graph g. */
static int pgem_nd_extract(pgem_nd_t *nd, const int *vertices, int count, pgem_nd_graph_t *g)
{
    for (int k = 0; k < count; k++) {
        nd->local[vertices[k]] = k;
    }
    size_t entries = 0;
    for (int k = 0; k < count; k++) {
        const int v = vertices[k];
        for (int q = nd->xadj[v]; q < nd->xadj[v + 1]; q++) {
            entries += nd->local[nd->adj[q]] >= 0;
        }
    }
    g->n = count;
    g->total = count;
    g->cmap = NULL;
    g->vwgt = NULL; /* every weight 1 */
    g->adjw = NULL;
    g->xadj = pgem_nd_take(&nd->space, (size_t)count + 1u);
    g->adj = pgem_nd_take(&nd->space, entries);
    if (g->adj == NULL) {
        return 0;
    }
    int at = 0;
    for (int k = 0; k < count; k++) {
        const int v = vertices[k];
        g->xadj[k] = at;
        for (int q = nd->xadj[v]; q < nd->xadj[v + 1]; q++) {
            const int w = nd->local[nd->adj[q]];
            if (w >= 0) {
                g->adj[at++] = w;
            }
        }
    }
    g->xadj[count] = at;
    return 1;
}

static void pgem_nd_forget(pgem_nd_t *nd, const int *vertices, int count)
{
    for (int k = 0; k < count; k++) {
        nd->local[vertices[k]] = -1;
    }
}

/* Multilevel vertex separator of g into part (0, 1, or 2 for the separator). */
static int pgem_nd_separate_once(pgem_nd_t *nd, pgem_nd_graph_t *g, int *part)
{
    const size_t mark = nd->space.used;
    pgem_nd_graph_t levels[PGEM_ND_LEVELS];
    int *temp = pgem_nd_take(&nd->space, (size_t)g->n);
    int *visit = pgem_nd_take(&nd->space, (size_t)g->n);
    if (visit == NULL) {
        nd->space.used = mark;
        return 0;
    }
    int depth = 0;
    levels[0] = *g;
    while (depth + 1 < PGEM_ND_LEVELS && levels[depth].n > PGEM_ND_COARSE &&
           pgem_nd_coarsen(nd, &levels[depth], &levels[depth + 1], temp, visit)) {
        depth++;
    }
    /* the coarsest graph gets a vertex separator (pgem_nd_initial); it is projected level by
     * level (a coarse vertex's fine vertices keep its side) and refined on each */
    if (!pgem_nd_initial(nd, &levels[depth], temp)) {
        nd->space.used = mark;
        return 0;
    }
    for (int l = depth - 1; l >= 0; l--) {
        for (int v = 0; v < levels[l].n; v++) {
            part[v] = temp[levels[l].cmap[v]];
        }
        memcpy(temp, part, (size_t)levels[l].n * sizeof *temp);
        pgem_nd_node_refine(nd, &levels[l], temp);
    }
    memcpy(part, temp, (size_t)g->n * sizeof *part);
    nd->space.used = mark;
    return 1;
}

/* The best of a few multilevel separators (each with its own pseudo-random matchings) for
 * large parts, where the separators decide most of the flops; one for small parts. */
static int pgem_nd_separate(pgem_nd_t *nd, pgem_nd_graph_t *g, int *part)
{
    const int runs = g->n >= 2000 ? PGEM_ND_RUNS_LARGE : g->n >= 500 ? PGEM_ND_RUNS_MEDIUM : 1;
    if (runs == 1) {
        return pgem_nd_separate_once(nd, g, part);
    }
    const size_t mark = nd->space.used;
    int *trial = pgem_nd_take(&nd->space, (size_t)g->n);
    if (trial == NULL) {
        return pgem_nd_separate_once(nd, g, part);
    }
    int64_t best = -1;
    for (int run = 0; run < runs; run++) {
        if (!pgem_nd_separate_once(nd, g, trial)) {
            break;
        }
        const int64_t score = pgem_nd_node_score(g, trial);
        if (best < 0 || score < best) {
            best = score;
            memcpy(part, trial, (size_t)g->n * sizeof *part);
        }
    }
    nd->space.used = mark;
    return best >= 0;
}

/* Orders vertices[0 .. count) by AMD on their part of the graph, in place. */
static int pgem_nd_leaf(pgem_nd_t *nd, int *vertices, int count)
{
    if (count <= 2) {
        return PGEM_OK;
    }
    const size_t mark = nd->space.used;
    pgem_nd_graph_t g;
    int *copy = pgem_nd_take(&nd->space, (size_t)count);
    int status = PGEM_OK;
    if (copy == NULL || !pgem_nd_extract(nd, vertices, count, &g)) {
        pgem_nd_forget(nd, vertices, count);
        nd->space.used = mark;
        return PGEM_OK; /* no room: the part keeps its order */
    }
    pgem_nd_forget(nd, vertices, count);
    cs_di pattern = {g.xadj[count], count, count, g.xadj, g.adj, NULL, -1};
    pgem_cs_open(nd->pool);
    int *order = cs_di_amd(1, &pattern);
    if (order == NULL) {
        status = PGEM_ERR_OUT_OF_MEMORY;
    } else {
        memcpy(copy, vertices, (size_t)count * sizeof *copy);
        for (int k = 0; k < count; k++) {
            vertices[k] = copy[order[k]];
        }
        cs_di_free(order);
    }
    pgem_cs_close(nd->pool);
    nd->space.used = mark;
    return status;
}

/* 1 if no edge joins part 0 and part 1 of vertices[0 .. count). */
static int pgem_nd_separates(pgem_nd_t *nd, const int *vertices, int count, const int *part)
{
    for (int k = 0; k < count; k++) {
        nd->local[vertices[k]] = k;
    }
    int ok = 1;
    for (int k = 0; k < count && ok; k++) {
        const int v = vertices[k];
        for (int q = nd->xadj[v]; q < nd->xadj[v + 1]; q++) {
            const int w = nd->local[nd->adj[q]];
            ok = ok && (w < 0 || part[w] == 2 || part[k] == 2 || part[w] == part[k]);
        }
    }
    pgem_nd_forget(nd, vertices, count);
    return ok;
}

/* Splits vertices[0 .. count) in place into [part 0 | part 1 | separator]; *first and *second
 * receive the two parts' sizes. 0 if no useful split was found. */
static int pgem_nd_step(pgem_nd_t *nd, int *vertices, int count, int *first, int *second)
{
    const size_t mark = nd->space.used;
    pgem_nd_graph_t g;
    int *part = pgem_nd_take(&nd->space, (size_t)count);
    const size_t separated = nd->space.used;
    const int ok = part != NULL && pgem_nd_extract(nd, vertices, count, &g) &&
                   pgem_nd_separate(nd, &g, part);
    pgem_nd_forget(nd, vertices, count);
    nd->space.used = separated;
    int *copy = pgem_nd_take(&nd->space, (size_t)count);
    int sizes[3] = {0, 0, 0};
    for (int k = 0; ok && k < count; k++) {
        sizes[part[k]]++;
    }
    if (ok && !pgem_nd_separates(nd, vertices, count, part)) {
        sizes[0] = 0; /* never: the separator is built to cover every cut edge */
    }
    if (!ok || copy == NULL || sizes[0] == 0 || sizes[1] == 0) {
        nd->space.used = mark;
        return 0;
    }
    memcpy(copy, vertices, (size_t)count * sizeof *copy);
    int at[3] = {0, sizes[0], sizes[0] + sizes[1]};
    for (int k = 0; k < count; k++) {
        vertices[at[part[k]]++] = copy[k];
    }
    *first = sizes[0];
    *second = sizes[1];
    nd->space.used = mark;
    return 1;
}

int pgem_nested_order(pgem_linear_t *linear, int n, const int *colptr, const int *rows,
                      int *order, int *region, size_t region_ints)
{
    pgem_nd_t nd;
    nd.space.base = region;
    nd.space.size = region_ints;
    nd.space.used = 0;
    nd.space.peak = 0;
    nd.n = n;
    nd.random = UINT64_C(0x9e3779b97f4a7c15);
    nd.pool = &linear->cs_pool;
    /* the whole graph, symmetric, from the upper block pattern */
    int *xadj = pgem_nd_take(&nd.space, (size_t)n + 1u);
    int *adj = pgem_nd_take(&nd.space, 2u * (size_t)colptr[n]);
    nd.local = pgem_nd_take(&nd.space, (size_t)n);
    int *ranges = pgem_nd_take(&nd.space, 2u * ((size_t)n / PGEM_ND_LEAF + 64u));
    if (ranges == NULL) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    for (int v = 0; v <= n; v++) {
        xadj[v] = 0;
    }
    for (int j = 0; j < n; j++) {
        for (int q = colptr[j]; q < colptr[j + 1]; q++) {
            xadj[rows[q] + 1]++;
            xadj[j + 1]++;
        }
    }
    for (int v = 0; v < n; v++) {
        xadj[v + 1] += xadj[v];
        nd.local[v] = xadj[v]; /* fill cursor, reset below */
    }
    for (int j = 0; j < n; j++) {
        for (int q = colptr[j]; q < colptr[j + 1]; q++) {
            adj[nd.local[rows[q]]++] = j;
            adj[nd.local[j]++] = rows[q];
        }
    }
    nd.xadj = xadj;
    nd.adj = adj;
    for (int v = 0; v < n; v++) {
        nd.local[v] = -1;
        order[v] = v;
    }
    /* depth first over ranges of order: each range is split in place, the separator staying
     * at its end; the stack holds (start, count) pairs */
    const size_t capacity = (size_t)n / PGEM_ND_LEAF + 64u;
    size_t top = 0;
    ranges[0] = 0;
    ranges[1] = n;
    top = 1;
    int status = PGEM_OK;
    while (top > 0 && status == PGEM_OK) {
        top--;
        const int start = ranges[2 * top], count = ranges[2 * top + 1];
        int first = 0, second = 0;
        if (count <= PGEM_ND_LEAF || top + 2 > capacity ||
            !pgem_nd_step(&nd, order + start, count, &first, &second)) {
            status = pgem_nd_leaf(&nd, order + start, count);
            continue;
        }
        ranges[2 * top] = start + first; /* the second part, after the first */
        ranges[2 * top + 1] = second;
        ranges[2 * top + 2] = start;
        ranges[2 * top + 3] = first;
        top += 2;
    }
    return status;
}

#endif /* PGEM_NO_NESTED */
