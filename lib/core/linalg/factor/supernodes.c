/* Supernodes of the factor, from the postordered block elimination tree and block column
 * counts: fundamental supernodes (chains sharing one structure), relaxed amalgamation of a
 * child into its parent when the explicit zeros stay few, the row structure of each supernode
 * and the factor's layout (value offsets, nonzeros, flops). No allocation: the workspace is
 * the analysis's scratch and arrays a factorisation uses only later. */
#include "linalg/linear.h"

/* Relaxed amalgamation (widths in scalar columns, zeros as a fraction of the merged
 * supernode's values): a merge is taken when the merged supernode is at most RELAX_MEDIUM
 * columns wide with fewer than ZEROS_MEDIUM explicit zeros, at most RELAX_WIDE with fewer than
 * ZEROS_WIDE, or of any width with fewer than ZEROS_ANY. Far more sparing than CHOLMOD's
 * defaults: the zeros cost fill budget, and one-block supernodes have fast kernels of their own
 * (linalg/factor/blocks.c). Measured on the shared datasets and the simulated graphs
 * (docs/benchmarks/2026-12-02-factorisation.md). */
#define PGEM_RELAX_MEDIUM 30
#define PGEM_RELAX_WIDE 100
#define PGEM_ZEROS_MEDIUM 0.10
#define PGEM_ZEROS_WIDE 0.05
#define PGEM_ZEROS_ANY 0.02

/* Values of a trapezoid of `height` rows and `width` columns (width <= height). */
static int64_t pgem_trapezoid(int64_t height, int64_t width)
{
    return width * height - width * (width - 1) / 2;
}

/* Fundamental supernodes: column j continues the supernode of j-1 when j is j-1's parent, its
 * only child, and has one block fewer. fsuper[j] receives the supernode of each column;
 * returns how many there are. */
static int pgem_fundamental(int blocks, const int *parent, const int *counts, int *children,
                            int *fsuper)
{
    for (int j = 0; j < blocks; j++) {
        children[j] = 0;
    }
    for (int j = 0; j < blocks; j++) {
        if (parent[j] >= 0) {
            children[parent[j]]++;
        }
    }
    int count = 0;
    for (int j = 0; j < blocks; j++) {
        const int joins = j > 0 && parent[j - 1] == j && children[j] == 1 &&
                          counts[j - 1] == counts[j] + 1;
        if (!joins) {
            count++;
        }
        fsuper[j] = count - 1;
    }
    return count;
}

/* 1 if a merged supernode of `columns` scalar columns and `values` values of which `zeros`
 * are explicit zeros is worth its zeros. */
static int pgem_relax_accepts(int64_t columns, double zeros, double values)
{
    const double fraction = values > 0.0 ? zeros / values : 0.0;
    return (columns <= PGEM_RELAX_MEDIUM && fraction < PGEM_ZEROS_MEDIUM) ||
           (columns <= PGEM_RELAX_WIDE && fraction < PGEM_ZEROS_WIDE) || fraction < PGEM_ZEROS_ANY;
}

/* Relaxed amalgamation over the fundamental supernodes (first[f], width[f] block columns,
 * height[f] block rows in its first column, zeros[f]): from the last to the first, a
 * supernode whose parent starts right after it (its last child in the postorder) is merged
 * into that parent when pgem_relax_accepts. merged[f] is the supernode f now belongs to
 * (itself if kept). */
