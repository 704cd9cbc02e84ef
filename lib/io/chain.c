/* pgem I/O chain: poses of an edge-only file, guessed along a spanning tree, odometry first. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "io_internal.h"
#include "pgem/geometry.h"

/* The graph seen as nodes (pose indices, ordered by id) and incident edges. */
typedef struct io_tree {
    pgem_io_graph_t *graph;
    size_t node_count;
    size_t *edge_from;     /* node of each edge's from id */
    size_t *edge_to;       /* node of each edge's to id */
    size_t *slot_start;    /* node -> first entry of slot_edge (node_count + 1 entries) */
    size_t *slot_edge;     /* incident edges of every node, in file order */
    unsigned char *reached;
    size_t *order;         /* nodes in the order they were reached */
    size_t reached_count;
    int overflowed;        /* a guess came out not finite: */
    size_t overflow_edge;  /* the first edge that made one, */
    size_t overflow_node;  /* the node it reached */
    size_t overflow_start; /* and the node it came from */
} io_tree_t;

static void io_tree_free(io_tree_t *tree)
{
    free(tree->edge_from);
    free(tree->edge_to);
    free(tree->slot_start);
    free(tree->slot_edge);
    free(tree->reached);
    free(tree->order);
}

static int io_tree_allocate(io_tree_t *tree, size_t edge_count)
{
    size_t nodes = tree->node_count;
    tree->edge_from = (size_t *)malloc(edge_count * sizeof(size_t));
    tree->edge_to = (size_t *)malloc(edge_count * sizeof(size_t));
    tree->slot_start = (size_t *)calloc(nodes + 1, sizeof(size_t));
    tree->slot_edge = (size_t *)calloc(2 * edge_count, sizeof(size_t));
    tree->reached = (unsigned char *)calloc(nodes, 1);
    tree->order = (size_t *)calloc(nodes, sizeof(size_t));
    return tree->edge_from && tree->edge_to && tree->slot_start && tree->slot_edge &&
                   tree->reached && tree->order
               ? PGEM_OK
               : PGEM_ERR_OUT_OF_MEMORY;
}

/* Every id named by an edge, sorted and unique, into *ids (caller frees); returns the count. */
static size_t io_edge_ids(const pgem_io_graph_t *graph, pgem_id_t **ids)
{
    size_t count = 0;
    size_t e;
    *ids = (pgem_id_t *)malloc(2 * graph->edge_count * sizeof **ids);
    if (*ids == NULL) {
        return 0;
    }
    for (e = 0; e < graph->edge_count; ++e) {
        (*ids)[2 * e] = graph->edges[e].from;
        (*ids)[2 * e + 1] = graph->edges[e].to;
    }
    io_sort_ids(*ids, 2 * graph->edge_count);
    for (e = 0; e < 2 * graph->edge_count; ++e) {
        if (count == 0 || (*ids)[count - 1] != (*ids)[e]) {
            (*ids)[count++] = (*ids)[e];
        }
    }
    return count;
}

/* One pose per id, ordered by id, at the identity. */
static int io_create_poses(pgem_io_graph_t *graph, const pgem_id_t *ids, size_t count)
{
    size_t i;
    for (i = 0; i < count; ++i) {
        pgem_io_pose_t *pose = io_graph_new_pose(graph);
        if (pose == NULL) {
            return PGEM_ERR_OUT_OF_MEMORY;
        }
        pose->id = ids[i];
        io_identity_pose(graph->dimension, pose->pose);
    }
    graph->chained_poses = count;
    return PGEM_OK;
}

/* Edge endpoints as node indices and the incidence lists (compressed, file order). */
static void io_tree_link(io_tree_t *tree, const pgem_id_t *ids)
{
    const pgem_io_graph_t *graph = tree->graph;
    size_t e;
    size_t node;
    size_t *fill = tree->order; /* borrowed as a cursor per node before the search uses it */
    for (e = 0; e < graph->edge_count; ++e) {
        io_find_id(ids, tree->node_count, graph->edges[e].from, &tree->edge_from[e]);
        io_find_id(ids, tree->node_count, graph->edges[e].to, &tree->edge_to[e]);
        tree->slot_start[tree->edge_from[e] + 1]++;
        tree->slot_start[tree->edge_to[e] + 1]++;
    }
    for (node = 0; node < tree->node_count; ++node) {
        tree->slot_start[node + 1] += tree->slot_start[node];
        fill[node] = tree->slot_start[node];
    }
    for (e = 0; e < graph->edge_count; ++e) {
        tree->slot_edge[fill[tree->edge_from[e]]++] = e;
        tree->slot_edge[fill[tree->edge_to[e]]++] = e;
    }
}

/* The measurement of an edge, quaternion normalised (a copy; the edge keeps what was read); a
 * zero quaternion, or one too large to normalise (its norm overflows), becomes the identity
 * rotation. */
static void io_unit_measurement(int dimension, const double *measurement, double *out)
{
    double norm;
    memcpy(out, measurement, sizeof(double) * (size_t)PGEM_POSE_SIZE(dimension));
    if (dimension != 3) {
        return;
    }
    norm = pgem_quat_normalize(&out[3]);
    if (!(norm > 0.0 && isfinite(norm))) {
        io_identity_pose(3, out);
        memcpy(out, measurement, sizeof(double) * 3);
    }
}

