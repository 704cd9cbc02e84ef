/* The result file's edge lines formatted on a second thread while the solve runs
 * (write_ahead.c). */
#ifndef PGEM_WRITE_AHEAD_H
#define PGEM_WRITE_AHEAD_H

#include <stddef.h>

#include "pgem/io.h"
#include "pgem/pgem.h"

/* Graphs with more edges are written after the solve only (the text would take about 200
 * bytes an edge more memory during it). */
#define PGEM_WRITE_AHEAD_MAX_EDGES 2000000u

typedef struct pgem_write_ahead {
    const pgem_io_graph_t *file; /* the graph read, not touched until finish */
    void *thread;                /* the formatting thread while it runs (NULL: none) */
    char *text;                  /* the edge lines, once finished (NULL: none) */
    size_t size;                 /* and their bytes */
    int ok;                      /* 1 if the text is whole */
} pgem_write_ahead_t;

/* Starts formatting file's edge lines (g2o) on a thread; without one, nothing is formatted. */
void pgem_write_ahead_start(pgem_write_ahead_t *ahead, const pgem_io_graph_t *file);
/* Waits for the thread; text is then the whole edge text or NULL. */
void pgem_write_ahead_finish(pgem_write_ahead_t *ahead);
/* finish, and the text freed. */
void pgem_write_ahead_free(pgem_write_ahead_t *ahead);
/* 1 if every edge of the instance is the file's (the same ids and the same bits of what the
 * writer writes), so the text is the instance's too. */
int pgem_write_ahead_matches(const pgem_t *instance, const pgem_io_graph_t *file);

#endif /* PGEM_WRITE_AHEAD_H */
