/* Nested dissection, first stage: the coarsening of a part's graph by heavy-edge matching, level
 * by level, down to a graph small enough to bisect directly (linalg/analysis/nested.h). */
#include "linalg/analysis/nested.h"

#ifndef PGEM_NO_NESTED

/* Heavy-edge matching of g and the coarser graph it gives (in c); 0 if the region is short or
 * the graph hardly shrinks. match and visit hold g->n ints each. */
int pgem_nd_coarsen(pgem_nd_t *nd, pgem_nd_graph_t *g, pgem_nd_graph_t *c, int *match,
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

#endif /* PGEM_NO_NESTED */
