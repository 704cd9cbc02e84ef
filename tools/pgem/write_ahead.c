/* The result file's edge lines, formatted on a second thread while the solve runs: optimize
 * changes the poses, never an edge's measurement or information, so the edges' text (most of
 * a g2o file: 9 or 27 numbers a line against 3 or 7 per pose) is known before the solve ends.
 * After it the poses are written and the text follows; where an edge of the instance differs
 * from the file's after all, the text is not used. POSIX: open_memstream, pthreads. */
#define _POSIX_C_SOURCE 200809L

#include "write_ahead.h"

#include <pthread.h>
#include <stdlib.h>
#include <string.h>

static void *pgem_write_ahead_run(void *argument)
{
    pgem_write_ahead_t *ahead = argument;
    FILE *stream = open_memstream(&ahead->text, &ahead->size);
    if (stream == NULL) {
        return NULL;
    }
    pgem_io_graph_t edges = *ahead->file; /* the edge lines only */
    edges.pose_count = 0;
    edges.fixed_count = 0;
    const int status = pgem_io_write_stream(stream, PGEM_FORMAT_G2O, &edges);
    ahead->ok = fclose(stream) == 0 && status == PGEM_OK;
    return NULL;
}

void pgem_write_ahead_start(pgem_write_ahead_t *ahead, const pgem_io_graph_t *file)
{
    memset(ahead, 0, sizeof *ahead);
    ahead->file = file;
    if (file->edge_count == 0 || file->edge_count > PGEM_WRITE_AHEAD_MAX_EDGES) {
        return;
    }
    pthread_t *thread = malloc(sizeof *thread);
    if (thread != NULL && pthread_create(thread, NULL, pgem_write_ahead_run, ahead) == 0) {
        ahead->thread = thread;
    } else {
        free(thread);
    }
}

void pgem_write_ahead_finish(pgem_write_ahead_t *ahead)
{
    if (ahead->thread != NULL) {
        (void)pthread_join(*(pthread_t *)ahead->thread, NULL);
        free(ahead->thread);
        ahead->thread = NULL;
    }
    if (!ahead->ok) {
        free(ahead->text);
        ahead->text = NULL;
        ahead->size = 0;
    }
}

void pgem_write_ahead_free(pgem_write_ahead_t *ahead)
{
    pgem_write_ahead_finish(ahead);
    free(ahead->text);
    ahead->text = NULL;
    ahead->size = 0;
}

int pgem_write_ahead_matches(const pgem_t *instance, const pgem_io_graph_t *file)
{
    if (file->edge_count != pgem_edge_count(instance) || file->dimension != pgem_dimension(instance)) {
        return 0;
    }
    const size_t values = (size_t)PGEM_POSE_SIZE(file->dimension) * sizeof(double);
    const size_t tangent = (size_t)PGEM_TANGENT_SIZE(file->dimension);
    const size_t information = tangent * tangent * sizeof(double); /* the bits written */
    for (uint32_t i = 0; i < pgem_edge_count(instance); i++) {
        const pgem_io_edge_t *edge = &file->edges[i];
        pgem_edge_view_t view;
        if (pgem_edge_at(instance, i, &view) != PGEM_OK || view.from != edge->from ||
            view.to != edge->to || memcmp(view.measurement, edge->measurement, values) != 0 ||
            memcmp(view.information, edge->information, information) != 0) {
            return 0;
        }
    }
    return 1;
}
