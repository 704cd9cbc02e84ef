/* The fill-reducing ordering of the free poses, chosen per graph: CSparse's AMD on the block
 * graph, and for graphs of at least PGEM_ND_MIN_BLOCKS free poses also nested dissection
 * (linalg/analysis/nested.c) and the orderer a hosted program set (pgem_set_ordering: METIS,
 * lib/metis);
 * the one whose factor needs the fewest flops (from the elimination tree and column counts of
 * each) is kept, as CHOLMOD chooses among its orderings. Bare-metal builds
 * (PGEM_NO_NESTED) order by AMD alone: a microcontroller's RAM holds far fewer poses than
 * nested dissection needs to pay, and it saves 6.6 KiB of flash. CSparse allocates
 * here: from the heap with the system CSparse, from the block's pool with the source-built
 * one; nested dissection works in the part of the block H's values use later. */
#include "linalg/analysis/nested.h"

/* Nested dissection is tried only where it can pay for itself: graphs of at least this many
 * free poses whose AMD factor needs at least PGEM_ND_MIN_FLOPS_PER_BLOCK flops per pose and
 * PGEM_ND_MIN_FLOPS in all. Below, fronts are small, AMD's flops are within some 10 % of
 * nested dissection's and the dissection (15-25 us per pose) costs more than it saves over a
 * solve's ten or so factorisations (measured, docs/design/ordering.md: City10000, 8.5e3 flops
 * per pose, 0.27 s of dissection to save 1 ms per factorisation; Sphere2500, 1.6e5 per pose
 * and 4e8 in all, where AMD also orders better). */
#define PGEM_ND_MIN_BLOCKS 2000
#define PGEM_ND_MIN_FLOPS_PER_BLOCK 2e5
#define PGEM_ND_MIN_FLOPS 1e9

/* Sets pose_block from the free numbering and position[free index]. */
static void pgem_order_apply(pgem_linear_t *linear, const pgem_store_t *store, const int *position)
{
    (void)pgem_pattern_number_free(linear, store);
    for (uint32_t p = 0; p < store->pose_count; p++) {
        const int free_index = linear->pose_block[p];
        linear->pose_block[p] = free_index >= 0 ? position[free_index] : -1;
    }
}

/* Sum over the factor's scalar columns of their squared counts under the numbering of
 * position, or -1 if CSparse could not get workspace. */
