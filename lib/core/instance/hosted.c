/* Hosted convenience: one malloc of the whole block (left out with PGEM_NO_MALLOC). */
#include "instance.h"

#ifndef PGEM_NO_MALLOC
#include <stdlib.h>

int pgem_create(pgem_t **instance, const pgem_config_t *config)
{
    if (instance == NULL || config == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    size_t size = pgem_memory_size(config);
    if (size == 0) {
        return PGEM_ERR_CONFIG;
    }
    void *block = malloc(size);
    if (block == NULL) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    int status = pgem_init(instance, config, block, size);
    if (status != PGEM_OK) {
        free(block);
        return status;
    }
    /* The block's start is remembered so destroy can free it whatever the alignment skip. */
    (*instance)->hosted_block = block;
    return PGEM_OK;
}

void pgem_destroy(pgem_t *instance)
{
    if (instance != NULL) {
        free(instance->hosted_block);
    }
}
#endif
