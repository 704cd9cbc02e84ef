/* The journal: LCM log records (big-endian): sync word 0xEDA1DA01, event number (int64),
 * timestamp in microseconds (int64), channel length (int32), data length (int32), channel
 * bytes, data bytes. */
#define _POSIX_C_SOURCE 200809L
#include "journal.h"

#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#define SYNC_WORD 0xEDA1DA01u
#define HEADER_BYTES 28
#define CHANNEL_MAX 256

struct pgem_journal {
    int fd;
    int sync;
    char broken[256];       /* why appends stopped for good ("" while they work) */
    int64_t records;
    int64_t next_event;
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

/* Makes room for a record of `size` bytes. */
static int reserve(pgem_journal_t *journal, size_t size)
{
    if (size <= journal->buffer_size) {
        return 0;
    }
    unsigned char *grown = realloc(journal->buffer, size);
    if (grown == NULL) {
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

/* A plausible record header at offset: 1 if whole, 0 if it runs past the end, -1 if damaged. */
static int header_at(const unsigned char *header, off_t offset, off_t file_size,
                     uint32_t *channel_length, uint32_t *data_length)
{
    if (get_u32(header) != SYNC_WORD) {
        return -1;
    }
    *channel_length = get_u32(header + 20);
    *data_length = get_u32(header + 24);
    if (*channel_length == 0 || *channel_length >= CHANNEL_MAX ||
        *data_length > PGEM_JOURNAL_RECORD_MAX) {
        return -1;
    }
    off_t end = offset + HEADER_BYTES + (off_t)*channel_length + (off_t)*data_length;
    return end <= file_size ? 1 : 0;
}

/* The offset of the next sync word after `offset`, or file_size. */
static off_t resync(int fd, off_t offset, off_t file_size)
{
    unsigned char window[4096];
    for (off_t at = offset + 1; at < file_size; at += (off_t)sizeof window - 3) {
        ssize_t got = read_at(fd, window, sizeof window, at);
        if (got < 4) {
            break;
        }
        for (ssize_t i = 0; i + 4 <= got; ++i) {
            if (get_u32(window + i) == SYNC_WORD) {
                return at + i;
            }
        }
    }
    return file_size;
}

/* Replays every whole record; returns the offset after the last one, or -1 on a read error. */
static off_t replay(pgem_journal_t *journal, off_t file_size, pgem_journal_record_fn on_record,
                    void *user, pgem_journal_info_t *info)
{
    off_t offset = 0;
    off_t good_end = 0;
    while (offset < file_size) {
        unsigned char header[HEADER_BYTES];
        ssize_t got = read_at(journal->fd, header, sizeof header, offset);
        if (got < 0) {
            return -1;
        }
        if (got < HEADER_BYTES) {
            break; /* torn header */
        }
        uint32_t channel_length = 0;
        uint32_t data_length = 0;
        int state = header_at(header, offset, file_size, &channel_length, &data_length);
        if (state == 0) {
            break; /* torn body */
        }
        if (state < 0) {
            off_t next = resync(journal->fd, offset, file_size);
            info->skipped_bytes += next - offset;
            offset = next;
            continue;
        }
        size_t body = (size_t)channel_length + data_length;
        if (reserve(journal, body + 1) != 0 ||
            read_at(journal->fd, journal->buffer, body, offset + HEADER_BYTES) != (ssize_t)body) {
            return -1;
        }
        char channel[CHANNEL_MAX];
        memcpy(channel, journal->buffer, channel_length);
        channel[channel_length] = '\0';
        int64_t event = (int64_t)get_u64(header + 4);
        int64_t utime = (int64_t)get_u64(header + 12);
        if (on_record != NULL) {
            on_record(user, channel, journal->buffer + channel_length, data_length, utime);
        }
        journal->records++;
        journal->next_event = event + 1;
        offset += HEADER_BYTES + (off_t)body;
        good_end = offset;
    }
    info->records = journal->records;
    return good_end;
}

/* A file to take as a journal: a regular file, empty or starting with an LCM log record (or
 * with a prefix of one, which is a record torn by a kill before it was whole). Anything else
 * (a g2o file given by mistake, a device) is refused before a byte of it is changed: the torn
 * tail cut would otherwise empty it. 0, or -1 with the message. */
static int journal_acceptable(const pgem_journal_t *journal, const struct stat *st,
                              char *message, size_t message_size)
{
    unsigned char head[HEADER_BYTES];
    uint32_t channel_length = 0;
    uint32_t data_length = 0;
    if (!S_ISREG(st->st_mode)) {
        snprintf(message, message_size, "%s: not a regular file: refusing it as a journal",
                 journal->path);
        return -1;
    }
    if (st->st_size == 0) {
        return 0;
    }
    ssize_t got = read_at(journal->fd, head, sizeof head, 0);
    if (got < 0) {
        snprintf(message, message_size, "%s: cannot read the journal: %s", journal->path,
                 strerror(errno));
        return -1;
    }
    static const unsigned char sync_word[4] = {0xED, 0xA1, 0xDA, 0x01};
    size_t compared = got < 4 ? (size_t)got : 4;
    int damaged = memcmp(head, sync_word, compared) != 0 ||
                  (got == HEADER_BYTES &&
                   header_at(head, 0, st->st_size, &channel_length, &data_length) < 0);
    if (damaged) {
        snprintf(message, message_size,
                 "%s is not an LCM log (its first bytes are not an LCM log record, %02x %02x "
                 "%02x %02x...): refusing to use it as a journal, nothing was changed (give a "
                 "new file name, or a journal or lcm-logger recording)", journal->path,
                 got > 0 ? head[0] : 0u, got > 1 ? head[1] : 0u, got > 2 ? head[2] : 0u,
                 got > 3 ? head[3] : 0u);
        return -1;
    }
    return 0;
}

pgem_journal_t *pgem_journal_open(const char *path, int sync, pgem_journal_record_fn on_record,
                                  void *user, pgem_journal_info_t *info, char *message,
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
    journal->fd = open(path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    struct stat st;
    if (journal->fd < 0 || fstat(journal->fd, &st) != 0) {
        snprintf(message, message_size, "%s: cannot open the journal: %s", path, strerror(errno));
        pgem_journal_close(journal);
        return NULL;
    }
    if (journal_acceptable(journal, &st, message, message_size) != 0) {
        pgem_journal_close(journal);
        return NULL;
    }
    off_t end = replay(journal, st.st_size, on_record, user, info);
    if (end < 0) {
        snprintf(message, message_size, "%s: cannot read the journal: %s", path, strerror(errno));
        pgem_journal_close(journal);
        return NULL;
    }
    /* The damaged tail goes (the skipped middle stays: it is reported, and a later reader
     * resynchronises on the sync word as LCM's own reader does). */
    info->torn_bytes = st.st_size - end;
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
    return journal;
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
    size_t total = HEADER_BYTES + channel_length + size;
    if (reserve(journal, total) != 0) {
        snprintf(message, message_size, "%s: out of memory", journal->path);
        return -1;
    }
    unsigned char *p = journal->buffer;
    put_u32(p, SYNC_WORD);
    put_u64(p + 4, (uint64_t)journal->next_event);
    put_u64(p + 12, (uint64_t)utime);
    put_u32(p + 20, (uint32_t)channel_length);
    put_u32(p + 24, (uint32_t)size);
    memcpy(p + HEADER_BYTES, channel, channel_length); // NOLINT(bugprone-not-null-terminated-result): LCM logs store the channel without its NUL
    memcpy(p + HEADER_BYTES + channel_length, data, size);
    off_t start = lseek(journal->fd, 0, SEEK_CUR);
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
    journal->records++;
    journal->next_event++;
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
            close(journal->fd);
        }
        free(journal->buffer);
        free(journal);
    }
}