/* Finite, and its translation within the core's limit (which the load would refuse). */
static int io_pose_finite(const pgem_io_graph_t *graph, size_t node)
{
    int k;
    const double *pose = graph->poses[node].pose;
    for (k = 0; k < PGEM_POSE_SIZE(graph->dimension); ++k) {
        if (!isfinite(pose[k]) || (k < graph->dimension && fabs(pose[k]) > PGEM_TRANSLATION_LIMIT)) {
            return 0;
        }
    }
    return 1;
}

/* pose(to) = pose(from) * z, or pose(from) = pose(to) * z^-1 when walking an edge backwards.
 * The first edge whose composition is not finite or beyond the translation limit (long chains
 * of large measurements) is remembered: the graph cannot be read with such a guess. */
static void io_walk_edge(io_tree_t *tree, size_t edge, size_t node, size_t next)
{
    pgem_io_graph_t *graph = tree->graph;
    double z[PGEM_POSE_SIZE_MAX];
    const double *start = graph->poses[node].pose;
    double *out = graph->poses[next].pose;
    int backwards = tree->edge_from[edge] != node;
    io_unit_measurement(graph->dimension, graph->edges[edge].measurement, z);
    if (graph->dimension == 3) {
        if (backwards) {
            pgem_se3_inverse(z, z);
        }
        pgem_se3_compose(start, z, out);
    } else {
        if (backwards) {
            pgem_se2_inverse(z, z);
        }
        pgem_se2_compose(start, z, out);
    }
    if (!tree->overflowed && !io_pose_finite(graph, next)) {
        tree->overflowed = 1;
        tree->overflow_edge = edge;
        tree->overflow_node = next;
        tree->overflow_start = node;
    }
}

static void io_reach(io_tree_t *tree, size_t node)
{
    tree->reached[node] = 1;
    tree->order[tree->reached_count++] = node;
}

/* Follows edge from node if it leads somewhere new (and is odometry, when asked); 1 if so. */
static int io_try_edge(io_tree_t *tree, size_t edge, size_t node, int odometry_only)
{
    size_t next = tree->edge_from[edge] == node ? tree->edge_to[edge] : tree->edge_from[edge];
    if (tree->reached[next] ||
        (odometry_only && tree->graph->edges[edge].kind != PGEM_EDGE_ODOMETRY)) {
        return 0;
    }
    io_walk_edge(tree, edge, node, next);
    io_reach(tree, next);
    return 1;
}

/* Breadth-first over odometry edges from the nodes not yet expanded. */
static void io_expand_odometry(io_tree_t *tree, size_t *head)
{
    while (*head < tree->reached_count) {
        size_t node = tree->order[(*head)++];
        size_t slot;
        for (slot = tree->slot_start[node]; slot < tree->slot_start[node + 1]; ++slot) {
            io_try_edge(tree, tree->slot_edge[slot], node, 1);
        }
    }
}

/* The next edge of any kind from a reached node to an unreached one; 1 if one was taken.
 * *node_cursor / *slot_cursor remember where the scan stopped. */
static int io_take_any_edge(io_tree_t *tree, size_t *node_cursor, size_t *slot_cursor)
{
    while (*node_cursor < tree->reached_count) {
        size_t node = tree->order[*node_cursor];
        size_t end = tree->slot_start[node + 1];
        if (*slot_cursor < tree->slot_start[node]) {
            *slot_cursor = tree->slot_start[node];
        }
        for (; *slot_cursor < end; ++*slot_cursor) {
            if (io_try_edge(tree, tree->slot_edge[*slot_cursor], node, 0)) {
                return 1;
            }
        }
        ++*node_cursor;
        *slot_cursor = 0;
    }
    return 0;
}

/* From the smallest id: odometry first, one other edge when odometry reaches nothing more. */
static void io_spanning_tree(io_tree_t *tree)
{
    size_t head = 0;
    size_t node_cursor = 0;
    size_t slot_cursor = 0;
    io_reach(tree, 0);
    do {
        io_expand_odometry(tree, &head);
    } while (io_take_any_edge(tree, &node_cursor, &slot_cursor));
}

int io_chain_poses(io_reader_t *reader)
{
    io_tree_t tree;
    pgem_id_t *ids = NULL;
    int status;
    memset(&tree, 0, sizeof tree);
    tree.graph = reader->graph;
    tree.node_count = io_edge_ids(reader->graph, &ids);
    status = ids != NULL ? io_create_poses(reader->graph, ids, tree.node_count)
                         : PGEM_ERR_OUT_OF_MEMORY;
    if (status == PGEM_OK) {
        status = io_tree_allocate(&tree, reader->graph->edge_count);
    }
    if (status == PGEM_OK) {
        io_tree_link(&tree, ids);
        io_spanning_tree(&tree);
    }
    io_tree_free(&tree);
    free(ids);
    if (status != PGEM_OK) {
        return io_fail(reader, 0, status, "out of memory");
    }
    if (tree.overflowed) {
        const pgem_io_graph_t *graph = reader->graph;
        const pgem_io_edge_t *edge = &graph->edges[tree.overflow_edge];
        return io_fail(reader, edge->line, PGEM_ERR_OUT_OF_RANGE,
                       "edge %llu -> %llu: the pose guessed for id %llu by composing the "
                       "measurements from id %llu is beyond the translation limit (at most "
                       "1e8 m, PGEM_TRANSLATION_LIMIT; no VERTEX lines, measurements too large)",
                       (unsigned long long)edge->from, (unsigned long long)edge->to,
                       (unsigned long long)graph->poses[tree.overflow_node].id,
                       (unsigned long long)graph->poses[tree.overflow_start].id);
    }
    return PGEM_OK;
}
