/* Nested dissection of the block graph: the graph is split by a small vertex separator into
 * two parts with no edge between them, each part is ordered the same way, the separator last;
 * parts of at most PGEM_ND_LEAF poses are ordered by CSparse's AMD. A separator comes from a
 * multilevel edge bisection (heavy-edge matching down to a small graph, greedy growing there,
 * Fiduccia-Mattheyses refinement on the way back up) turned into a vertex separator by a
 * minimum vertex cover of the cut edges (Konig's theorem on the bipartite cut). Everything is
 * deterministic (a fixed pseudo-random sequence) and works in a region of ints the caller
 * lends (the analysis passes the part of the block H's values will later use); when the region
 * is short the coarsening simply stops earlier. This file is the dissection itself; its stages
 * are nested_coarsen.c, nested_bisect.c and nested_separator.c (linalg/analysis/nested.h). */
#include "linalg/analysis/nested.h"

#ifndef PGEM_NO_NESTED

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