static void pgem_amalgamate(const pgem_linear_t *linear, int fcount, const int *ffirst,
                            const int *fsuper, int *width, int *height, int *zeros,
                            int *merged)
{
    const int b = linear->block;
    const int *parent = linear->block_parent;
    for (int f = 0; f < fcount; f++) {
        merged[f] = f;
    }
    for (int f = fcount - 2; f >= 0; f--) {
        const int last = ffirst[f + 1] - 1;
        if (parent[last] != last + 1) {
            continue; /* the parent does not start right after f (or f is a root) */
        }
        int p = fsuper[last + 1];
        while (merged[p] != p) {
            p = merged[p];
        }
        /* f's columns each gain the rows of p's first column they lacked */
        const int64_t new_width = (int64_t)(width[f] + width[p]) * b;
        const int64_t new_height = (int64_t)(width[f] + height[p]) * b;
        const int64_t added = (int64_t)width[f] * b * (int64_t)(width[f] + height[p] - height[f]) * b;
        const int64_t total_zeros = (int64_t)zeros[f] + zeros[p] + added;
        const int64_t values = pgem_trapezoid(new_height, new_width);
        if (values < INT32_MAX && pgem_relax_accepts(new_width, (double)total_zeros, (double)values)) {
            merged[f] = p;
            width[p] += width[f];
            height[p] += width[f];
            zeros[p] = (int)total_zeros;
        }
    }
}

/* In-place heap sort of count ints. */
static void pgem_sort_ints(int *values, int count)
{
    for (int start = count / 2 - 1, end = count; end > 1;) {
        int root;
        if (start >= 0) {
            root = start--;
        } else {
            end--;
            int swap = values[0];
            values[0] = values[end];
            values[end] = swap;
            root = 0;
        }
        for (int child = 2 * root + 1; child < end; child = 2 * root + 1) {
            if (child + 1 < end && values[child + 1] > values[child]) {
                child++;
            }
            if (values[root] >= values[child]) {
                break;
            }
            int swap = values[root];
            values[root] = values[child];
            values[child] = swap;
            root = child;
        }
    }
}

/* Final supernodes from the amalgamated fundamental ones: first columns, the supernode of each
 * block column, the supernodal tree. */
static void pgem_supernodes_number(pgem_factor_t *factor, const pgem_linear_t *linear,
                                   int fcount, const int *ffirst, const int *merged)
{
    int count = 0;
    for (int f = 0; f < fcount; f++) {
        /* a merged supernode's columns run from its lowest member to the representative */
        if (f == 0 || merged[f - 1] == f - 1) {
            factor->super_first[count++] = ffirst[f];
        }
    }
    factor->super_first[count] = linear->block_count;
    factor->super_count = count;
    for (int s = 0; s < count; s++) {
        for (int j = factor->super_first[s]; j < factor->super_first[s + 1]; j++) {
            factor->block_super[j] = s;
        }
    }
}

/* Block rows below each supernode: those of H's columns in it and of its children's rows,
 * after its last column; sorted. children/sibling lists are built in head/next, marks in
 * position. Returns 0 if a count disagrees with the analysis (never, for a valid tree). */
static int pgem_supernodes_rows(pgem_factor_t *factor, const pgem_linear_t *linear,
                                const int *counts)
{
    int *child = factor->head, *sibling = factor->next, *mark = factor->position;
    const int count = factor->super_count;
    for (int s = 0; s < count; s++) {
        child[s] = -1;
    }
    for (int j = 0; j < linear->block_count; j++) {
        mark[j] = -1;
    }
    for (int s = count - 1; s >= 0; s--) { /* children in increasing order */
        const int up = pgem_factor_parent(factor, linear->block_parent, s);
        if (up >= 0) {
            sibling[s] = child[up];
            child[up] = s;
        }
    }
    int written = 0;
    for (int s = 0; s < count; s++) {
        const int last = factor->super_first[s + 1] - 1;
        int *out = factor->rows + written;
        int found = 0;
        factor->row_start[s] = written;
        for (int j = factor->super_first[s]; j <= last; j++) {
            for (int q = linear->block_colptr[j]; q < linear->block_colptr[j + 1]; q++) {
                const int row = linear->block_rows[q];
                if (row > last && mark[row] != s) {
                    mark[row] = s;
                    out[found++] = row;
                }
            }
        }
        for (int c = child[s]; c >= 0; c = sibling[c]) {
            for (int q = factor->row_start[c]; q < factor->row_start[c + 1]; q++) {
                const int row = factor->rows[q];
                if (row > last && mark[row] != s) {
                    mark[row] = s;
                    out[found++] = row;
                }
            }
        }
        if (found != counts[last] - 1) {
            return 0;
        }
        pgem_sort_ints(out, found);
        written += found;
    }
    factor->row_start[count] = written;
    return 1;
}

