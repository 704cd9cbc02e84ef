/* Symbolic analysis, once per topology change: ordering, postordered block elimination tree
 * and column counts (CSparse), the supernodes of L (linalg/factor/supernodes.c) and their schedule,
 * H's lower block pattern and each edge's place in it. */
#include "linalg/linear.h"

/* Position of block row `row` inside block column `column` (rows are sorted). */
static int pgem_block_position(const pgem_linear_t *linear, int row, int column)
{
    int low = linear->block_colptr[column];
    int high = linear->block_colptr[column + 1] - 1;
    while (low <= high) {
        int middle = low + (high - low) / 2;
        if (linear->block_rows[middle] < row) {
            low = middle + 1;
        } else if (linear->block_rows[middle] > row) {
            high = middle - 1;
        } else {
            return middle - linear->block_colptr[column];
        }
    }
    return -1; /* unreachable: every edge block is in the pattern */
}

/* Each edge's place in H's lower block pattern: the block (larger, smaller) of column
 * min(a, b); stored as H_{to,from} (transposed) when from < to. */
static void pgem_analyze_edges(pgem_linear_t *linear, const pgem_store_t *store)
{
    for (uint32_t k = 0; k < store->edge_count; k++) {
        int a, b;
        if (!pgem_edge_blocks(linear, store, k, &a, &b)) {
            linear->edge_offset[k] = -1;
            continue;
        }
        int row = a < b ? b : a;
        int column = a < b ? a : b;
        linear->edge_offset[k] = pgem_block_position(linear, row, column) * linear->block;
        linear->edge_transposed[k] = (uint8_t)(a < b);
    }
}

/* Where each block column of H's lower triangle starts: its b scalar columns hold their
 * diagonal block's rows c .. b-1 and then b rows per off-diagonal block (pgem_lower_column).
 * The rows themselves are never stored: assembly and factorisation address values by block. */
static void pgem_analyze_lower(pgem_linear_t *linear)
{
    const int b = linear->block;
    int count = 0;
    for (int column = 0; column < linear->block_count; column++) {
        const int off_diagonal = linear->block_colptr[column + 1] - linear->block_colptr[column];
        linear->lower_start[column] = count;
        count += b * (b + 1) / 2 + off_diagonal * b * b;
    }
    linear->lower_start[linear->block_count] = count;
}

/* Renumbers the free poses by a postorder of the elimination tree of the ordering's upper
 * block pattern (colptr, rows): the same fill, and every subtree becomes a range of
 * consecutive block columns, which supernodes need. block_parent receives the renumbered
 * tree. work holds block_count ints. */
static int pgem_analyze_postorder(pgem_linear_t *linear, const pgem_store_t *store,
                                  const cs_di *pattern, int *work)
{
    const int blocks = linear->block_count;
    int *parent = cs_di_etree(pattern, 0);
    int *post = parent != NULL ? cs_di_post(parent, blocks) : NULL;
    if (post != NULL) {
        int *renumbered = work; /* old block column -> its place in the postorder */
        for (int k = 0; k < blocks; k++) {
            renumbered[post[k]] = k;
        }
        for (int j = 0; j < blocks; j++) {
            linear->block_parent[renumbered[j]] = parent[j] >= 0 ? renumbered[parent[j]] : -1;
        }
        for (uint32_t p = 0; p < store->pose_count; p++) {
            const int block = linear->pose_block[p];
            linear->pose_block[p] = block >= 0 ? renumbered[block] : -1;
        }
    }
    cs_di_free(post);
    cs_di_free(parent);
    return post != NULL ? PGEM_OK : PGEM_ERR_OUT_OF_MEMORY;
}

/* Postordering, block column counts of L with CSparse, H's lower block pattern and the
 * supernodal layout. Returns the nonzeros of L or a negative error. */
