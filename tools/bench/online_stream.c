/* The online driver's stream: poses in file order, each followed by the edges it completes. */
#include <stdlib.h>
#include <string.h>

#include "online.h"

/* The file index of each edge's later pose (the one sent last), as pair keys: sorting the
 * pairs by (later pose, edge index) gives the stream order. */
static int online_ready_pairs(const pgem_io_graph_t *file, const pgem_io_pose_index_t *ids,
                              pgem_cli_pair_t *pairs)
{
    for (size_t e = 0; e < file->edge_count; e++) {
        size_t from = pgem_io_find_pose(ids, file->pose_count, file->edges[e].from);
        size_t to = pgem_io_find_pose(ids, file->pose_count, file->edges[e].to);
        if (from == PGEM_IO_NO_POSE || to == PGEM_IO_NO_POSE) {
            return -1; /* the reader refuses such files */
        }
        pairs[e] = (pgem_cli_pair_t){(pgem_id_t)(from > to ? from : to), 0, e};
    }
    pgem_cli_sort_pairs(pairs, file->edge_count);
    return 0;
}

/* Fills the stream's arrays from the sorted pairs, and the FIX flags. */
static void online_fill(const pgem_io_graph_t *file, const pgem_io_pose_index_t *ids,
                        const pgem_cli_pair_t *pairs, online_stream_t *stream)
{
    size_t next = 0;
    for (size_t p = 0; p < file->pose_count; p++) {
        stream->first_edge[p] = next;
        while (next < file->edge_count && pairs[next].from == (pgem_id_t)p) {
            stream->edges[next] = pairs[next].index;
            next++;
        }
    }
    stream->first_edge[file->pose_count] = next;
    for (size_t f = 0; f < file->fixed_count; f++) {
        size_t pose = pgem_io_find_pose(ids, file->pose_count, file->fixed[f]);
        if (pose != PGEM_IO_NO_POSE) {
            stream->fixed[pose] = 1;
        }
    }
}

int online_stream_build(const pgem_io_graph_t *file, online_stream_t *stream)
{
    memset(stream, 0, sizeof *stream);
    stream->file = file;
    stream->edges = malloc((file->edge_count + 1u) * sizeof *stream->edges);
    stream->first_edge = malloc((file->pose_count + 1u) * sizeof *stream->first_edge);
    stream->fixed = calloc(file->pose_count + 1u, 1);
    pgem_io_pose_index_t *ids = pgem_io_index_poses(file);
    pgem_cli_pair_t *pairs = malloc((file->edge_count + 1u) * sizeof *pairs);
    int status = -1;
    if (stream->edges != NULL && stream->first_edge != NULL && stream->fixed != NULL &&
        ids != NULL && pairs != NULL && online_ready_pairs(file, ids, pairs) == 0) {
        online_fill(file, ids, pairs, stream);
        status = 0;
    }
    free(ids);
    free(pairs);
    if (status != 0) {
        online_stream_free(stream);
    }
    return status;
}

void online_stream_free(online_stream_t *stream)
{
    free(stream->edges);
    free(stream->first_edge);
    free(stream->fixed);
    memset(stream, 0, sizeof *stream);
}