/* Nonzeros (with zeros) of the supernodes the amalgamation chose, from the counts alone. */
static int64_t pgem_supernodes_values(const pgem_factor_t *factor, const int *counts, int b)
{
    int64_t values = 0;
    for (int s = 0; s < factor->super_count; s++) {
        const int width = factor->super_first[s + 1] - factor->super_first[s];
        const int64_t height = (int64_t)(width + counts[factor->super_first[s + 1] - 1] - 1) * b;
        values += pgem_trapezoid(height, (int64_t)width * b);
    }
    return values;
}

double pgem_factor_supernode_flops(const pgem_factor_t *factor, int s)
{
    return pgem_factor_trapezoid_flops(pgem_factor_height(factor, s),
                                       (factor->super_first[s + 1] - factor->super_first[s]) * factor->block);
}

int64_t pgem_supernodes_analyze(pgem_linear_t *linear, const int *counts, uint32_t fill_budget)
{
    pgem_factor_t *factor = &linear->factor;
    const int blocks = linear->block_count, b = linear->block;
    int *fsuper = pgem_linear_scratch(linear);          /* [blocks] */
    int *width = fsuper + blocks;           /* block columns of each fundamental supernode */
    int *height = width + blocks;           /* block rows of its first column */
    int *ffirst = factor->task_first;       /* [fcount + 1]; the schedule is built later */
    int *merged = factor->order;            /* [fcount] */
    int *zeros = factor->position;          /* [fcount] explicit zeros of each */
    int fcount = pgem_fundamental(blocks, linear->block_parent, counts, merged, fsuper);
    for (int j = blocks - 1; j >= 0; j--) {
        ffirst[fsuper[j]] = j;
    }
    ffirst[fcount] = blocks;
    for (int f = 0; f < fcount; f++) {
        width[f] = ffirst[f + 1] - ffirst[f];
        height[f] = counts[ffirst[f]];
        zeros[f] = 0;
    }
    pgem_amalgamate(linear, fcount, ffirst, fsuper, width, height, zeros, merged);
    factor->block = b;
    factor->block_count = blocks;
    pgem_supernodes_number(factor, linear, fcount, ffirst, merged);
    int64_t exact = 0;
    double exact_flops = 0.0;
    for (int j = 0; j < blocks; j++) {
        exact += (int64_t)(counts[j] - 1) * b * b + b * (b + 1) / 2;
        for (int c = 0; c < b; c++) {
            const double column = (double)(counts[j] - 1) * b + (b - c);
            exact_flops += column * column;
        }
    }
    factor->exact_flops = exact_flops;
    const int64_t values = pgem_supernodes_values(factor, counts, b);
    factor->exact_nonzeros = exact > INT32_MAX ? INT32_MAX : (int)exact;
    factor->nonzeros = values > INT32_MAX ? INT32_MAX : (int)values;
    if (values > (int64_t)fill_budget) {
        return values; /* the caller refuses it before anything is written past the budget */
    }
    if (!pgem_supernodes_rows(factor, linear, counts)) {
        return PGEM_ERR_OUT_OF_MEMORY; /* cannot happen: the counts describe this tree */
    }
    int64_t offset = 0;
    double flops = 0.0;
    for (int s = 0; s < factor->super_count; s++) {
        const int height_s = pgem_factor_height(factor, s);
        const int width_s = (factor->super_first[s + 1] - factor->super_first[s]) * b;
        factor->value_start[s] = (int)offset;
        offset += pgem_trapezoid(height_s, width_s);
        flops += pgem_factor_trapezoid_flops(height_s, width_s);
    }
    factor->value_start[factor->super_count] = (int)offset;
    factor->flops = flops;
    return values;
}
