/* Replays inputs through a fuzz target without libFuzzer, so regression inputs run in the
 * ordinary (and the sanitizer) test suite:
 *
 *   fuzz_replay_TARGET [DIR|FILE ...]     the built-in seeds, then every file named or in DIR
 *   fuzz_replay_TARGET --write-seeds DIR  writes the built-in seeds into DIR (a corpus)
 *
 * A broken invariant aborts inside the target; before each input the program prints its name
 * to stderr, so the failing one is the last named. */
#define _POSIX_C_SOURCE 200809L

#include <dirent.h>
#include <errno.h>
#include <string.h>
#include <sys/stat.h>

#include "fuzz.h"

/* Largest input replayed (a regression file is small and written by hand). */
#define REPLAY_MAX (1u << 20)

static uint8_t input[REPLAY_MAX];

static int run_file(const char *path)
{
    FILE *file = fopen(path, "rb");
    if (file == NULL) {
        fprintf(stderr, "%s: cannot open: %s\n", path, strerror(errno));
        return -1;
    }
    size_t size = fread(input, 1, sizeof input, file);
    int failed = ferror(file) || (size == sizeof input && getc(file) != EOF);
    fclose(file);
    if (failed) {
        fprintf(stderr, "%s: cannot read it whole (at most %u bytes)\n", path, REPLAY_MAX);
        return -1;
    }
    fprintf(stderr, "replay %s (%zu bytes)\n", path, size);
    LLVMFuzzerTestOneInput(input, size);
    return 1;
}

static int compare_names(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* Every regular file in dir, in name order; returns how many ran, or -1. */
static int run_directory(const char *dir)
{
    DIR *stream = opendir(dir);
    if (stream == NULL) {
        fprintf(stderr, "%s: cannot open: %s\n", dir, strerror(errno));
        return -1;
    }
    char **names = NULL;
    size_t count = 0, capacity = 0;
    struct dirent *entry;
    while ((entry = readdir(stream)) != NULL) {
        if (entry->d_name[0] == '.') {
            continue;
        }
        if (count == capacity) {
            capacity = capacity == 0 ? 64 : 2 * capacity;
            char **grown = realloc(names, capacity * sizeof *names);
            if (grown == NULL) {
                abort();
            }
            names = grown;
        }
        size_t length = strlen(dir) + strlen(entry->d_name) + 2;
        names[count] = malloc(length);
        if (names[count] == NULL) {
            abort();
        }
        snprintf(names[count], length, "%s/%s", dir, entry->d_name);
        count++;
    }
    closedir(stream);
    if (count > 1) {
        qsort(names, count, sizeof *names, compare_names);
    }
    int ran = 0;
    for (size_t i = 0; i < count; ++i) {
        struct stat info;
        if (ran >= 0 && stat(names[i], &info) == 0 && S_ISREG(info.st_mode)) {
            ran = run_file(names[i]) < 0 ? -1 : ran + 1;
        }
        free(names[i]);
    }
    free(names);
    return ran;
}

static int run_seeds(void)
{
    static uint8_t seed[FUZZ_SEED_MAX];
    unsigned index = 0;
    size_t size;
    while ((size = fuzz_seed(index, seed, sizeof seed)) > 0) {
        fprintf(stderr, "replay built-in seed %u (%zu bytes)\n", index, size);
        LLVMFuzzerTestOneInput(seed, size);
        index++;
    }
    return (int)index;
}

static int write_seeds(const char *dir)
{
    static uint8_t seed[FUZZ_SEED_MAX];
    unsigned index = 0;
    size_t size;
    while ((size = fuzz_seed(index, seed, sizeof seed)) > 0) {
        char path[4096];
        snprintf(path, sizeof path, "%s/builtin-%03u", dir, index);
        FILE *file = fopen(path, "wb");
        if (file == NULL || fwrite(seed, 1, size, file) != size || fclose(file) != 0) {
            fprintf(stderr, "%s: cannot write: %s\n", path, strerror(errno));
            return 1;
        }
        index++;
    }
    printf("%u built-in seeds written to %s\n", index, dir);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "--write-seeds") == 0) {
        return write_seeds(argv[2]);
    }
    if (argc > 1 && argv[1][0] == '-') {
        fprintf(stderr, "usage: %s [DIR|FILE ...] | --write-seeds DIR\n", argv[0]);
        return 2;
    }
    int total = run_seeds();
    for (int i = 1; i < argc; ++i) {
        struct stat info;
        if (stat(argv[i], &info) != 0) {
            fprintf(stderr, "%s: %s\n", argv[i], strerror(errno));
            return 1;
        }
        int ran = S_ISDIR(info.st_mode) ? run_directory(argv[i]) : run_file(argv[i]);
        if (ran < 0) {
            return 1;
        }
        total += ran;
    }
    printf("%d inputs replayed, every invariant held\n", total);
    return 0;
}
