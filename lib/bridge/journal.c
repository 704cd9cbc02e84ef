/* The journal: LCM log records (big-endian): sync word 0xEDA1DA01, event number (int64),
 * timestamp in microseconds (int64), channel length (int32), data length (int32), channel
 * bytes, data bytes. The journal's own records carry their checksum in the event number: its
 * high 32 bits count the records from 1, its low 32 bits are the CRC-32 of every other byte
 * of the record (sync word, count, timestamp, lengths, channel, data). */
#define _POSIX_C_SOURCE 200809L
#include "journal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#define SYNC_WORD 0xEDA1DA01u
#define HEADER_BYTES 28
#define CHANNEL_MAX 256
#define COUNT_MAX 0x7FFFFFFFu /* the count saturates here: event numbers stay positive */
#define NO_PREVIOUS UINT64_MAX   /* no record before: one numbered 0 is not "right after" */

struct pgem_journal {
    int fd;
    int sync;
    char broken[256];       /* why appends stopped for good ("" while they work) */
    int64_t records;
    uint32_t count;         /* the next record's count (its event number's high half) */
    off_t end;              /* the file's size as the journal left it */
    int away;               /* the last check found the path not naming the file */
    dev_t dev;              /* the open file */
    ino_t ino;
    int folder_known;       /* its folder, for pgem_journal_is_named */
    dev_t folder_dev;
    ino_t folder_ino;
    const char *name;       /* the path's last component (in path) */
    unsigned char *buffer;  /* one record being written or read */
    size_t buffer_size;
    char path[1024];
};

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int i = 3; i >= 0; --i) {
        p[i] = (unsigned char)(v & 0xFF);
        v >>= 8;
    }
}

static void put_u64(unsigned char *p, uint64_t v)
{
    for (int i = 7; i >= 0; --i) {
        p[i] = (unsigned char)(v & 0xFF);
        v >>= 8;
    }
}

