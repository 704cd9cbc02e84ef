/* AMD (CSparse) on a pattern a layer above built: linalg owns the CSparse pool, so the online
 * factor's rebuild orders its block graph through this call rather than opening the pool. */
#include "linalg/linear.h"

int pgem_linear_amd(pgem_linear_t *linear, int n, int *colptr, int *rows, int *order)
{
    cs_di pattern = {colptr[n], n, n, colptr, rows, NULL, -1};
    pgem_cs_open(&linear->cs_pool);
    int *amd = n > 0 ? cs_di_amd(1, &pattern) : NULL;
    if (n > 0 && amd == NULL) {
        pgem_cs_close(&linear->cs_pool);
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    for (int k = 0; k < n; k++) {
        order[k] = amd[k];
    }
    cs_di_free(amd);
    pgem_cs_close(&linear->cs_pool);
    return PGEM_OK;
}
