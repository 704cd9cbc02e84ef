/* The bridge's append-only journal, in the standard LCM log format (what lcm-logger writes and
 * lcm-logplayer replays): every accepted pose, edge and reset, in the order the bridge
 * admitted them. A bridge restarted on its journal replays it and has exactly the graph it had
 * accepted; each record goes to the file in a single write(2), so a process killed at any
 * moment leaves whole records (plus at most one torn record at the end, which the next open
 * cuts off and reports). */
#ifndef PGEM_BRIDGE_JOURNAL_H
#define PGEM_BRIDGE_JOURNAL_H

#include <stddef.h>
#include <stdint.h>

typedef struct pgem_journal pgem_journal_t;

/* Called for each whole record on open, in file order. */
typedef void (*pgem_journal_record_fn)(void *user, const char *channel, const void *data,
                                       size_t size, int64_t utime);

typedef struct pgem_journal_info {
    int64_t records;        /* whole records replayed */
    int64_t torn_bytes;     /* bytes of an incomplete last record, cut off */
    int64_t skipped_bytes;  /* damaged bytes skipped between records (reported, not fatal) */
} pgem_journal_info_t;

/* Largest record accepted (channel + data); a larger header is damage. */
#define PGEM_JOURNAL_RECORD_MAX (16u << 20)

/* Opens the journal at path, creating it if absent. A file that is not a regular file, or is
 * not empty and does not start with an LCM log record, is refused unchanged. An existing
 * journal is replayed through on_record first (may be NULL), its torn tail is truncated, and
 * appends go after its last whole record. sync != 0 makes every append fdatasync(2) (survives
 * power loss, slower). Returns NULL on error with "PATH: what went wrong" in message. */
pgem_journal_t *pgem_journal_open(const char *path, int sync, pgem_journal_record_fn on_record,
                                  void *user, pgem_journal_info_t *info, char *message,
                                  size_t message_size);

/* Appends one record; 0 on success, -1 with message on failure. A failed record is taken back
 * out of the file, so the journal holds exactly the records that succeeded, and the next
 * append may succeed (a disk that had no room may have room again). When it cannot be taken
 * back, or an fdatasync failed (the disk's state is then unknown), every later append fails
 * too, saying why. */
int pgem_journal_append(pgem_journal_t *journal, const char *channel, const void *data,
                        size_t size, int64_t utime, char *message, size_t message_size);

/* Records in the file (replayed plus appended). */
int64_t pgem_journal_records(const pgem_journal_t *journal);

void pgem_journal_close(pgem_journal_t *journal);

#endif /* PGEM_BRIDGE_JOURNAL_H */
