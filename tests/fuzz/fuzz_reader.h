/* The checks fuzz_g2o and fuzz_toro share: read the bytes as a graph file, check what the
 * reader promises, then load, solve and write the graph back. */
#ifndef PGEM_FUZZ_READER_H
#define PGEM_FUZZ_READER_H

#include "fuzz.h"
#include "pgem/io.h"

/* Reads data (size bytes) with format under the stream name `name`, and checks:
 * - a failed read returns a documented code, leaves the graph empty, and its message is
 *   NUL-terminated and starts with "NAME:LINE: " (LINE one of the input's lines);
 * - a read graph is consistent (unique pose ids, edges and FIX ids naming poses, edge kinds
 *   from the ids, symmetric information, finite values, unit rotations in guessed 3D poses,
 *   counters);
 * - writing it in its format and reading that back gives the same graph bit for bit;
 * - small graphs (at most FUZZ_READER_MAX_POSES / _EDGES) load into an instance sized by
 *   pgem_io_config without a capacity error, and a short solve either succeeds with finite
 *   poses or fails leaving them as they were; the solved instance round-trips through g2o. */
void fuzz_reader_run(const uint8_t *data, size_t size, pgem_format_t format, const char *name);

#define FUZZ_READER_MAX_POSES 64u
#define FUZZ_READER_MAX_EDGES 256u

/* Copies seeds[index] (text) into buffer; 0 past the last seed. */
size_t fuzz_reader_seed(const char *const *seeds, unsigned count, unsigned index,
                        uint8_t *buffer, size_t capacity);

#endif /* PGEM_FUZZ_READER_H */
