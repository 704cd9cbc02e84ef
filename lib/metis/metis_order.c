/* METIS_NodeND on the block graph an analysis hands its orderer (pgem/metis.h). */
#include <stdlib.h>

#include <metis.h>

#include "pgem/metis.h"

/* The symmetric adjacency (METIS's xadj / adjncy) of the upper pattern colptr / rows. */
static void pgem_metis_adjacency(int blocks, const int *colptr, const int *rows, idx_t *xadj,
                                 idx_t *adjncy)
{
    for (int v = 0; v <= blocks; v++) {
        xadj[v] = 0;
    }
    for (int j = 0; j < blocks; j++) {
        for (int q = colptr[j]; q < colptr[j + 1]; q++) {
            xadj[rows[q] + 1]++;
            xadj[j + 1]++;
        }
    }
    for (int v = 0; v < blocks; v++) {
        xadj[v + 1] += xadj[v];
    }
    /* each vertex's neighbours in rising order: first its own column's rows (all below it),
     * then the later columns that hold it as a row, in rising order */
    idx_t *cursor = adjncy + xadj[blocks]; /* the second half of the lent space */
    for (int v = 0; v < blocks; v++) {
        cursor[v] = xadj[v];
    }
    for (int j = 0; j < blocks; j++) {
        for (int q = colptr[j]; q < colptr[j + 1]; q++) {
            adjncy[cursor[j]++] = rows[q];
        }
    }
    for (int j = 0; j < blocks; j++) {
        for (int q = colptr[j]; q < colptr[j + 1]; q++) {
            adjncy[cursor[rows[q]]++] = j;
        }
    }
}

static int pgem_metis_order(void *orderer, int blocks, const int *colptr, const int *rows,
                            int *order)
{
    (void)orderer;
    const size_t edges = (size_t)colptr[blocks];
    /* xadj [blocks + 1], adjncy [2 edges] then its cursors [blocks], perm and iperm [blocks] */
    idx_t *space = malloc(((size_t)blocks * 4u + 1u + 2u * edges) * sizeof *space);
    if (space == NULL) {
        return 1;
    }
    idx_t *xadj = space;
    idx_t *adjncy = xadj + blocks + 1;
    idx_t *perm = adjncy + 2u * edges + (size_t)blocks;
    idx_t *iperm = perm + blocks;
    pgem_metis_adjacency(blocks, colptr, rows, xadj, adjncy);
    idx_t options[METIS_NOPTIONS];
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_NUMBERING] = 0;
    idx_t n = blocks;
    const int status = METIS_NodeND(&n, xadj, adjncy, NULL, options, perm, iperm);
    for (int k = 0; status == METIS_OK && k < blocks; k++) {
        order[k] = (int)perm[k]; /* row k of the permuted matrix is row perm[k] */
    }
    free(space);
    return status == METIS_OK ? 0 : 1;
}

pgem_orderer_t pgem_metis_orderer(void)
{
    pgem_orderer_t orderer = {pgem_metis_order, NULL};
    return orderer;
}

int pgem_metis_use(pgem_t *instance, pgem_order_choice_t choice)
{
    const pgem_orderer_t metis = pgem_metis_orderer();
    return pgem_set_ordering(instance, choice, &metis);
}
