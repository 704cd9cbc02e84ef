/* The solver thread's SNAPSHOT writes: the graph and its weights, whole or absent. */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bridge_internal.h"
#include "pgem/io.h"

/* What a snapshot file holds, written to a stream. */
typedef int (*snapshot_writer_fn)(FILE *stream, const pgem_t *core);

static int write_graph(FILE *stream, const pgem_t *core)
{
    pgem_io_graph_t graph;
    int status = pgem_io_from_instance(core, &graph);
    if (status == PGEM_OK) {
        status = pgem_io_write_stream(stream, PGEM_FORMAT_G2O, &graph);
        pgem_io_graph_free(&graph);
    }
    return status;
}

/* Writes a new hidden temporary file in the snapshot folder for NAME (O_EXCL | O_NOFOLLOW,
 * so nothing planted there is followed or reused), synced; its name into temporary and its
 * size into *bytes. 0, or -1 with message (nothing left behind). */
static int snapshot_temporary(const bridge_t *bridge, const char *name,
                              snapshot_writer_fn writer, char *temporary, size_t temporary_size,
                              uint64_t *bytes, char *message, size_t message_size)
{
    int dir = bridge->snapshot_dir;
    int fd = -1;
    for (unsigned attempt = 0; fd < 0 && attempt < 100; ++attempt) {
        snprintf(temporary, temporary_size, ".%s.%ld.%u.tmp", name, (long)getpid(), attempt);
        fd = openat(dir, temporary, O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
        if (fd < 0 && errno != EEXIST) {
            break;
        }
    }
    if (fd < 0) {
        snprintf(message, message_size, "%s: cannot create a temporary file: %s", name,
                 strerror(errno));
        return -1;
    }
    FILE *stream = fdopen(fd, "w");
    struct stat info;
    int failed = stream == NULL || writer(stream, bridge->solver.core) != PGEM_OK ||
                 fflush(stream) != 0 || fsync(fd) != 0 || fstat(fd, &info) != 0;
    int saved = errno;
    if (stream != NULL ? fclose(stream) != 0 : close(fd) != 0) {
        failed = 1;
        saved = errno;
    }
    if (failed) {
        unlinkat(dir, temporary, 0);
        snprintf(message, message_size, "%s: cannot write: %s", name, strerror(saved));
        return -1;
    }
    *bytes = (uint64_t)info.st_size;
    return 0;
}

/* A name in the snapshot folder a snapshot may replace: absent, a file or a symlink (a
 * rename replaces a symlink, never writes through it). 1, or 0 with the reason. */
static int snapshot_target_ok(const bridge_t *bridge, const char *name, char *message,
                              size_t message_size)
{
    struct stat info;
    if (fstatat(bridge->snapshot_dir, name, &info, AT_SYMLINK_NOFOLLOW) != 0 ||
        S_ISREG(info.st_mode) || S_ISLNK(info.st_mode)) {
        return 1;
    }
    snprintf(message, message_size, "%s is %s, not a file a snapshot may replace", name,
             S_ISDIR(info.st_mode) ? "a folder" : "a special file");
    return 0;
}

/* A snapshot is whole or absent (issue 31): NAME and NAME.weights are both written to
 * temporary files first; only when both are complete are they renamed into place, the
 * weights first, then the graph; if the graph's rename fails the new NAME.weights is removed,
 * so a failure leaves no new half (an older NAME or NAME.weights stays as it was, unless
 * that removal is what replaced it). A folder or special file at either name refuses the
 * snapshot before anything is written. */
void bridge_snapshot_write(bridge_t *bridge, const char *name)
{
    char message[PGEM_PATH_MAX + 512] = "";
    char weights[PGEM_SNAPSHOT_NAME_MAX + 16];
    char graph_temporary[PGEM_SNAPSHOT_NAME_MAX + 64] = "";
    char weights_temporary[PGEM_SNAPSHOT_NAME_MAX + 80] = "";
    snprintf(weights, sizeof weights, "%s.weights", name);
    uint64_t graph_bytes = 0;
    uint64_t weights_bytes = 0;
    const int dir = bridge->snapshot_dir;
    int done = snapshot_target_ok(bridge, name, message, sizeof message) &&
               snapshot_target_ok(bridge, weights, message, sizeof message) &&
               snapshot_temporary(bridge, name, write_graph, graph_temporary,
                                  sizeof graph_temporary, &graph_bytes, message,
                                  sizeof message) == 0;
    if (done && snapshot_temporary(bridge, weights, pgem_io_write_weights, weights_temporary,
                                   sizeof weights_temporary, &weights_bytes, message,
                                   sizeof message) != 0) {
        unlinkat(dir, graph_temporary, 0);
        done = 0;
    }
    if (done && renameat(dir, weights_temporary, dir, weights) != 0) {
        snprintf(message, sizeof message, "%s: cannot write: %s", weights, strerror(errno));
        unlinkat(dir, weights_temporary, 0);
        unlinkat(dir, graph_temporary, 0);
        done = 0;
    }
    if (done && renameat(dir, graph_temporary, dir, name) != 0) {
        snprintf(message, sizeof message, "%s: cannot write: %s (the new %s removed again)",
                 name, strerror(errno), weights);
        unlinkat(dir, graph_temporary, 0);
        unlinkat(dir, weights, 0);
        done = 0;
    }
    if (done) {
        pthread_mutex_lock(&bridge->handoff.lock);
        bridge_snapshot_written(bridge, graph_bytes + weights_bytes);
        pthread_mutex_unlock(&bridge->handoff.lock);
        bridge_note(bridge, "snapshot: %s/%s (%u poses, %u edges) and %s, %.1f MiB",
                    bridge->options.snapshot_dir, name, pgem_pose_count(bridge->solver.core),
                    pgem_edge_count(bridge->solver.core), weights,
                    (double)(graph_bytes + weights_bytes) / 1048576.0);
    } else {
        bridge_note(bridge, "snapshot failed, nothing written: %s/%s",
                    bridge->options.snapshot_dir, message);
    }
}
