/* Block pattern of H: free-pose numbering, the sorted upper block pattern and its transpose. */
#include "linalg/linear.h"

/* Numbers the free poses 0, 1, ... (-1 for held poses); returns how many are free. */
int pgem_pattern_number_free(pgem_linear_t *linear, const pgem_store_t *store)
{
    int free_count = 0;
    for (uint32_t p = 0; p < store->pose_count; p++) {
        int held = PGEM_POSE_HELD(store, p);
        linear->pose_block[p] = held ? -1 : free_count++;
    }
    return free_count;
}

/* Column-compressed (row, column) pairs of every edge in the structure joining two free poses, rows sorted
 * and duplicates merged: the classic double transpose, into colptr / rows.
 * work must hold 2 * edge_count + 2 * (block_count + 1) ints. */
static void pgem_pattern_bucket(const pgem_linear_t *linear, const pgem_store_t *store,
                                int block_count, int *colptr, int *rows, int *work)
{
    int *rowptr = work;
    int *cols = work + block_count + 1;
    int *cursor = cols + store->edge_count;
    for (int j = 0; j <= block_count; j++) {
        rowptr[j] = 0;
    }
    for (uint32_t k = 0; k < store->edge_count; k++) {
        int a, b;
        if (pgem_edge_blocks(linear, store, k, &a, &b)) {
            rowptr[(a < b ? a : b) + 1]++;
        }
    }
    for (int j = 0; j < block_count; j++) {
        rowptr[j + 1] += rowptr[j];
        cursor[j] = rowptr[j];
    }
    /* rows bucketed by row index, holding their column */
    for (uint32_t k = 0; k < store->edge_count; k++) {
        int a, b;
        if (pgem_edge_blocks(linear, store, k, &a, &b)) {
            cols[cursor[a < b ? a : b]++] = a < b ? b : a;
        }
    }
    /* transpose back: visiting rows in order sorts every column's rows */
    for (int j = 0; j <= block_count; j++) {
        colptr[j] = 0;
    }
    for (int q = 0; q < rowptr[block_count]; q++) {
        colptr[cols[q] + 1]++;
    }
    for (int j = 0; j < block_count; j++) {
        colptr[j + 1] += colptr[j];
        cursor[j] = colptr[j];
    }
    for (int i = 0; i < block_count; i++) {
        for (int q = rowptr[i]; q < rowptr[i + 1]; q++) {
            rows[cursor[cols[q]]++] = i;
        }
    }
}

/* Removes adjacent duplicate rows inside each column, in place. */
static void pgem_pattern_unique(int block_count, int *colptr, int *rows)
{
    int write = 0;
    int start = colptr[0];
    for (int j = 0; j < block_count; j++) {
        int end = colptr[j + 1];
        colptr[j] = write;
        for (int q = start; q < end; q++) {
            if (q == start || rows[q] != rows[q - 1]) {
                rows[write++] = rows[q];
            }
        }
        start = end;
    }
    colptr[block_count] = write;
}

void pgem_pattern_build(const pgem_linear_t *linear, const pgem_store_t *store, int block_count,
                        int *colptr, int *rows, int *work)
{
    pgem_pattern_bucket(linear, store, block_count, colptr, rows, work);
    pgem_pattern_unique(block_count, colptr, rows);
}

void pgem_pattern_transpose(int block_count, const int *colptr, const int *rows, int *out_colptr,
                            int *out_rows)
{
    for (int j = 0; j <= block_count; j++) {
        out_colptr[j] = 0;
    }
    for (int q = 0; q < colptr[block_count]; q++) {
        out_colptr[rows[q] + 1]++;
    }
    for (int j = 0; j < block_count; j++) {
        out_colptr[j + 1] += out_colptr[j];
    }
    /* out_colptr[i] is now where row i's column starts; fill by walking the columns in order,
     * so each output column's rows come out sorted */
    for (int j = 0; j < block_count; j++) {
        for (int q = colptr[j]; q < colptr[j + 1]; q++) {
            out_rows[out_colptr[rows[q]]++] = j;
        }
    }
    for (int j = block_count; j > 0; j--) {
        out_colptr[j] = out_colptr[j - 1];
    }
    out_colptr[0] = 0;
}
