/* Nested dissection, third stage: a vertex separator, from the coarsest graph's bisections
 * (a minimum vertex cover of the cut edges, Konig's theorem on the bipartite cut) and refined
 * level by level on the way back up (linalg/analysis/nested.h). */
#include "linalg/analysis/nested.h"

#ifndef PGEM_NO_NESTED

static int pgem_nd_cover(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part);

/* Separator weight of a node partition, plus a penalty past the allowed balance. */
int64_t pgem_nd_node_score(const pgem_nd_graph_t *g, const int *part)
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
int pgem_nd_initial(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part)
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

void pgem_nd_node_refine(pgem_nd_t *nd, const pgem_nd_graph_t *g, int *part)
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

#endif /* PGEM_NO_NESTED */