static int64_t pgem_analyze_factor(pgem_linear_t *linear, const pgem_store_t *store,
                                   uint32_t fill_budget)
{
    const int blocks = linear->block_count;
    int *colptr = pgem_linear_scratch(linear);
    int *rows = colptr + blocks + 1;
    int *work = rows + store->edge_count;
    pgem_pattern_build(linear, store, blocks, colptr, rows, work);
    cs_di pattern = {colptr[blocks], blocks, blocks, colptr, rows, NULL, -1};
    pgem_cs_open(&linear->cs_pool);
    if (pgem_analyze_postorder(linear, store, &pattern, work) != PGEM_OK) {
        pgem_cs_close(&linear->cs_pool);
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    pgem_pattern_build(linear, store, blocks, colptr, rows, work);
    pattern.p = colptr;
    pattern.i = rows;
    pattern.nzmax = colptr[blocks];
    for (int k = 0; k < blocks; k++) {
        work[k] = k; /* the tree is postordered now */
    }
    int *counts = cs_di_counts(&pattern, linear->block_parent, work, 0);
    int64_t nonzeros = PGEM_ERR_OUT_OF_MEMORY;
    if (counts != NULL) {
        pgem_pattern_transpose(blocks, colptr, rows, linear->block_colptr, linear->block_rows);
        nonzeros = pgem_supernodes_analyze(linear, counts, fill_budget);
    }
    cs_di_free(counts);
    pgem_cs_close(&linear->cs_pool);
    return nonzeros;
}

/* CSparse's symbolic routines could not get workspace: the message names the step and the
 * memory that was short (the C heap with the system CSparse, else the block's pool). */
static int pgem_fail_workspace(const pgem_linear_t *linear, char *message, const char *step)
{
    const size_t pool = linear->cs_pool.size;
    message[0] = '\0';
    pgem_text_append(message, PGEM_MESSAGE_SIZE, "out of memory in the symbolic analysis (");
    pgem_text_append(message, PGEM_MESSAGE_SIZE, step);
    if (pool == 0) {
        pgem_text_append(message, PGEM_MESSAGE_SIZE,
                         "): CSparse's workspace from the C heap: malloc returned NULL");
    } else {
        pgem_text_append(message, PGEM_MESSAGE_SIZE, "): CSparse's pool in the memory block (");
        pgem_text_u64(message, PGEM_MESSAGE_SIZE, pool);
        pgem_text_append(message, PGEM_MESSAGE_SIZE, " bytes) could not hold its workspace");
    }
    return PGEM_ERR_OUT_OF_MEMORY;
}

static int pgem_fill_exceeded(char *message, int64_t nonzeros, uint32_t fill_budget)
{
    message[0] = '\0';
    pgem_text_append(message, PGEM_MESSAGE_SIZE, "the Cholesky factor needs ");
    pgem_text_i64(message, PGEM_MESSAGE_SIZE, nonzeros);
    pgem_text_append(message, PGEM_MESSAGE_SIZE, " nonzeros but config.fill_budget is ");
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, fill_budget);
    return PGEM_ERR_FILL_BUDGET;
}

/* Every part of the graph (poses joined by edges in the problem: active or dormant, not
 * pruned) must hold a held pose (fixed, or holding the gauge: pgem_hold_gauge), or its poses can move together at no cost. Gauss-Newton
 * would meet a zero pivot, but Levenberg-Marquardt's damping hides it and solves a part that
 * floats anywhere; so the rule is checked on the graph before every solve (pruning may split
 * a graph without a new analysis: pruned loops keep their place in H for a while). O(poses +
 * edges), against the assembly's O(edges) dense blocks. The factorisation's lists
 * (factor.head, factor.next: max_poses ints each, free between factorisations) hold the
 * union-find forest and the held marks. */
int pgem_linear_check_parts(pgem_linear_t *linear, const pgem_store_t *store, char *message)
{
    uint32_t *parent = (uint32_t *)(void *)linear->factor.head;
    int *held = linear->factor.next;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        parent[p] = p;
        held[p] = 0;
    }
    for (uint32_t k = 0; k < store->edge_count; k++) {
        if (store->edge_active[k] != PGEM_EDGE_PRUNED) {
            (void)pgem_part_join(parent, store->edge_from[k], store->edge_to[k]);
        }
    }
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (linear->pose_block[p] < 0 || PGEM_POSE_DAMPED(store->pose_fixed[p])) {
            held[pgem_part_root(parent, p)] = 1;
        }
    }
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (!held[pgem_part_root(parent, p)]) {
            message[0] = '\0';
            pgem_text_append(message, PGEM_MESSAGE_SIZE, "pose ");
            pgem_text_u64(message, PGEM_MESSAGE_SIZE, store->pose_id[p]);
            pgem_text_append(message, PGEM_MESSAGE_SIZE,
                             " is in a part of the graph with no held pose (a fixed pose, or the "
                             "first pose added when none is fixed): no edge, or only pruned "
                             "loop closures, join it to one");
            return PGEM_ERR_NOT_POSITIVE_DEFINITE;
        }
    }
    return PGEM_OK;
}

/* The parts of the graph (every edge, or those in the problem: not pruned, and not a loop at
 * weight 0, as a run the leave-run-out test leaves out for one factorisation) that no held
 * pose holds: counted, and each held at its pose with the smallest id (pgem_pose_hold_part)
 * unless flag is 0.
 * Needs no analysis: a pose is held if fixed (or the first while none is) or damped. The
 * lists of pgem_linear_check_parts hold the forest and, per part, -2 once held, else its pose
 * with the smallest id so far (-1: none yet). */
