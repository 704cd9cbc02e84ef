/* The bridge's append-only journal, in the standard LCM log format (what lcm-logger writes and
 * lcm-logplayer replays): every accepted pose, edge and reset, in the order the bridge
 * admitted them. A bridge restarted on its journal replays it and has exactly the graph it had
 * accepted; each record goes to the file in a single write(2), so a process killed at any
 * moment leaves whole records (plus at most one torn record at the end, which the next open
 * cuts off and reports).
 *
 * Each record the journal writes carries a CRC-32 of its bytes in the low 32 bits of its LCM
 * event number (the high 32 bits count the records from 1, so event numbers still increase);
 * LCM's readers and lcm-logplayer pass event numbers through unread. A record whose event
 * number is below 2^32 (lcm-logger's, or a journal written before the checksum), or one more
 * than the record's before it (a writer counting in ones appended it), is taken by its
 * structure and payload. A record that fails its checks in the middle of the file is
 * skipped, counted and reported with its byte offsets, and reading resumes at the next record
 * that passes them; only a torn last record is ever cut, and no byte of a record is rewritten.
 *
 * The file is held with an exclusive lock (flock) while open, so a second bridge on the same
 * journal is refused; its path is opened without following a symbolic link, and every append
 * checks that the path still names the open file (not renamed, deleted or replaced). */
#ifndef PGEM_BRIDGE_JOURNAL_H
#define PGEM_BRIDGE_JOURNAL_H

#include <stddef.h>
#include <stdint.h>

typedef struct pgem_journal pgem_journal_t;

/* Called for each whole record on open, in file order. */
typedef void (*pgem_journal_record_fn)(void *user, const char *channel, const void *data,
                                       size_t size, int64_t utime);

/* Says whether a record without a checksum holds a message the reader knows (1) or not (0):
 * with damage around, a record is only taken as the place to resume reading when it does.
 * May be NULL (then any record whose structure is sound will do). */
typedef int (*pgem_journal_recognise_fn)(void *user, const char *channel, const void *data,
                                         size_t size);

#define PGEM_JOURNAL_DAMAGE_LISTED 8 /* damaged stretches whose offsets the info lists */

typedef struct pgem_journal_info {
    int64_t records;         /* whole records replayed */
    int64_t checked;         /* of them, records whose checksum was verified */
    int64_t torn_bytes;      /* bytes of an incomplete last record, cut off */
    int64_t skipped_bytes;   /* damaged bytes skipped between records (left in place) */
    int64_t skipped;         /* damaged stretches skipped (one per damaged record, as a rule) */
    struct {
        int64_t start;       /* byte offsets of the stretch, [start, end) */
        int64_t end;
        const char *why;     /* the check its first record failed, in words */
    } damage[PGEM_JOURNAL_DAMAGE_LISTED]; /* the first of them */
} pgem_journal_info_t;

/* Largest record accepted (channel + data); a larger header is damage. */
#define PGEM_JOURNAL_RECORD_MAX (16u << 20)

/* Opens the journal at path, creating it if absent, and locks it (a file another process holds
 * locked is refused: another bridge runs on it). A path that is a symbolic link is refused
 * (never followed), and so is a file that is not a regular file, or is not empty and holds no
 * LCM log record (neither at its start nor, after damage, further in), unchanged. An existing
 * journal is replayed through on_record first (may be NULL), damaged records are skipped (see
 * above; recognise may be NULL), a torn last record is truncated, and appends go after the
 * last byte kept. sync != 0 makes every append fdatasync(2) (survives power loss, slower).
 * Returns NULL on error with "PATH: what went wrong" in message. */
pgem_journal_t *pgem_journal_open(const char *path, int sync, pgem_journal_record_fn on_record,
                                  pgem_journal_recognise_fn recognise, void *user,
                                  pgem_journal_info_t *info, char *message,
                                  size_t message_size);

/* Appends one record; 0 on success, -1 with message on failure. A failed record is taken back
 * out of the file, so the journal holds exactly the records that succeeded, and the next
 * append may succeed (a disk that had no room may have room again). A record fails too when,
 * after its write, the path no longer names the open file (renamed, rotated, deleted,
 * replaced, a symlink put there) or the file's size is not what the journal wrote (cut or
 * written by another program): a restart would not replay it. From then on nothing is
 * written until the file is back in place (pgem_journal_check says so too). When a record
 * cannot be taken back, or an fdatasync failed (the disk's state is then unknown), every
 * later append fails too, saying why. */
int pgem_journal_append(pgem_journal_t *journal, const char *channel, const void *data,
                        size_t size, int64_t utime, char *message, size_t message_size);

/* 0 while the path names the open journal and its size is what the journal wrote; else -1
 * with what happened in message (the check every append makes, for a periodic look). */
int pgem_journal_check(pgem_journal_t *journal, char *message, size_t message_size);

/* 1 if `name` in the folder open as `dir` is the journal: the same file, or the journal's own
 * name in its own folder (whatever that name holds now); else 0. */
int pgem_journal_is_named(const pgem_journal_t *journal, int dir, const char *name);

/* Records in the file (replayed plus appended). */
int64_t pgem_journal_records(const pgem_journal_t *journal);

/* The CRC-32 the records carry (zlib's crc32: reflected polynomial 0xEDB88320), continued
 * from crc (0 to start). */
uint32_t pgem_journal_crc32(uint32_t crc, const void *data, size_t size);

void pgem_journal_close(pgem_journal_t *journal);

#endif /* PGEM_BRIDGE_JOURNAL_H */