static uint32_t get_u32(const unsigned char *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

static uint64_t get_u64(const unsigned char *p)
{
    return (uint64_t)get_u32(p) << 32 | get_u32(p + 4);
}

uint32_t pgem_journal_crc32(uint32_t crc, const void *data, size_t size)
{
    /* four bits at a time: the CRC of each nibble value under the reflected polynomial */
    static const uint32_t nibble[16] = {
        0x00000000u, 0x1DB71064u, 0x3B6E20C8u, 0x26D930ACu, 0x76DC4190u, 0x6B6B51F4u,
        0x4DB26158u, 0x5005713Cu, 0xEDB88320u, 0xF00F9344u, 0xD6D6A3E8u, 0xCB61B38Cu,
        0x9B64C2B0u, 0x86D3D2D4u, 0xA00AE278u, 0xBDBDF21Cu};
    const unsigned char *p = data;
    crc = ~crc;
    for (size_t i = 0; i < size; ++i) {
        crc ^= p[i];
        crc = (crc >> 4) ^ nibble[crc & 0x0F];
        crc = (crc >> 4) ^ nibble[crc & 0x0F];
    }
    return ~crc;
}

/* The checksum of a record: its header but the checksum's own four bytes (8..11), then the
 * channel and data. */
static uint32_t record_crc(const unsigned char *header, const unsigned char *body, size_t size)
{
    uint32_t crc = pgem_journal_crc32(0, header, 8);
    crc = pgem_journal_crc32(crc, header + 12, HEADER_BYTES - 12);
    return pgem_journal_crc32(crc, body, size);
}

/* Makes room for a record of `size` bytes. */
static int reserve(pgem_journal_t *journal, size_t size)
{
    if (size <= journal->buffer_size) {
        return 0;
    }
    unsigned char *grown = realloc(journal->buffer, size);
    if (grown == NULL) {
        errno = ENOMEM;
        return -1;
    }
    journal->buffer = grown;
    journal->buffer_size = size;
    return 0;
}

/* Reads exactly size bytes at offset; returns the bytes read (short at end of file) or -1. */
static ssize_t read_at(int fd, void *data, size_t size, off_t offset)
{
    size_t done = 0;
    while (done < size) {
        ssize_t got = pread(fd, (unsigned char *)data + done, size - done, offset + (off_t)done);
        if (got < 0 && errno == EINTR) {
            continue;
        }
        if (got < 0) {
            return -1;
        }
        if (got == 0) {
            break;
        }
        done += (size_t)got;
    }
    return (ssize_t)done;
}

static const unsigned char sync_bytes[4] = {0xED, 0xA1, 0xDA, 0x01};

/* ---- reading: records, damage, the torn tail ---------------------------------------------- */

typedef enum record_state {
    RECORD_WHOLE = 0,  /* its channel and data in journal->buffer, its checksum (if any) right */
    RECORD_TORN = 1,   /* a prefix of a record: runs past the end of the file */
    RECORD_BAD = 2     /* fails a check (why) */
} record_state_t;

typedef struct record {
    uint32_t channel_length;
    uint32_t data_length;
    uint64_t event;
    int64_t utime;
    off_t end;
    int checked;       /* carries a checksum (event number of 2^32 or more) */
    const char *why;
} record_t;

/* The record at offset: a record_state_t, or -1 on a read error (errno set). `previous` is
 * the event number of the record that ends at offset (or NO_PREVIOUS): one numbered right
 * after it comes from a writer that counts in ones (lcm-logger, or an older bridge appending
 * to this journal) and carries no checksum, whatever its number. */
static int examine(pgem_journal_t *journal, off_t offset, off_t file_size, uint64_t previous,
                   record_t *record)
{
    unsigned char header[HEADER_BYTES];
    memset(record, 0, sizeof *record);
    ssize_t got = read_at(journal->fd, header, sizeof header, offset);
    if (got < 0) {
        return -1;
    }
    if (memcmp(header, sync_bytes, got < 4 ? (size_t)got : 4) != 0) {
        record->why = "no sync word";
        return RECORD_BAD;
    }
    if (got < HEADER_BYTES) {
        return RECORD_TORN;
    }
    record->channel_length = get_u32(header + 20);
    record->data_length = get_u32(header + 24);
    if (record->channel_length == 0 || record->channel_length >= CHANNEL_MAX ||
        record->data_length > PGEM_JOURNAL_RECORD_MAX) {
        record->why = "impossible lengths";
        return RECORD_BAD;
    }
    record->event = get_u64(header + 4);
    record->utime = (int64_t)get_u64(header + 12);
    size_t body = (size_t)record->channel_length + record->data_length;
    record->end = offset + HEADER_BYTES + (off_t)body;
    if (record->end > file_size) {
        record->why = "runs past the end of the file";
        return RECORD_TORN;
    }
    if (reserve(journal, body + 1) != 0) {
        return -1;
    }
    got = read_at(journal->fd, journal->buffer, body, offset + HEADER_BYTES);
    if (got < 0) {
        return -1;
    }
    if ((size_t)got != body) {
        record->why = "runs past the end of the file"; /* the file shrank meanwhile */
        return RECORD_TORN;
    }
    record->checked = (record->event >> 32) != 0 && record->event != previous + 1;
    if (record->checked && record_crc(header, journal->buffer, body) != (uint32_t)record->event) {
        record->why = "checksum mismatch";
        return RECORD_BAD;
    }
    return RECORD_WHOLE;
}

/* 1 if the bytes at offset are the end of the file or the start of a record's sync word. */
static int record_follows(const pgem_journal_t *journal, off_t offset, off_t file_size)
{
    unsigned char next[4];
    if (offset >= file_size) {
        return 1;
    }
    ssize_t got = read_at(journal->fd, next, sizeof next, offset);
    return got > 0 && memcmp(next, sync_bytes, (size_t)got) == 0;
}

typedef struct reader {
    pgem_journal_record_fn on_record;
    pgem_journal_recognise_fn recognise;
    void *user;
} reader_t;

/* Whether a whole record (in journal->buffer) is taken. One with a checksum is, it matched.
 * One without is taken in sequence (at the start, or where the record before it ended) when
 * its lengths lead to the next record (or the end of the file) or the reader knows its
 * payload; as the place to resume after damage only when its channel is printable text, its
 * lengths lead to the next record and the reader knows its payload. */
static int record_taken(const pgem_journal_t *journal, const record_t *record, off_t file_size,
                        int resuming, const reader_t *reader)
{
    if (record->checked) {
        return 1;
    }
    char channel[CHANNEL_MAX];
    int printable = 1;
    for (uint32_t i = 0; i < record->channel_length; ++i) {
        unsigned char c = journal->buffer[i];
        printable &= c > 0x20 && c < 0x7F;
        channel[i] = (char)c;
    }
    channel[record->channel_length] = '\0';
    int framed = record_follows(journal, record->end, file_size);
    if (!resuming && framed) {
        return 1;
    }
    if (resuming && !(printable && framed)) {
        return 0;
    }
    if (reader->recognise == NULL) {
        return resuming;
    }
    return reader->recognise(reader->user, channel, journal->buffer + record->channel_length,
                             record->data_length);
}

/* The next offset after `offset` where a record to resume at starts, -1 if none does, -2 on a
 * read error (errno set). */
static off_t resume_point(pgem_journal_t *journal, off_t offset, off_t file_size,
                          const reader_t *reader)
{
    unsigned char window[4096];
    for (off_t at = offset + 1; at < file_size; at += (off_t)sizeof window - 3) {
        ssize_t got = read_at(journal->fd, window, sizeof window, at);
        if (got < 0) {
            return -2;
        }
        for (ssize_t i = 0; i + 4 <= got; ++i) {
            if (memcmp(window + i, sync_bytes, 4) != 0) {
                continue;
            }
            record_t record;
            int state = examine(journal, at + i, file_size, NO_PREVIOUS, &record);
            if (state < 0) {
                return -2;
            }
            if (state == RECORD_WHOLE && record_taken(journal, &record, file_size, 1, reader)) {
                return at + i;
            }
        }
        if (got < (ssize_t)sizeof window) {
            break;
        }
    }
    return -1;
}

static void note_damage(pgem_journal_info_t *info, off_t start, off_t end, const char *why)
{
    if (info->skipped < PGEM_JOURNAL_DAMAGE_LISTED) {
        info->damage[info->skipped].start = start;
        info->damage[info->skipped].end = end;
        info->damage[info->skipped].why = why;
    }
    info->skipped++;
    info->skipped_bytes += end - start;
}

/* Replays every record taken, skipping damage; returns the offset where appends go (the end
 * of the file, or the start of a torn last record, which info->torn_bytes then counts), or -1
 * on a read error (errno set). */
static off_t replay(pgem_journal_t *journal, off_t file_size, const reader_t *reader,
                    pgem_journal_info_t *info)
{
    off_t offset = 0;
    uint64_t previous = NO_PREVIOUS;
    while (offset < file_size) {
        record_t record;
        int state = examine(journal, offset, file_size, previous, &record);
        if (state < 0) {
            return -1;
        }
        if (state == RECORD_WHOLE && record_taken(journal, &record, file_size, 0, reader)) {
            char channel[CHANNEL_MAX];
            memcpy(channel, journal->buffer, record.channel_length);
            channel[record.channel_length] = '\0';
            if (reader->on_record != NULL) {
                reader->on_record(reader->user, channel,
                                  journal->buffer + record.channel_length, record.data_length,
                                  record.utime);
            }
            uint32_t count = (uint32_t)(record.event >> 32);
            if (count >= journal->count) {
                journal->count = count < COUNT_MAX ? count + 1 : COUNT_MAX;
            }
            journal->records++;
            info->checked += record.checked;
            offset = record.end;
            previous = record.event;
            continue;
        }
        if (state == RECORD_WHOLE) {
            record.why = "its length does not lead to the next record";
        }
        /* Damage, or the torn tail: a torn tail has no record after it. */
        off_t next = resume_point(journal, offset, file_size, reader);
        if (next == -2) {
            return -1;
        }
        if (next < 0 && state == RECORD_TORN) {
            info->torn_bytes = file_size - offset;
            return offset;
        }
        if (next < 0) {
            next = file_size; /* damage at the end that is not a record's prefix: kept */
        }
        note_damage(info, offset, next, record.why);
        offset = next;
        previous = NO_PREVIOUS;
    }
    return file_size;
}

/* A file to take as a journal: empty, or starting with an LCM log record (or with a prefix of
 * one, which is a record torn by a kill before it was whole), or, its start damaged, holding a
 * record to resume at further in. Anything else (a g2o file given by mistake) is refused before
 * a byte of it is changed: the torn tail cut would otherwise empty it. 0, or -1 with the
 * message. */
static int journal_acceptable(pgem_journal_t *journal, off_t file_size, const reader_t *reader,
                              char *message, size_t message_size)
{
    if (file_size == 0) {
        return 0;
    }
    record_t record;
    int state = examine(journal, 0, file_size, NO_PREVIOUS, &record);
    off_t resume = -1;
    if (state == RECORD_TORN ||
        (state == RECORD_WHOLE && record_taken(journal, &record, file_size, 0, reader))) {
        return 0;
    }
    if (state >= 0) {
        resume = resume_point(journal, 0, file_size, reader);
    }
    if (state < 0 || resume == -2) {
        snprintf(message, message_size, "%s: cannot read the journal: %s", journal->path,
                 strerror(errno));
        return -1;
    }
    if (resume >= 0) {
        return 0; /* a damaged first record: skipped and reported like any other */
    }
    unsigned char head[4] = {0, 0, 0, 0};
    if (read_at(journal->fd, head, sizeof head, 0) < 0) {
        memset(head, 0, sizeof head);
    }
    snprintf(message, message_size,
             "%s is not an LCM log (its first bytes are not an LCM log record, %02x %02x %02x "
             "%02x...): refusing to use it as a journal, nothing was changed (give a new file "
             "name, or a journal or lcm-logger recording)",
             journal->path, head[0], head[1], head[2], head[3]);
    return -1;
}

/* ---- opening: one bridge per file, never through a symlink --------------------------------- */

static void describe_open_error(const char *path, char *message, size_t message_size)
{
    int saved = errno;
    struct stat st;
    if (saved == ELOOP && lstat(path, &st) == 0 && S_ISLNK(st.st_mode)) {
        char target[512];
        ssize_t length = readlink(path, target, sizeof target - 1);
        target[length > 0 ? length : 0] = '\0';
        snprintf(message, message_size,
                 "%s is a symbolic link (to '%s'): refusing to follow it for the journal (a "
                 "link swapped in would have the bridge replay, cut and append to another "
                 "file); give the journal's own path", path, target);
        return;
    }
    snprintf(message, message_size, "%s: cannot open the journal: %s", path, strerror(saved));
}

/* The lock: one process per journal. flock, not fcntl's record locks: a flock belongs to the
 * open file, so it holds against a second open in the same process too, and closing another
 * descriptor of the file does not drop it. */
static int journal_lock(const pgem_journal_t *journal, char *message, size_t message_size)
{
    while (flock(journal->fd, LOCK_EX | LOCK_NB) != 0) {
        if (errno == EINTR) {
            continue;
        }
        if (errno == EWOULDBLOCK) {
            snprintf(message, message_size,
                     "%s: the journal is locked by another process (is another pgem-lcm-bridge "
                     "running on it?): refusing to start, nothing was changed (two bridges on "
                     "one journal would mix their records)", journal->path);
        } else {
            snprintf(message, message_size, "%s: cannot lock the journal: %s", journal->path,
                     strerror(errno));
        }
        return -1;
    }
    return 0;
}

/* Remembers the file (to notice a rename, a deletion or a replacement) and its folder and
 * name (for pgem_journal_is_named). */
static void journal_identity(pgem_journal_t *journal, const struct stat *st)
{
    journal->dev = st->st_dev;
    journal->ino = st->st_ino;
    const char *slash = strrchr(journal->path, '/');
    journal->name = slash != NULL ? slash + 1 : journal->path;
    char folder[sizeof journal->path];
    if (slash == NULL) {
        snprintf(folder, sizeof folder, ".");
    } else {
        size_t length = slash == journal->path ? 1 : (size_t)(slash - journal->path);
        memcpy(folder, journal->path, length);
        folder[length] = '\0';
    }
    struct stat folder_st;
    if (stat(folder, &folder_st) == 0) {
        journal->folder_known = 1;
        journal->folder_dev = folder_st.st_dev;
        journal->folder_ino = folder_st.st_ino;
    }
}

pgem_journal_t *pgem_journal_open(const char *path, int sync, pgem_journal_record_fn on_record,
                                  pgem_journal_recognise_fn recognise, void *user,
                                  pgem_journal_info_t *info, char *message,
                                  size_t message_size)
{
    pgem_journal_info_t ignored;
    if (info == NULL) {
        info = &ignored;
    }
    memset(info, 0, sizeof *info);
    pgem_journal_t *journal = calloc(1, sizeof *journal);
    if (journal == NULL || strlen(path) >= sizeof journal->path) {
        snprintf(message, message_size, "%s: %s", path,
                 journal == NULL ? "out of memory" : "path too long");
        free(journal);
        return NULL;
    }
    snprintf(journal->path, sizeof journal->path, "%s", path);
    journal->sync = sync;
    journal->count = 1;
    journal->fd = open(path, O_RDWR | O_CREAT | O_NOFOLLOW | O_NOCTTY | O_CLOEXEC, 0644);
    if (journal->fd < 0) {
        describe_open_error(path, message, message_size);
        pgem_journal_close(journal);
        return NULL;
    }
    struct stat st;
    if (fstat(journal->fd, &st) != 0) {
        snprintf(message, message_size, "%s: cannot open the journal: %s", path, strerror(errno));
        pgem_journal_close(journal);
        return NULL;
    }
    if (!S_ISREG(st.st_mode)) {
        snprintf(message, message_size, "%s: not a regular file: refusing it as a journal",
                 path);
        pgem_journal_close(journal);
        return NULL;
    }
    if (journal_lock(journal, message, message_size) != 0) {
        pgem_journal_close(journal);
        return NULL;
    }
    journal_identity(journal, &st);
    reader_t reader = {on_record, recognise, user};
    if (journal_acceptable(journal, st.st_size, &reader, message, message_size) != 0) {
        pgem_journal_close(journal);
        return NULL;
    }
    off_t end = replay(journal, st.st_size, &reader, info);
    info->records = journal->records;
    if (end < 0) {
        snprintf(message, message_size, "%s: cannot read the journal: %s", path, strerror(errno));
        pgem_journal_close(journal);
        return NULL;
    }
    /* Only the torn tail goes: damage in the middle (or at the end, when it is not the prefix
     * of a record) stays, reported, and is skipped again by the next replay. */
    if (end < st.st_size && ftruncate(journal->fd, end) != 0) {
        snprintf(message, message_size, "%s: cannot cut the torn last record: %s", path,
                 strerror(errno));
        pgem_journal_close(journal);
        return NULL;
    }
    if (lseek(journal->fd, end, SEEK_SET) < 0) {
        snprintf(message, message_size, "%s: cannot seek: %s", path, strerror(errno));
        pgem_journal_close(journal);
        return NULL;
    }
    journal->end = end;
    return journal;
}

/* ---- appending ------------------------------------------------------------------------------ */

/* Whether the path still names the open journal and the file is `size` bytes long: 0, or -1
 * with what happened. */
static int journal_in_place(const pgem_journal_t *journal, off_t size, char *message,
                            size_t message_size)
{
    struct stat own;
    struct stat at;
    if (fstat(journal->fd, &own) != 0) {
        snprintf(message, message_size, "%s: cannot check the journal: %s", journal->path,
                 strerror(errno));
        return -1;
    }
    if (own.st_nlink == 0) {
        snprintf(message, message_size,
                 "%s was deleted (its records are in /proc/%ld/fd/%d: copy that to the path, "
                 "then restart)", journal->path, (long)getpid(), journal->fd);
        return -1;
    }
    if (own.st_size != size) {
        snprintf(message, message_size,
                 "%s changed behind the bridge's back (%lld bytes, it wrote %lld: truncated, or "
                 "written by another program): restart on the file that holds its records",
                 journal->path, (long long)own.st_size, (long long)size);
        return -1;
    }
    if (lstat(journal->path, &at) != 0) {
        if (errno == ENOENT) {
            snprintf(message, message_size,
                     "%s no longer names the journal (renamed or rotated away): put it back, "
                     "or restart on its new name", journal->path);
        } else {
            snprintf(message, message_size, "%s: cannot check the journal's path: %s",
                     journal->path, strerror(errno));
        }
        return -1;
    }
    if (S_ISLNK(at.st_mode)) {
        snprintf(message, message_size,
                 "%s is now a symbolic link, not the journal (not followed): put the journal "
                 "back", journal->path);
        return -1;
    }
    if (at.st_dev != journal->dev || at.st_ino != journal->ino) {
        snprintf(message, message_size,
                 "%s names another file now (the journal was renamed or replaced): put it "
                 "back, or restart on its new name", journal->path);
        return -1;
    }
    return 0;
}

int pgem_journal_check(pgem_journal_t *journal, char *message, size_t message_size)
{
    journal->away = journal_in_place(journal, journal->end, message, message_size) != 0;
    return journal->away ? -1 : 0;
}

int pgem_journal_is_named(const pgem_journal_t *journal, int dir, const char *name)
{
    struct stat st;
    if (fstatat(dir, name, &st, AT_SYMLINK_NOFOLLOW) == 0 && st.st_dev == journal->dev &&
        st.st_ino == journal->ino) {
        return 1;
    }
    return journal->folder_known && fstat(dir, &st) == 0 && st.st_dev == journal->folder_dev &&
           st.st_ino == journal->folder_ino && strcmp(name, journal->name) == 0;
}

/* Takes a record that did not make it back out of the file, so the journal holds exactly what
 * was acknowledged; when even that fails, no later append is trusted. */
static void journal_undo(pgem_journal_t *journal, off_t start, const char *why)
{
    if (start < 0 || ftruncate(journal->fd, start) != 0 || lseek(journal->fd, start, SEEK_SET) < 0) {
        snprintf(journal->broken, sizeof journal->broken,
                 "a failed record could not be taken back (%s; truncate: %s)", why,
                 strerror(errno));
    }
}

int pgem_journal_append(pgem_journal_t *journal, const char *channel, const void *data,
                        size_t size, int64_t utime, char *message, size_t message_size)
{
    if (journal->broken[0] != '\0') {
        snprintf(message, message_size, "%s: no more records since %s: restart the bridge "
                 "once the disk is sound", journal->path, journal->broken);
        return -1;
    }
    size_t channel_length = strlen(channel);
    if (channel_length == 0 || channel_length >= CHANNEL_MAX || size > PGEM_JOURNAL_RECORD_MAX) {
        snprintf(message, message_size, "%s: record too large for the journal", journal->path);
        return -1;
    }
    if (journal->away && pgem_journal_check(journal, message, message_size) != 0) {
        return -1; /* still away: nothing written where no restart looks */
    }
    size_t total = HEADER_BYTES + channel_length + size;
    if (reserve(journal, total) != 0) {
        snprintf(message, message_size, "%s: out of memory", journal->path);
        return -1;
    }
    unsigned char *p = journal->buffer;
    put_u32(p, SYNC_WORD);
    put_u32(p + 4, journal->count);
    put_u64(p + 12, (uint64_t)utime);
    put_u32(p + 20, (uint32_t)channel_length);
    put_u32(p + 24, (uint32_t)size);
    memcpy(p + HEADER_BYTES, channel, channel_length); // NOLINT(bugprone-not-null-terminated-result): LCM logs store the channel without its NUL
    memcpy(p + HEADER_BYTES + channel_length, data, size);
    put_u32(p + 8, record_crc(p, p + HEADER_BYTES, channel_length + size));
    off_t start = journal->end;
    size_t done = 0;
    while (done < total) {
        ssize_t wrote = write(journal->fd, p + done, total - done);
        if (wrote < 0 && errno == EINTR) {
            continue;
        }
        if (wrote <= 0) {
            const char *why = wrote < 0 ? strerror(errno) : "no progress";
            snprintf(message, message_size, "%s: write failed: %s", journal->path, why);
            journal_undo(journal, start, why); /* no partial record: the next append is clean */
            return -1;
        }
        done += (size_t)wrote;
    }
    if (journal->sync && fdatasync(journal->fd) != 0) {
        /* After a failed sync the kernel may have dropped the dirty pages: the disk's state is
         * unknown, so the record is taken back and no later one trusted. */
        const char *why = strerror(errno);
        snprintf(message, message_size, "%s: fdatasync failed: %s", journal->path, why);
        journal_undo(journal, start, why);
        if (journal->broken[0] == '\0') {
            snprintf(journal->broken, sizeof journal->broken, "fdatasync failed (%s)", why);
        }
        return -1;
    }
    /* Acknowledged only if the path still names the file (checked after the write, so a
     * rename before it or during it is seen): else the record is taken back out of the file
     * it went to, when nothing else was written there since, and refused. */
    off_t end = start + (off_t)total;
    if (journal_in_place(journal, end, message, message_size) != 0) {
        struct stat own;
        if (fstat(journal->fd, &own) == 0 && own.st_size == end) {
            journal_undo(journal, start, "the journal moved");
        }
        journal->away = 1;
        return -1;
    }
    journal->end = end;
    journal->records++;
    if (journal->count < COUNT_MAX) {
        journal->count++;
    }
    return 0;
}

int64_t pgem_journal_records(const pgem_journal_t *journal)
{
    return journal->records;
}

void pgem_journal_close(pgem_journal_t *journal)
{
    if (journal != NULL) {
        if (journal->fd >= 0) {
            close(journal->fd); /* releases the lock */
        }
        free(journal->buffer);
        free(journal);
    }
}