static double pgem_order_flops(pgem_linear_t *linear, const pgem_store_t *store, int blocks,
                               const int *position)
{
    const int b = linear->block;
    int *colptr = pgem_linear_scratch(linear);
    int *rows = colptr + blocks + 1;
    int *work = rows + store->edge_count;
    pgem_order_apply(linear, store, position);
    pgem_pattern_build(linear, store, blocks, colptr, rows, work);
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
static int pgem_order_amd(pgem_linear_t *linear, const pgem_store_t *store, int blocks,
                          int *position)
{
    int *colptr = pgem_linear_scratch(linear);
    int *rows = colptr + blocks + 1;
    int *work = rows + store->edge_count;
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
static int pgem_order_nested(pgem_linear_t *linear, const pgem_config_t *config, int blocks,
                             int *position, int *order)
{
    const int *colptr = pgem_linear_scratch(linear);
    const int *rows = colptr + blocks + 1;
    const size_t b = (size_t)linear->block;
    const size_t doubles = (size_t)config->max_edges * b * b +
                           (size_t)config->max_poses * b * (b + 1u) / 2u;
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

/* The instance's orderer's position of every free index, into position (order is workspace),
 * after checking that it gave a permutation. */
static int pgem_order_orderer(const pgem_linear_t *linear, int blocks, int *position, int *order)
{
    const int *colptr = pgem_linear_scratch(linear);
    const int *rows = colptr + blocks + 1;
    const pgem_orderer_t *orderer = &linear->orderer;
    if (orderer->order(orderer->orderer, blocks, colptr, rows, order) != 0) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    for (int k = 0; k < blocks; k++) {
        position[k] = -1;
    }
    for (int k = 0; k < blocks; k++) {
        if (order[k] < 0 || order[k] >= blocks || position[order[k]] >= 0) {
            return PGEM_ERR_INVALID_ARGUMENT; /* not a permutation: ignored */
        }
        position[order[k]] = k;
    }
    return PGEM_OK;
}

/* Tries ordering `kind` (nested dissection or the orderer) into candidate and keeps it in best
 * when the choice names it, or under AUTO when it needs fewer flops than *best_flops. */
static int pgem_order_try(pgem_linear_t *linear, const pgem_store_t *store,
                          const pgem_config_t *config, int block_count, pgem_ordering_t kind,
                          int *best, double *best_flops)
{
    int *colptr = pgem_linear_scratch(linear);
    int *candidate = linear->factor.task_worker;
    /* the free numbering's pattern again (an evaluation renumbers it) */
    (void)pgem_pattern_number_free(linear, store);
    pgem_pattern_build(linear, store, block_count, colptr, colptr + block_count + 1,
                       colptr + block_count + 1 + store->edge_count);
    const int ok = (kind == PGEM_ORDERING_NESTED
                        ? pgem_order_nested(linear, config, block_count, candidate,
                                            linear->factor.head)
                        : pgem_order_orderer(linear, block_count, candidate,
                                             linear->factor.head)) == PGEM_OK;
    const double flops = ok ? pgem_order_flops(linear, store, block_count, candidate) : -1.0;
    if (ok && flops < 0.0) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    *(kind == PGEM_ORDERING_NESTED ? &linear->factor.nested_flops
                                   : &linear->factor.orderer_flops) = flops;
    if (ok && (linear->ordering_choice != PGEM_ORDER_AUTO || flops < *best_flops)) {
        for (int k = 0; k < block_count; k++) {
            best[k] = candidate[k];
        }
        *best_flops = flops;
        linear->factor.ordering = kind;
    }
    return PGEM_OK;
}

/* AMD always (the fallback); under AUTO on large graphs also the orderer and, unless the
 * orderer beat AMD, nested dissection, by flops; or the one the instance's choice names. */
int pgem_pattern_order(pgem_linear_t *linear, const pgem_store_t *store,
                       const pgem_config_t *config, int block_count)
{
    int *colptr = pgem_linear_scratch(linear);
    int *rows = colptr + block_count + 1;
    int *work = rows + store->edge_count;
    int *best = linear->factor.order; /* free until the schedule is built */
    const pgem_order_choice_t choice = linear->ordering_choice;
    pgem_pattern_build(linear, store, block_count, colptr, rows, work);
    int status = pgem_order_amd(linear, store, block_count, best);
    linear->factor.ordering = PGEM_ORDERING_AMD;
    linear->factor.amd_flops = -1.0;
    linear->factor.nested_flops = -1.0;
    linear->factor.orderer_flops = -1.0;
    if (status != PGEM_OK || choice == PGEM_ORDER_AMD ||
        (choice == PGEM_ORDER_AUTO && block_count < PGEM_ND_MIN_BLOCKS)) {
        if (status == PGEM_OK) {
            pgem_order_apply(linear, store, best);
        }
        return status;
    }
    double best_flops = pgem_order_flops(linear, store, block_count, best);
    if (best_flops < 0.0) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    linear->factor.amd_flops = best_flops;
    const int small = best_flops < PGEM_ND_MIN_FLOPS_PER_BLOCK * block_count ||
                      best_flops < PGEM_ND_MIN_FLOPS;
    if (choice == PGEM_ORDER_AUTO && small) {
        pgem_order_apply(linear, store, best);
        return PGEM_OK;
    }
    if (choice != PGEM_ORDER_NESTED && linear->orderer.order != NULL) {
        status = pgem_order_try(linear, store, config, block_count, PGEM_ORDERING_ORDERER, best,
                                &best_flops);
    }
    /* Our own dissection is not run beside an orderer that beat AMD: a multilevel dissection
     * such as METIS's orders better than ours on every large graph measured (grid3d 100000:
     * 266G flops against 355G) and ours took twice its time there (docs/design/ordering.md). */
    const int orderer_won = linear->factor.ordering == PGEM_ORDERING_ORDERER;
    if (status == PGEM_OK && choice != PGEM_ORDER_ORDERER &&
        !(choice == PGEM_ORDER_AUTO && orderer_won)) {
        status = pgem_order_try(linear, store, config, block_count, PGEM_ORDERING_NESTED, best,
                                &best_flops);
    }
    if (status == PGEM_OK) {
        pgem_order_apply(linear, store, best);
    }
    return status;
}

void pgem_linear_set_ordering(pgem_linear_t *linear, pgem_order_choice_t choice,
                              const pgem_orderer_t *orderer)
{
    linear->ordering_choice = choice;
    if (orderer != NULL) {
        linear->orderer = *orderer;
    } else {
        linear->orderer.order = NULL;
        linear->orderer.orderer = NULL;
    }
    pgem_linear_invalidate(linear); /* the next analysis orders anew */
}
