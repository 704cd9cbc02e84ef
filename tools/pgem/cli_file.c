/* Output files of the tools, written whole or not at all: a new temporary file beside the
 * target, renamed over it when complete, so a full disk, a failed write or a killed process
 * never leaves a file cut short, and `pgem optimize X -o X` cannot destroy X. */
#define _XOPEN_SOURCE 700 /* realpath */
#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"

/* The file a rename must replace: the path, or the file a symbolic link there names (the link
 * stays, as when the file was written through it); NULL when out of memory. */
static char *pgem_cli_target(const char *path)
{
    struct stat link;
    if (lstat(path, &link) == 0 && S_ISLNK(link.st_mode)) {
        char *resolved = realpath(path, NULL);
        if (resolved != NULL) {
            return resolved;
        }
    }
    char *copy = malloc(strlen(path) + 1);
    if (copy != NULL) {
        strcpy(copy, path);
    }
    return copy;
}

/* "DIR/.NAME.XXXXXX" for mkstemp, beside target. */
static char *pgem_cli_temporary_name(const char *target)
{
    const char *slash = strrchr(target, '/');
    size_t folder = slash != NULL ? (size_t)(slash - target) + 1u : 0u;
    char *name = malloc(strlen(target) + 10u);
    if (name != NULL) {
        memcpy(name, target, folder);
        sprintf(name + folder, ".%s.XXXXXX", target + folder);
    }
    return name;
}

/* The permissions a new file gets (the process's umask applied), or the old file's. */
static mode_t pgem_cli_mode(const char *target)
{
    struct stat old;
    if (stat(target, &old) == 0 && S_ISREG(old.st_mode)) {
        return old.st_mode & 07777;
    }
    mode_t mask = umask(0);
    umask(mask);
    return 0666 & ~mask;
}

int pgem_cli_file_open(pgem_cli_file_t *file, const char *prefix, const char *path)
{
    memset(file, 0, sizeof *file);
    file->prefix = prefix;
    file->path = path;
    struct stat existing;
    if (stat(path, &existing) == 0 && !S_ISREG(existing.st_mode) && !S_ISDIR(existing.st_mode)) {
        file->stream = fopen(path, "w"); /* a device or a pipe (/dev/stdout): no rename */
        if (file->stream == NULL) {
            fprintf(stderr, "%s: %s: cannot open for writing: %s\n", prefix, path,
                    strerror(errno));
            return -1;
        }
        return 0;
    }
    file->target = pgem_cli_target(path);
    file->temporary = file->target != NULL ? pgem_cli_temporary_name(file->target) : NULL;
    if (file->temporary == NULL) {
        fprintf(stderr, "%s: out of memory\n", prefix);
        free(file->target);
        return -1;
    }
    int fd = mkstemp(file->temporary);
    if (fd < 0 || fchmod(fd, pgem_cli_mode(file->target)) != 0 ||
        (file->stream = fdopen(fd, "w")) == NULL) {
        fprintf(stderr, "%s: %s: cannot create a file beside it to write into: %s\n", prefix,
                path, strerror(errno));
        if (fd >= 0) {
            close(fd);
            remove(file->temporary);
        }
        free(file->target);
        free(file->temporary);
        memset(file, 0, sizeof *file);
        return -1;
    }
    return 0;
}

void pgem_cli_file_discard(pgem_cli_file_t *file)
{
    fclose(file->stream);
    if (file->temporary != NULL) {
        remove(file->temporary);
    }
    free(file->target);
    free(file->temporary);
    memset(file, 0, sizeof *file);
}

int pgem_cli_file_commit(pgem_cli_file_t *file, int failed)
{
    const char *step = NULL;
    int error = errno;
    if (failed || ferror(file->stream) || fflush(file->stream) != 0) {
        step = "write";
        error = errno;
    } else if (file->temporary != NULL && fsync(fileno(file->stream)) != 0) {
        step = "fsync";
        error = errno;
    }
    if (fclose(file->stream) != 0 && step == NULL) {
        step = "close";
        error = errno;
    }
    if (step == NULL && file->temporary != NULL && rename(file->temporary, file->target) != 0) {
        step = "rename";
        error = errno;
    }
    if (step != NULL) {
        fprintf(stderr, "%s: %s: %s failed: %s%s\n", file->prefix, file->path, step,
                error != 0 ? strerror(error) : "unknown error",
                file->temporary != NULL ? " (the file is as it was)" : "");
        if (file->temporary != NULL) {
            remove(file->temporary);
        }
    }
    free(file->target);
    free(file->temporary);
    memset(file, 0, sizeof *file);
    return step == NULL ? PGEM_EXIT_OK : PGEM_EXIT_IO;
}