uint32_t pgem_linear_unheld_parts(pgem_linear_t *linear, pgem_store_t *store, int every_edge,
                                  uint8_t flag)
{
    uint32_t *parent = (uint32_t *)(void *)linear->factor.head;
    int *lowest = linear->factor.next;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        parent[p] = p;
        lowest[p] = -1;
    }
    for (uint32_t k = 0; k < store->edge_count; k++) {
        const int out = store->edge_active[k] == PGEM_EDGE_PRUNED ||
                        (store->edge_kind[k] == PGEM_EDGE_LOOP && store->edge_weight[k] == 0.0);
        if (every_edge || !out) {
            (void)pgem_part_join(parent, store->edge_from[k], store->edge_to[k]);
        }
    }
    for (uint32_t p = 0; p < store->pose_count; p++) {
        int *part = &lowest[pgem_part_root(parent, p)];
        if (PGEM_POSE_HELD(store, p) || PGEM_POSE_DAMPED(store->pose_fixed[p])) {
            *part = -2;
        } else if (*part == -1 || (*part >= 0 && store->pose_id[p] < store->pose_id[*part])) {
            *part = (int)p;
        }
    }
    uint32_t unheld = 0;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        if (parent[p] != p || lowest[p] < 0) {
            continue;
        }
        unheld++;
        if (flag != 0u) {
            pgem_pose_hold_part(store, (uint32_t)lowest[p], flag);
        }
    }
    return unheld;
}

static int pgem_linear_analyze_once(pgem_linear_t *linear, const pgem_store_t *store,
                                    const pgem_config_t *config, char *message)
{
    linear->valid = 0;
    linear->factor.nonzeros = 0;
    int blocks = 0;
    if (linear->ordered) { /* pgem_copy handed over this graph's ordering */
        for (uint32_t p = 0; p < store->pose_count; p++) {
            blocks += linear->pose_block[p] >= 0;
        }
    } else {
        blocks = pgem_pattern_number_free(linear, store);
        if (blocks == 0) {
            message[0] = '\0';
            pgem_text_append(message, PGEM_MESSAGE_SIZE,
                             "every pose is fixed: nothing to optimize");
            return PGEM_ERR_EMPTY;
        }
        if (pgem_pattern_order(linear, store, config, blocks) != PGEM_OK) {
            return pgem_fail_workspace(linear, message, "AMD ordering");
        }
    }
    linear->block_count = blocks;
    linear->scalar_count = blocks * linear->block;
    int64_t nonzeros = pgem_analyze_factor(linear, store, config->fill_budget);
    if (nonzeros < 0) {
        return pgem_fail_workspace(linear, message, "elimination tree and column counts");
    }
    linear->ordered = 1; /* pose_block holds the (postordered) ordering, whatever follows */
    if (nonzeros > (int64_t)config->fill_budget) {
        return pgem_fill_exceeded(message, nonzeros, config->fill_budget);
    }
    pgem_analyze_edges(linear, store);
    pgem_analyze_lower(linear);
    pgem_schedule_analyze(linear);
    linear->analyses++;
    linear->valid = 1;
    return PGEM_OK;
}

/* Pruned loops are left out of the structure, so a graph cleared of many long-range false
 * loops factors as sparsely as the clean one. AMD on a subgraph almost always needs less fill
 * than on the whole graph, but not provably; if it would exceed the budget, the structure is
 * built over every edge instead (the fill the caller sized for). */
int pgem_linear_analyze(pgem_linear_t *linear, const pgem_store_t *store,
                        const pgem_config_t *config, char *message)
{
    pgem_linear_follow(linear, store);
    linear->covariance = PGEM_COVARIANCE_NONE;
    linear->all_edges = 0; /* a handed-over ordering (pgem_copy) is never the fallback's */
    int status = pgem_linear_analyze_once(linear, store, config, message);
    if (status == PGEM_ERR_FILL_BUDGET) {
        uint32_t k = 0;
        while (k < store->edge_count && store->edge_active[k] == PGEM_EDGE_ACTIVE) {
            k++;
        }
        if (k < store->edge_count) { /* some edge was left out: try the full structure */
            linear->all_edges = 1;
            linear->ordered = 0;
            status = pgem_linear_analyze_once(linear, store, config, message);
        }
    }
    return status;
}

/* The structure is kept while it is still the graph's (linalg/analysis/structure.c). */
int pgem_linear_prepare(pgem_linear_t *linear, const pgem_store_t *store,
                        const pgem_config_t *config, char *message)
{
    pgem_linear_follow(linear, store);
    return linear->valid ? PGEM_OK : pgem_linear_analyze(linear, store, config, message);
}

int pgem_linear_fill_needed(pgem_linear_t *linear, const pgem_store_t *store,
                            const pgem_config_t *config, char *message, uint32_t *nonzeros)
{
    pgem_linear_follow(linear, store);
    int status = PGEM_OK;
    if (!linear->valid || linear->all_edges) {
        linear->all_edges = 0;
        status = pgem_linear_analyze_once(linear, store, config, message);
    }
    if (status == PGEM_OK || status == PGEM_ERR_FILL_BUDGET) {
        *nonzeros = (uint32_t)linear->factor.nonzeros;
        message[0] = '\0';
        return PGEM_OK;
    }
    return status;
}
