/* Symbolic analysis, once per topology change: ordering, block elimination tree and column
 * counts (CSparse), then the scalar patterns of H and L and each edge's place in H. */
#include "internal.h"

void pgem_linear_invalidate(pgem_t *graph)
{
    graph->linear.valid = 0;
}

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

static void pgem_analyze_edges(pgem_t *graph)
{
    pgem_linear_t *linear = &graph->linear;
    for (uint32_t k = 0; k < graph->edge_count; k++) {
        int a, b;
        if (!pgem_edge_blocks(graph, k, &a, &b)) {
            linear->edge_offset[k] = -1;
            continue;
        }
        int row = a < b ? a : b;
        int column = a < b ? b : a;
        linear->edge_offset[k] = pgem_block_position(linear, row, column) * linear->block;
        linear->edge_transposed[k] = (uint8_t)(a > b);
    }
}

/* Column pointers of H's scalar upper triangle: column J*b+c holds every off-diagonal block
 * row of block column J (b rows each), then rows J*b .. J*b+c of the diagonal block. The rows
 * themselves are never stored: assembly and factorisation address values by block. */
static void pgem_analyze_upper(pgem_linear_t *linear)
{
    const int b = linear->block;
    int count = 0;
    for (int column = 0; column < linear->block_count; column++) {
        const int off_diagonal = (linear->block_colptr[column + 1] - linear->block_colptr[column]) * b;
        for (int c = 0; c < b; c++) {
            linear->upper_colptr[column * b + c] = count;
            count += off_diagonal + c + 1;
        }
    }
    linear->upper_colptr[linear->scalar_count] = count;
}

static int pgem_clamp_int(int64_t value)
{
    return value > INT32_MAX ? INT32_MAX : (int)value;
}

/* Block elimination tree and block column counts of L with CSparse; expands the counts to
 * scalar column pointers. Returns nonzeros of L or a negative error. */
static int64_t pgem_analyze_factor(pgem_linear_t *linear)
{
    const int b = linear->block;
    const int blocks = linear->block_count;
    cs_di pattern = {linear->block_colptr[blocks], blocks, blocks, linear->block_colptr,
                     linear->block_rows, NULL, -1};
    pgem_cs_open(&linear->cs_pool);
    int *parent = cs_di_etree(&pattern, 0);
    int *post = parent != NULL ? cs_di_post(parent, blocks) : NULL;
    int *counts = post != NULL ? cs_di_counts(&pattern, parent, post, 0) : NULL;
    int64_t nonzeros = counts != NULL ? 0 : PGEM_ERR_OUT_OF_MEMORY;
    /* off-diagonal blocks of L: at most fill_budget / b^2 when nonzeros fits the budget (the
     * caller refuses it otherwise, so clamped values are never used) */
    int64_t off_diagonal = 0;
    for (int column = 0; counts != NULL && column < blocks; column++) {
        linear->block_parent[column] = parent[column];
        linear->factor_block_colptr[column] = pgem_clamp_int(off_diagonal);
        off_diagonal += counts[column] - 1;
        for (int c = 0; c < b; c++) {
            linear->factor_colptr[column * b + c] = pgem_clamp_int(nonzeros);
            nonzeros += (int64_t)(counts[column] - 1) * b + (b - c);
        }
    }
    if (counts != NULL) {
        linear->factor_block_colptr[blocks] = pgem_clamp_int(off_diagonal);
    }
    cs_di_free(parent);
    cs_di_free(post);
    cs_di_free(counts);
    pgem_cs_close(&linear->cs_pool);
    return nonzeros;
}

/* CSparse's symbolic routines could not get workspace: the message names the step and the
 * memory that was short (the C heap with the system CSparse, else the block's pool). */
static int pgem_fail_workspace(pgem_t *graph, const char *step)
{
    const size_t pool = graph->linear.cs_pool.size;
    pgem_message_clear(graph);
    pgem_message_text(graph, "out of memory in the symbolic analysis (");
    pgem_message_text(graph, step);
    if (pool == 0) {
        pgem_message_text(graph, "): CSparse's workspace from the C heap: malloc returned NULL");
    } else {
        pgem_message_text(graph, "): CSparse's pool in the memory block (");
        pgem_message_u64(graph, pool);
        pgem_message_text(graph, " bytes) could not hold its workspace");
    }
    return PGEM_ERR_OUT_OF_MEMORY;
}

static int pgem_fill_exceeded(pgem_t *graph, int64_t nonzeros)
{
    pgem_message_clear(graph);
    pgem_message_text(graph, "the Cholesky factor needs ");
    pgem_message_i64(graph, nonzeros);
    pgem_message_text(graph, " nonzeros but config.fill_budget is ");
    pgem_message_u64(graph, graph->config.fill_budget);
    return PGEM_ERR_FILL_BUDGET;
}

