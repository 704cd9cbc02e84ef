/* Nested dissection, second stage: an edge bisection of the coarsest graph, grown greedily from
 * a seed, and its Fiduccia-Mattheyses refinement on the edge cut (linalg/analysis/nested.h). */
#include "linalg/analysis/nested.h"

#ifndef PGEM_NO_NESTED

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
int pgem_nd_excess(const pgem_nd_graph_t *g, const int *weight)
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

void pgem_nd_refine(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part)
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
void pgem_nd_grow(const pgem_nd_graph_t *g, int seed, int *part, int *queue)
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

#endif /* PGEM_NO_NESTED */
