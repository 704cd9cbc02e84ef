/* The fill-reducing ordering of the free poses, chosen per graph: CSparse's AMD on the block
 * graph, and for graphs of at least PGEM_ND_MIN_BLOCKS free poses also nested dissection
 * (linalg/nested.c); the one whose factor needs fewer flops (from the elimination tree and
 * column counts of each) is kept, as CHOLMOD chooses among its orderings. Bare-metal builds
 * (PGEM_NO_NESTED) order by AMD alone: a microcontroller's RAM holds far fewer poses than
 * nested dissection needs to pay, and it saves 6.6 KiB of flash. CSparse allocates
 * here: from the heap with the system CSparse, from the block's pool with the source-built
 * one; nested dissection works in the part of the block H's values use later. */
#include "linalg/linear.h"

/* Nested dissection is tried only where it can pay for itself: graphs of at least this many
 * free poses whose AMD factor needs at least PGEM_ND_MIN_FLOPS_PER_BLOCK flops per pose and
 * PGEM_ND_MIN_FLOPS in all. Below, fronts are small, AMD's flops are within some 10 % of
 * nested dissection's and the dissection (15-25 us per pose) costs more than it saves over a
 * solve's ten or so factorisations (measured, DESIGN.md: City10000, 8.5e3 flops per pose, 0.27 s
 * of dissection to save 1 ms per factorisation; Sphere2500, 1.6e5 per pose and 4e8 in all,
 * where AMD also orders better). */
#define PGEM_ND_MIN_BLOCKS 2000
#define PGEM_ND_MIN_FLOPS_PER_BLOCK 2e5
#define PGEM_ND_MIN_FLOPS 1e9

/* Sets pose_block from the free numbering and position[free index]. */
static void pgem_order_apply(pgem_t *graph, const int *position)
{
    (void)pgem_pattern_number_free(graph);
    for (uint32_t p = 0; p < graph->store.pose_count; p++) {
        const int free_index = graph->linear->pose_block[p];
        graph->linear->pose_block[p] = free_index >= 0 ? position[free_index] : -1;
    }
}

/* Sum over the factor's scalar columns of their squared counts under the numbering of
 * position, or -1 if CSparse could not get workspace. */
static double pgem_order_flops(pgem_t *graph, int blocks, const int *position)
{
    pgem_linear_t *linear = graph->linear;
    const int b = linear->block;
    int *colptr = pgem_linear_scratch(linear);
    int *rows = colptr + blocks + 1;
    int *work = rows + graph->store.edge_count;
    pgem_order_apply(graph, position);
    pgem_pattern_build(graph, blocks, colptr, rows, work);
    cs_di pattern = {colptr[blocks], blocks, blocks, colptr, rows, NULL, -1};
    pgem_cs_open(&linear->cs_pool);
    int *parent = cs_di_etree(&pattern, 0);
    int *post = parent != NULL ? cs_di_post(parent, blocks) : NULL;
    int *counts = post != NULL ? cs_di_counts(&pattern, parent, post, 0) : NULL;
    double flops = counts != NULL ? 0.0 : -1.0;
    for (int j = 0; counts != NULL && j < blocks; j++) {
        for (int c = 0; c < b; c++) {
            const double column = (double)(counts[j] - 1) * b + (b - c);
            flops += column * column;
        }
    }
    cs_di_free(counts);
    cs_di_free(post);
    cs_di_free(parent);
    pgem_cs_close(&linear->cs_pool);
    return flops;
}

/* AMD's position of every free index, into position. */
static int pgem_order_amd(pgem_t *graph, int blocks, int *position)
{
    pgem_linear_t *linear = graph->linear;
    int *colptr = pgem_linear_scratch(linear);
    int *rows = colptr + blocks + 1;
    int *work = rows + graph->store.edge_count;
    cs_di pattern = {colptr[blocks], blocks, blocks, colptr, rows, NULL, -1};
    pgem_cs_open(&linear->cs_pool);
    int *order = cs_di_amd(1, &pattern);
    if (order == NULL) {
        pgem_cs_close(&linear->cs_pool);
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    (void)work;
    for (int k = 0; k < blocks; k++) {
        position[order[k]] = k;
    }
    cs_di_free(order);
    pgem_cs_close(&linear->cs_pool);
    return PGEM_OK;
}

/* Nested dissection's position of every free index, into position; order is workspace. */
static int pgem_order_nested(pgem_t *graph, int blocks, int *position, int *order)
{
    pgem_linear_t *linear = graph->linear;
    const int *colptr = pgem_linear_scratch(linear);
    const int *rows = colptr + blocks + 1;
    const size_t b = (size_t)linear->block;
    const size_t doubles = (size_t)graph->config.max_edges * b * b +
                           (size_t)graph->config.max_poses * b * (b + 1u) / 2u;
#ifdef PGEM_NO_NESTED
    (void)colptr;
    (void)rows;
    (void)doubles;
    (void)order;
    const int status = PGEM_ERR_OUT_OF_MEMORY; /* compiled out: AMD only */
#else
    const int status = pgem_nested_order(linear, blocks, colptr, rows, order,
                                         (int *)(void *)linear->lower_values, 2u * doubles);
#endif
    for (int k = 0; status == PGEM_OK && k < blocks; k++) {
        position[order[k]] = k;
    }
    return status;
}

int pgem_pattern_order(pgem_t *graph, int block_count)
{
    pgem_linear_t *linear = graph->linear;
    int *colptr = pgem_linear_scratch(linear);
    int *rows = colptr + block_count + 1;
    int *work = rows + graph->store.edge_count;
    int *amd = linear->factor.order;       /* free until the schedule is built */
    int *nested = linear->factor.task_worker;
    pgem_pattern_build(graph, block_count, colptr, rows, work);
    int status = pgem_order_amd(graph, block_count, amd);
    linear->factor.ordering = PGEM_ORDERING_AMD;
    linear->factor.amd_flops = -1.0;
    linear->factor.nested_flops = -1.0;
    if (status != PGEM_OK || block_count < PGEM_ND_MIN_BLOCKS) {
        if (status == PGEM_OK) {
            pgem_order_apply(graph, amd);
        }
        return status;
    }
    const double amd_flops = pgem_order_flops(graph, block_count, amd);
    if (amd_flops < 0.0) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    linear->factor.amd_flops = amd_flops;
    if (amd_flops < PGEM_ND_MIN_FLOPS_PER_BLOCK * block_count || amd_flops < PGEM_ND_MIN_FLOPS) {
        pgem_order_apply(graph, amd);
        return PGEM_OK;
    }
    /* nested dissection: a failure there (no room) keeps AMD; it needs the free numbering's
     * pattern again (the evaluation above renumbered it) */
    (void)pgem_pattern_number_free(graph);
    pgem_pattern_build(graph, block_count, colptr, rows, work);
    const int nested_ok = pgem_order_nested(graph, block_count, nested, linear->factor.head) == PGEM_OK;
    const double nested_flops = nested_ok ? pgem_order_flops(graph, block_count, nested) : -1.0;
    if (nested_ok && nested_flops < 0.0) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    const int use_nested = nested_ok && nested_flops < amd_flops;
    linear->factor.ordering = use_nested ? PGEM_ORDERING_NESTED : PGEM_ORDERING_AMD;
    linear->factor.nested_flops = nested_flops;
    pgem_order_apply(graph, use_nested ? nested : amd);
    return PGEM_OK;
}