/* Root of a pose in the union-find forest `parent`, halving the path on the way. */
static int pgem_part_root(int *parent, int pose)
{
    while (parent[pose] != pose) {
        parent[pose] = parent[parent[pose]];
        pose = parent[pose];
    }
    return pose;
}

/* Every part of the graph (poses joined by edges in the problem: active or dormant, not
 * pruned) must hold a held pose, or its poses can move together at no cost. Gauss-Newton
 * would meet a zero pivot, but Levenberg-Marquardt's damping hides it and solves a part that
 * floats anywhere; so the rule is checked on the graph before every solve (pruning may split
 * a graph without a new analysis: pruned loops keep their place in H for a while). O(poses +
 * edges), against the assembly's O(edges) dense blocks. The factorisation's scratch
 * (reach_stack, fill_next: max_poses ints each, free between factorisations) holds the
 * union-find forest and the held marks. */
int pgem_linear_check_parts(pgem_t *graph)
{
    int *parent = graph->linear.reach_stack;
    int *held = graph->linear.fill_next;
    for (uint32_t p = 0; p < graph->pose_count; p++) {
        parent[p] = (int)p;
        held[p] = 0;
    }
    for (uint32_t k = 0; k < graph->edge_count; k++) {
        if (graph->edge_active[k] != PGEM_EDGE_PRUNED) {
            int a = pgem_part_root(parent, (int)graph->edge_from[k]);
            int b = pgem_part_root(parent, (int)graph->edge_to[k]);
            parent[a < b ? b : a] = a < b ? a : b;
        }
    }
    for (uint32_t p = 0; p < graph->pose_count; p++) {
        if (graph->linear.pose_block[p] < 0) {
            held[pgem_part_root(parent, (int)p)] = 1;
        }
    }
    for (uint32_t p = 0; p < graph->pose_count; p++) {
        if (!held[pgem_part_root(parent, (int)p)]) {
            pgem_message_clear(graph);
            pgem_message_text(graph, "pose ");
            pgem_message_u64(graph, graph->pose_id[p]);
            pgem_message_text(graph, " is in a part of the graph with no held pose (a fixed "
                                     "pose, or the first pose added when none is fixed): no "
                                     "edge, or only pruned loop closures, join it to one");
            return PGEM_ERR_NOT_POSITIVE_DEFINITE;
        }
    }
    return PGEM_OK;
}

static int pgem_linear_analyze_once(pgem_t *graph)
{
    pgem_linear_t *linear = &graph->linear;
    linear->valid = 0;
    linear->factor_nonzeros = 0;
    int blocks = pgem_pattern_number_free(graph);
    if (blocks == 0) {
        return pgem_fail(graph, PGEM_ERR_EMPTY, "every pose is fixed: nothing to optimize");
    }
    if (pgem_pattern_order(graph, blocks) != PGEM_OK) {
        return pgem_fail_workspace(graph, "AMD ordering");
    }
    linear->block_count = blocks;
    linear->scalar_count = blocks * linear->block;
    pgem_pattern_build(graph, blocks, linear->block_colptr, linear->block_rows, linear->scratch);
    pgem_analyze_edges(graph);
    pgem_analyze_upper(linear);
    int64_t nonzeros = pgem_analyze_factor(linear);
    if (nonzeros < 0) {
        return pgem_fail_workspace(graph, "elimination tree and column counts");
    }
    linear->factor_nonzeros = nonzeros > INT32_MAX ? INT32_MAX : (int)nonzeros;
    if (nonzeros > (int64_t)graph->config.fill_budget) {
        return pgem_fill_exceeded(graph, nonzeros);
    }
    linear->factor_colptr[linear->scalar_count] = (int)nonzeros;
    linear->analyses++;
    linear->valid = 1;
    return PGEM_OK;
}

/* Pruned loops are left out of the structure, so a graph cleared of many long-range false
 * loops factors as sparsely as the clean one. AMD on a subgraph almost always needs less fill
 * than on the whole graph, but not provably; if it would exceed the budget, the structure is
 * built over every edge instead (the fill the caller sized for). */
int pgem_linear_analyze(pgem_t *graph)
{
    graph->linear.all_edges = 0;
    int status = pgem_linear_analyze_once(graph);
    if (status == PGEM_ERR_FILL_BUDGET) {
        uint32_t k = 0;
        while (k < graph->edge_count && graph->edge_active[k] == PGEM_EDGE_ACTIVE) {
            k++;
        }
        if (k < graph->edge_count) { /* some edge was left out: try the full structure */
            graph->linear.all_edges = 1;
            status = pgem_linear_analyze_once(graph);
        }
    }
    return status;
}
