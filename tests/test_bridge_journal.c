/* The bridge's journal: round trip, torn tails, damage, files that are not journals, failed
 * appends taken back, and compatibility both ways with LCM's own log reader and writer
 * (lcm-logger / lcm-logplayer's format). */
#define _POSIX_C_SOURCE 200809L
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <signal.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>
#include <fcntl.h>

#include <cmocka.h>
#include <lcm/eventlog.h>
#include <pthread.h>
#include <time.h>

#include "bridge.h"
#include "journal.h"
#include "pgem_edge2_t.h"
#include "pgem_pose2_t.h"
#include "pgem_status_t.h"

#define RECORDS 50

typedef struct seen {
    int count;
    char channel[RECORDS * 2][64];
    unsigned char data[RECORDS * 2][64];
    size_t size[RECORDS * 2];
    int64_t utime[RECORDS * 2];
} seen_t;

static void collect(void *user, const char *channel, const void *data, size_t size,
                    int64_t utime)
{
    seen_t *seen = user;
    assert_true(seen->count < RECORDS * 2 && size <= 64);
    snprintf(seen->channel[seen->count], 64, "%s", channel);
    memcpy(seen->data[seen->count], data, size);
    seen->size[seen->count] = size;
    seen->utime[seen->count] = utime;
    seen->count++;
}

static void path_for(char *path, size_t size, const char *name)
{
    const char *dir = getenv("PGEM_TEST_TMP");
    snprintf(path, size, "%s/%s", dir != NULL ? dir : "/tmp", name);
    remove(path);
}

/* Record i: channel "CH<i%3>", i+1 bytes of value i, utime 1000 + i. */
static void append_records(pgem_journal_t *journal, int first, int count)
{
    char message[256];
    for (int i = first; i < first + count; ++i) {
        unsigned char data[64];
        memset(data, i, sizeof data);
        char channel[16];
        snprintf(channel, sizeof channel, "CH%d", i % 3);
        assert_int_equal(pgem_journal_append(journal, channel, data, (size_t)(i % 60) + 1,
                                             1000 + i, message, sizeof message),
                         0);
    }
}

static void expect_records(const seen_t *seen, int count)
{
    assert_int_equal(seen->count, count);
    for (int i = 0; i < count; ++i) {
        char channel[16];
        snprintf(channel, sizeof channel, "CH%d", i % 3);
        assert_string_equal(seen->channel[i], channel);
        assert_int_equal(seen->size[i], (size_t)(i % 60) + 1);
        assert_int_equal(seen->data[i][0], (unsigned char)i);
        assert_int_equal(seen->utime[i], 1000 + i);
    }
}

static void put_be(unsigned char *p, uint64_t value, int bytes)
{
    for (int i = bytes - 1; i >= 0; --i) {
        p[i] = (unsigned char)(value & 0xFF);
        value >>= 8;
    }
}

/* CRC-32 as zlib computes it, one bit at a time (the journal's is table-driven). */
static uint32_t crc32_bitwise(uint32_t crc, const void *data, size_t size)
{
    const unsigned char *p = data;
    crc = ~crc;
    for (size_t i = 0; i < size; ++i) {
        crc ^= p[i];
        for (int bit = 0; bit < 8; ++bit) {
            crc = (crc >> 1) ^ ((crc & 1u) != 0 ? 0xEDB88320u : 0u);
        }
    }
    return ~crc;
}

static pgem_journal_t *reopen(const char *path, seen_t *seen, pgem_journal_info_t *info)
{
    char message[256];
    memset(seen, 0, sizeof *seen);
    pgem_journal_t *journal = pgem_journal_open(path, 0, collect, NULL, seen, info, message,
                                                sizeof message);
    assert_non_null(journal);
    return journal;
}

static void test_round_trip(void **state)
{
    (void)state;
    char path[512];
    path_for(path, sizeof path, "journal_round_trip.lcmlog");
    seen_t seen;
    pgem_journal_info_t info;
    pgem_journal_t *journal = reopen(path, &seen, &info);
    assert_int_equal(info.records, 0);
    append_records(journal, 0, RECORDS);
    pgem_journal_close(journal);
    journal = reopen(path, &seen, &info);
    expect_records(&seen, RECORDS);
    assert_int_equal(info.torn_bytes, 0);
    /* appends continue after a reopen */
    append_records(journal, RECORDS, 10);
    assert_int_equal(pgem_journal_records(journal), RECORDS + 10);
    pgem_journal_close(journal);
    journal = reopen(path, &seen, &info);
    expect_records(&seen, RECORDS + 10);
    pgem_journal_close(journal);
}

static void test_torn_tail_is_cut(void **state)
{
    (void)state;
    char path[512];
    path_for(path, sizeof path, "journal_torn.lcmlog");
    seen_t seen;
    pgem_journal_info_t info;
    pgem_journal_t *journal = reopen(path, &seen, &info);
    append_records(journal, 0, RECORDS);
    pgem_journal_close(journal);
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    /* every cut inside the last record loses only that record */
    off_t last_size = 28 + 3 + (off_t)((RECORDS - 1) % 60) + 1; /* header, "CHn", data */
    for (off_t cut = 1; cut < last_size; cut += 7) {
        char copy[512];
        path_for(copy, sizeof copy, "journal_torn_copy.lcmlog");
        FILE *in = fopen(path, "rb");
        FILE *out = fopen(copy, "wb");
        assert_non_null(in);
        assert_non_null(out);
        for (off_t k = 0; k < st.st_size - cut; ++k) {
            fputc(fgetc(in), out);
        }
        fclose(in);
        fclose(out);
        journal = reopen(copy, &seen, &info);
        expect_records(&seen, RECORDS - 1);
        assert_int_equal(info.torn_bytes, last_size - cut);
        /* the next record lands where the torn one was */
        append_records(journal, RECORDS - 1, 1);
        pgem_journal_close(journal);
        journal = reopen(copy, &seen, &info);
        expect_records(&seen, RECORDS);
        assert_int_equal(info.torn_bytes, 0);
        pgem_journal_close(journal);
    }
}

static void test_damage_is_skipped_and_reported(void **state)
{
    (void)state;
    char path[512];
    path_for(path, sizeof path, "journal_damage.lcmlog");
    seen_t seen;
    pgem_journal_info_t info;
    pgem_journal_t *journal = reopen(path, &seen, &info);
    append_records(journal, 0, 3);
    pgem_journal_close(journal);
    FILE *file = fopen(path, "r+b");
    assert_non_null(file);
    fseek(file, 28 + 3 + 1, SEEK_SET);
    fputc(0x00, file); /* break the second record's sync word */
    fclose(file);
    journal = reopen(path, &seen, &info);
    assert_int_equal(seen.count, 2);
    assert_int_equal(seen.utime[0], 1000);
    assert_int_equal(seen.utime[1], 1002);
    assert_int_equal(info.skipped, 1);
    assert_int_equal(info.damage[0].start, 28 + 3 + 1);
    assert_int_equal(info.damage[0].end, 2 * (28 + 3) + 1 + 2);
    assert_int_equal(info.skipped_bytes, 28 + 3 + 2);
    assert_string_equal(info.damage[0].why, "no sync word");
    pgem_journal_close(journal);
}

static off_t file_size(const char *path)
{
    struct stat st;
    assert_int_equal(stat(path, &st), 0);
    return st.st_size;
}

/* Issue 17: `--journal some.g2o` emptied the file ("cut 171 bytes of a torn last record") and
 * started. A file that is not empty and does not start with an LCM log record, or is not a
 * regular file, is refused, and not a byte of it changes. A prefix of a record (the first one,
 * torn by a kill) is still a journal. */
static void test_not_a_journal_is_refused(void **state)
{
    (void)state;
    char path[512];
    char message[512];
    path_for(path, sizeof path, "journal_not_a_log.g2o");
    const char text[] = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";
    FILE *file = fopen(path, "wb");
    assert_non_null(file);
    fputs(text, file);
    fclose(file);
    pgem_journal_t *journal = pgem_journal_open(path, 0, NULL, NULL, NULL, NULL, message,
                                                sizeof message);
    assert_null(journal);
    assert_non_null(strstr(message, "journal_not_a_log.g2o is not an LCM log (its first bytes "
                                    "are not an LCM log record, 56 45 52 54...): refusing to use "
                                    "it as a journal, nothing was changed"));
    assert_int_equal(file_size(path), (off_t)(sizeof text - 1));
    /* the sync word, then a header no LCM log has (a channel of 2^31 bytes) */
    static const unsigned char lying[28] = {0xED, 0xA1, 0xDA, 0x01, 0, 0, 0, 0, 0, 0, 0, 0,
                                            0, 0, 0, 0, 0, 0, 0, 0, 0x80, 0, 0, 0, 0, 0, 0, 1};
    file = fopen(path, "wb");
    fwrite(lying, 1, sizeof lying, file);
    fputs(text, file);
    fclose(file);
    assert_null(pgem_journal_open(path, 0, NULL, NULL, NULL, NULL, message, sizeof message));
    assert_non_null(strstr(message, "is not an LCM log"));
    assert_int_equal(file_size(path), (off_t)(sizeof lying + sizeof text - 1));
    /* a folder and a device */
    const char *dir = getenv("PGEM_TEST_TMP");
    assert_null(pgem_journal_open(dir != NULL ? dir : "/tmp", 0, NULL, NULL, NULL, NULL,
                                  message, sizeof message));
    assert_null(pgem_journal_open("/dev/null", 0, NULL, NULL, NULL, NULL, message,
                                  sizeof message));
    assert_non_null(strstr(message, "/dev/null: not a regular file"));
    /* three bytes of a sync word: the first record, torn; cut, and the journal starts */
    file = fopen(path, "wb");
    fwrite(lying, 1, 3, file);
    fclose(file);
    seen_t seen;
    pgem_journal_info_t info;
    journal = reopen(path, &seen, &info);
    assert_int_equal(info.torn_bytes, 3);
    assert_int_equal(seen.count, 0);
    pgem_journal_close(journal);
    assert_int_equal(file_size(path), 0);
    remove(path);
}

/* Issue 17: on a full disk the bridge acknowledged edges its journal did not hold. An append
 * that fails (here past a file size limit, as a full disk fails it) leaves no part of its
 * record in the file, says why, and the next append succeeds once there is room. */
static void test_failed_append_is_taken_back(void **state)
{
    (void)state;
    char path[512];
    char message[256];
    path_for(path, sizeof path, "journal_full.lcmlog");
    seen_t seen;
    pgem_journal_info_t info;
    pgem_journal_t *journal = reopen(path, &seen, &info);
    append_records(journal, 0, 5);
    off_t whole = file_size(path);
    struct rlimit saved;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &saved), 0);
    struct rlimit small = saved;
    small.rlim_cur = (rlim_t)whole + 40; /* room for part of the next record only */
    void (*previous)(int) = signal(SIGXFSZ, SIG_IGN);
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &small), 0);
    unsigned char data[64];
    memset(data, 5, sizeof data);
    int failed = pgem_journal_append(journal, "CH2", data, 60, 1005, message, sizeof message);
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &saved), 0);
    signal(SIGXFSZ, previous);
    assert_int_equal(failed, -1);
    assert_non_null(strstr(message, "journal_full.lcmlog: write failed: File too large"));
    assert_int_equal(file_size(path), whole);
    assert_int_equal(pgem_journal_records(journal), 5);
    append_records(journal, 5, 1); /* room again */
    pgem_journal_close(journal);
    journal = reopen(path, &seen, &info);
    expect_records(&seen, 6);
    assert_int_equal(info.torn_bytes, 0);
    pgem_journal_close(journal);
    remove(path);
}

static void test_lcm_reads_the_journal(void **state)
{
    (void)state;
    char path[512];
    path_for(path, sizeof path, "journal_for_lcm.lcmlog");
    seen_t seen;
    pgem_journal_t *journal = reopen(path, &seen, NULL);
    append_records(journal, 0, RECORDS);
    pgem_journal_close(journal);
    lcm_eventlog_t *log = lcm_eventlog_create(path, "r");
    assert_non_null(log);
    int count = 0;
    lcm_eventlog_event_t *event;
    while ((event = lcm_eventlog_read_next_event(log)) != NULL) {
        char channel[16];
        snprintf(channel, sizeof channel, "CH%d", count % 3);
        /* the event number: the record's count from 1, then its CRC-32 (checked here by a
         * bit-by-bit CRC over the record as LCM read it) */
        assert_int_equal(event->eventnum >> 32, count + 1);
        unsigned char header[28];
        put_be(header, 0xEDA1DA01u, 4);
        put_be(header + 4, (uint64_t)event->eventnum >> 32, 4);
        put_be(header + 12, (uint64_t)event->timestamp, 8);
        put_be(header + 20, (uint64_t)event->channellen, 4);
        put_be(header + 24, (uint64_t)event->datalen, 4);
        uint32_t crc = crc32_bitwise(0, header, 8);
        crc = crc32_bitwise(crc, header + 12, 16);
        crc = crc32_bitwise(crc, event->channel, (size_t)event->channellen);
        crc = crc32_bitwise(crc, event->data, (size_t)event->datalen);
        assert_int_equal(event->eventnum & 0xFFFFFFFF, crc);
        assert_int_equal(event->timestamp, 1000 + count);
        assert_int_equal(event->channellen, (int32_t)strlen(channel));
        assert_memory_equal(event->channel, channel, strlen(channel));
        assert_int_equal(event->datalen, count % 60 + 1);
        assert_int_equal(((unsigned char *)event->data)[0], (unsigned char)count);
        lcm_eventlog_free_event(event);
        count++;
    }
    lcm_eventlog_destroy(log);
    assert_int_equal(count, RECORDS);
}

static void test_journal_reads_lcm_logs(void **state)
{
    (void)state;
    char path[512];
    path_for(path, sizeof path, "lcm_written.lcmlog");
    lcm_eventlog_t *log = lcm_eventlog_create(path, "w");
    assert_non_null(log);
    for (int i = 0; i < RECORDS; ++i) {
        unsigned char data[64];
        memset(data, i, sizeof data);
        char channel[16];
        snprintf(channel, sizeof channel, "CH%d", i % 3);
        lcm_eventlog_event_t event;
        event.eventnum = i;
        event.timestamp = 1000 + i;
        event.channellen = (int32_t)strlen(channel);
        event.datalen = i % 60 + 1;
        event.channel = channel;
        event.data = data;
        assert_int_equal(lcm_eventlog_write_event(log, &event), 0);
    }
    lcm_eventlog_destroy(log);
    seen_t seen;
    pgem_journal_info_t info;
    pgem_journal_t *journal = reopen(path, &seen, &info);
    expect_records(&seen, RECORDS);
    pgem_journal_close(journal);
}

static void test_open_errors(void **state)
{
    (void)state;
    char message[256] = "";
    pgem_journal_t *journal = pgem_journal_open("/nonexistent-dir/j.lcmlog", 0, NULL, NULL, NULL,
                                                NULL, message, sizeof message);
    assert_null(journal);
    assert_non_null(strstr(message, "/nonexistent-dir/j.lcmlog"));
}

/* ---- damage in the middle, the lock, a moved or swapped journal (issue 31) --------------- */

#define SWEEP_RECORDS 60

static unsigned char *slurp(const char *path, size_t *size)
{
    FILE *file = fopen(path, "rb");
    assert_non_null(file);
    assert_int_equal(fseek(file, 0, SEEK_END), 0);
    long length = ftell(file);
    assert_true(length >= 0);
    rewind(file);
    unsigned char *bytes = malloc((size_t)length + 1);
    assert_non_null(bytes);
    assert_int_equal(fread(bytes, 1, (size_t)length, file), (size_t)length);
    fclose(file);
    *size = (size_t)length;
    return bytes;
}

static void spill(const char *path, const unsigned char *bytes, size_t size)
{
    FILE *file = fopen(path, "wb");
    assert_non_null(file);
    assert_int_equal(fwrite(bytes, 1, size, file), size);
    assert_int_equal(fclose(file), 0);
}

/* Where record i of append_records' journal starts (header, "CHn", i % 60 + 1 data bytes). */
static off_t record_offset(int i)
{
    off_t offset = 0;
    for (int k = 0; k < i; ++k) {
        offset += 28 + 3 + k % 60 + 1;
    }
    return offset;
}

/* Records 0..count-1 as lcm-logger writes them (LCM's own writer: event numbers from 0, no
 * checksum), the records append_records writes. */
static void write_lcm_log(const char *path, int count)
{
    remove(path);
    lcm_eventlog_t *log = lcm_eventlog_create(path, "w");
    assert_non_null(log);
    for (int i = 0; i < count; ++i) {
        unsigned char data[64];
        memset(data, i, sizeof data);
        char channel[16];
        snprintf(channel, sizeof channel, "CH%d", i % 3);
        lcm_eventlog_event_t event;
        event.eventnum = i;
        event.timestamp = 1000 + i;
        event.channellen = (int32_t)strlen(channel);
        event.datalen = i % 60 + 1;
        event.channel = channel;
        event.data = data;
        assert_int_equal(lcm_eventlog_write_event(log, &event), 0);
    }
    lcm_eventlog_destroy(log);
}

/* The test records' "message type": channel CH<i % 3>, i % 60 + 1 bytes of value i. */
static int recognise_test_record(void *user, const char *channel, const void *data, size_t size)
{
    (void)user;
    const unsigned char *bytes = data;
    if (size == 0 || size != (size_t)(bytes[0] % 60) + 1) {
        return 0;
    }
    for (size_t k = 1; k < size; ++k) {
        if (bytes[k] != bytes[0]) {
            return 0;
        }
    }
    char expected[16];
    snprintf(expected, sizeof expected, "CH%d", bytes[0] % 3);
    return strcmp(channel, expected) == 0;
}

/* seen holds records 0..count-1 but (perhaps) `damaged`; returns 1 if that one is there. Every
 * record is whole and in order; the damaged one, when there, has its channel and data. */
static int expect_all_but(const seen_t *seen, int count, int damaged)
{
    int there = seen->count == count;
    if (!there) {
        assert_int_equal(seen->count, count - 1);
    }
    for (int j = 0; j < seen->count; ++j) {
        int i = there || j < damaged ? j : j + 1;
        char channel[16];
        snprintf(channel, sizeof channel, "CH%d", i % 3);
        assert_string_equal(seen->channel[j], channel);
        assert_int_equal(seen->size[j], (size_t)(i % 60) + 1);
        for (size_t k = 0; k < seen->size[j]; ++k) {
            assert_int_equal(seen->data[j][k], (unsigned char)i);
        }
        if (i != damaged) {
            assert_int_equal(seen->utime[j], 1000 + i);
        }
    }
    return there;
}

/* Damages byte `at` of the clean journal into `copy` by pattern p; 0 if the byte stays. */
static int damage(const unsigned char *clean, size_t size, size_t at, int p, const char *copy)
{
    unsigned char *bytes = malloc(size);
    assert_non_null(bytes);
    memcpy(bytes, clean, size);
    static const int xors[] = {0x01, 0x80, 0xFF};
    bytes[at] = p < 3 ? (unsigned char)(bytes[at] ^ xors[p]) : p == 3 ? 0x00 : 0xFF;
    int changed = bytes[at] != clean[at];
    spill(copy, bytes, size);
    free(bytes);
    return changed;
}

/* Damage to one record of the journal: every byte of its header five ways (flip the lowest
 * bit, the highest, all; set 0x00, 0xFF) and, in a journal with checksums, every byte of its
 * channel and data one way (without a checksum nothing can tell a changed payload byte).
 * Each must lose at most that record: the others replay, whole and in order; the damaged one
 * is skipped (reported at exactly its offsets) or replays with its channel and data as
 * written (a header byte nothing checks without a checksum: the event number, a timestamp);
 * no byte of the file changes; appends go after it and replay next time. */
static void damage_sweep(int checked, int damaged)
{
    char path[512];
    char copy[512];
    path_for(path, sizeof path, checked ? "journal_sweep.lcmlog" : "journal_sweep_lcm.lcmlog");
    path_for(copy, sizeof copy, "journal_sweep_copy.lcmlog");
    seen_t seen;
    pgem_journal_info_t info;
    char message[256];
    if (checked) {
        pgem_journal_t *journal = reopen(path, &seen, &info);
        append_records(journal, 0, SWEEP_RECORDS);
        pgem_journal_close(journal);
    } else {
        write_lcm_log(path, SWEEP_RECORDS);
    }
    size_t size = 0;
    unsigned char *clean = slurp(path, &size);
    assert_int_equal(size, (size_t)record_offset(SWEEP_RECORDS));
    const size_t start = (size_t)record_offset(damaged);
    const size_t end = (size_t)record_offset(damaged + 1);
    int skipped = 0;
    int kept = 0;
    for (size_t at = start; at < (checked ? end : start + 28); ++at) {
        for (int p = 0; p < (at < start + 28 ? 5 : 1); ++p) {
            if (!damage(clean, size, at, p, copy)) {
                continue;
            }
            size_t before_size = 0;
            unsigned char *before = slurp(copy, &before_size);
            memset(&seen, 0, sizeof seen);
            pgem_journal_t *journal =
                pgem_journal_open(copy, 0, collect, recognise_test_record, &seen, &info,
                                  message, sizeof message);
            if (journal == NULL) {
                fail_msg("byte %zu, pattern %d: %s", at - start, p, message);
            }
            int there = expect_all_but(&seen, SWEEP_RECORDS, damaged);
            assert_int_equal(info.torn_bytes, 0);
            if (there) {
                kept++;
                assert_int_equal(info.skipped, 0);
            } else {
                skipped++;
                assert_int_equal(info.skipped, 1);
                assert_int_equal(info.damage[0].start, (int64_t)start);
                assert_int_equal(info.damage[0].end, (int64_t)end);
                assert_int_equal(info.skipped_bytes, (int64_t)(end - start));
            }
            size_t after_size = 0;
            unsigned char *after = slurp(copy, &after_size);
            assert_int_equal(after_size, before_size);
            assert_memory_equal(after, before, before_size);
            free(after);
            free(before);
            /* the next record goes after the last one, and the damage is still skipped */
            append_records(journal, SWEEP_RECORDS, 1);
            pgem_journal_close(journal);
            memset(&seen, 0, sizeof seen);
            journal = pgem_journal_open(copy, 0, collect, recognise_test_record, &seen, &info,
                                        message, sizeof message);
            assert_non_null(journal);
            assert_int_equal(seen.count, SWEEP_RECORDS + there);
            assert_int_equal(seen.data[seen.count - 1][0], SWEEP_RECORDS);
            assert_int_equal(info.skipped, !there);
            pgem_journal_close(journal);
        }
    }
    print_message("%s journal, record %d of %d damaged: %d ways skipped it alone, %d left it "
                  "whole\n", checked ? "checksummed" : "lcm-logger", damaged, SWEEP_RECORDS,
                  skipped, kept);
    assert_true(skipped > 0);
    free(clean);
    remove(copy);
    remove(path);
}

static void test_damage_sweep_checksummed(void **state)
{
    (void)state;
    damage_sweep(1, SWEEP_RECORDS / 2);
    damage_sweep(1, 0); /* the first record */
}

static void test_damage_sweep_lcm_logger(void **state)
{
    (void)state;
    damage_sweep(0, SWEEP_RECORDS / 2);
}

typedef struct tally {
    int64_t count;
    int64_t last_utime;
    int out_of_order;
} tally_t;

static void count_record(void *user, const char *channel, const void *data, size_t size,
                         int64_t utime)
{
    (void)channel;
    (void)data;
    (void)size;
    tally_t *tally = user;
    tally->out_of_order += utime <= tally->last_utime;
    tally->last_utime = utime;
    tally->count++;
}

/* Issue 31, as measured: one damaged length byte in record 200 of a 3999-record journal was
 * taken for a torn last record ("cut 478706 bytes"): 95 % of the acknowledged records gone.
 * Now that record alone is skipped, and the file keeps every byte. */
static void test_bad_length_is_not_a_torn_tail(void **state)
{
    (void)state;
    char path[512];
    char message[256];
    for (int checked = 1; checked >= 0; --checked) {
        path_for(path, sizeof path, "journal_3999.lcmlog");
        if (checked) {
            pgem_journal_t *journal = pgem_journal_open(path, 0, NULL, NULL, NULL, NULL, message,
                                                        sizeof message);
            assert_non_null(journal);
            append_records(journal, 0, 3999);
            pgem_journal_close(journal);
        } else {
            write_lcm_log(path, 3999);
        }
        size_t size = 0;
        unsigned char *bytes = slurp(path, &size);
        size_t at = (size_t)record_offset(200);
        bytes[at + 25] = 0x07; /* the data length grows by 458752 bytes: past the end */
        spill(path, bytes, size);
        tally_t tally = {0, 0, 0};
        pgem_journal_info_t info;
        pgem_journal_t *journal = pgem_journal_open(path, 0, count_record,
                                                    recognise_test_record, &tally, &info,
                                                    message, sizeof message);
        assert_non_null(journal);
        pgem_journal_close(journal);
        assert_int_equal(tally.count, 3998);
        assert_int_equal(tally.out_of_order, 0);
        assert_int_equal(info.records, 3998);
        assert_int_equal(info.torn_bytes, 0);
        assert_int_equal(info.skipped, 1);
        assert_int_equal(info.damage[0].start, (int64_t)at);
        assert_int_equal(info.damage[0].end, (int64_t)record_offset(201));
        assert_int_equal(file_size(path), (off_t)size);
        free(bytes);
        remove(path);
    }
}

/* The last record damaged: a checksum that fails leaves it in place, skipped (it is whole: no
 * torn tail), and the next record goes after it; a length that runs past the end is what a
 * torn record looks like, and is cut. Either way one record is lost. */
static void test_damaged_last_record(void **state)
{
    (void)state;
    char path[512];
    seen_t seen;
    pgem_journal_info_t info;
    path_for(path, sizeof path, "journal_last.lcmlog");
    pgem_journal_t *journal = reopen(path, &seen, &info);
    append_records(journal, 0, 10);
    pgem_journal_close(journal);
    size_t size = 0;
    unsigned char *bytes = slurp(path, &size);
    const off_t last = record_offset(9);
    bytes[size - 1] ^= 0x01; /* its last data byte */
    spill(path, bytes, size);
    journal = reopen(path, &seen, &info);
    expect_records(&seen, 9);
    assert_int_equal(info.skipped, 1);
    assert_int_equal(info.damage[0].start, last);
    assert_int_equal(info.damage[0].end, (int64_t)size);
    assert_string_equal(info.damage[0].why, "checksum mismatch");
    assert_int_equal(info.torn_bytes, 0);
    assert_int_equal(file_size(path), (off_t)size);
    append_records(journal, 9, 1);
    pgem_journal_close(journal);
    journal = reopen(path, &seen, &info);
    expect_records(&seen, 10);
    assert_int_equal(info.skipped, 1);
    pgem_journal_close(journal);
    /* a data length past the end of the file: cut as a torn record */
    bytes[size - 1] ^= 0x01;
    bytes[last + 26] = 0x01;
    spill(path, bytes, size);
    journal = reopen(path, &seen, &info);
    expect_records(&seen, 9);
    assert_int_equal(info.torn_bytes, (int64_t)size - last);
    assert_int_equal(info.skipped, 0);
    assert_int_equal(file_size(path), last);
    pgem_journal_close(journal);
    free(bytes);
    remove(path);
}

/* Issue 31: two bridges on one --journal both ran; after a restart one's acknowledged edges
 * were gone and the other's poses mixed in. The journal is locked while open: a second open
 * (another process, or this one) is refused, naming the file, and changes nothing. */
static void test_second_open_is_refused(void **state)
{
    (void)state;
    char path[512];
    char message[512];
    seen_t seen;
    pgem_journal_info_t info;
    path_for(path, sizeof path, "journal_locked.lcmlog");
    pgem_journal_t *journal = reopen(path, &seen, &info);
    append_records(journal, 0, 5);
    off_t size = file_size(path);
    assert_null(pgem_journal_open(path, 0, NULL, NULL, NULL, NULL, message, sizeof message));
    assert_non_null(strstr(message, "journal_locked.lcmlog: the journal is locked by another "
                                    "process (is another pgem-lcm-bridge running on it?): "
                                    "refusing to start, nothing was changed"));
    assert_int_equal(file_size(path), size);
    append_records(journal, 5, 1); /* the first goes on */
    pgem_journal_close(journal);
    journal = reopen(path, &seen, &info); /* closed: free again */
    expect_records(&seen, 6);
    pgem_journal_close(journal);
    remove(path);
}

/* Issue 31: a symlink swapped in for the journal was followed at the restart, and the other
 * file's tail cut. The journal's path is never followed: a symlink there is refused at open,
 * naming its target, and the target is not touched (a dangling one is not created either). */
static void test_symlink_is_refused(void **state)
{
    (void)state;
    char path[512];
    char target[512];
    char message[512];
    seen_t seen;
    pgem_journal_info_t info;
    path_for(target, sizeof target, "journal_other.lcmlog");
    path_for(path, sizeof path, "journal_link.lcmlog");
    pgem_journal_t *journal = reopen(target, &seen, &info);
    append_records(journal, 0, 5);
    pgem_journal_close(journal);
    FILE *file = fopen(target, "ab");
    assert_non_null(file);
    fputc(0xED, file); /* a tail a replay through the link would have cut */
    fclose(file);
    off_t size = file_size(target);
    assert_int_equal(symlink(target, path), 0);
    assert_null(pgem_journal_open(path, 0, NULL, NULL, NULL, NULL, message, sizeof message));
    assert_non_null(strstr(message, "journal_link.lcmlog is a symbolic link (to '"));
    assert_non_null(strstr(message, "journal_other.lcmlog'): refusing to follow it"));
    assert_int_equal(file_size(target), size);
    remove(target);
    assert_null(pgem_journal_open(path, 0, NULL, NULL, NULL, NULL, message, sizeof message));
    assert_non_null(strstr(message, "is a symbolic link"));
    struct stat st;
    assert_int_equal(stat(target, &st), -1);
    remove(path);
}

/* Appends one record; returns pgem_journal_append's result and its message. */
static int try_append(pgem_journal_t *journal, int i, char *message, size_t size)
{
    unsigned char data[64];
    memset(data, i, sizeof data);
    char channel[16];
    snprintf(channel, sizeof channel, "CH%d", i % 3);
    return pgem_journal_append(journal, channel, data, (size_t)(i % 60) + 1, 1000 + i, message,
                               size);
}

/* Issue 31: the journal renamed (log rotation) or deleted while the bridge ran, or a symlink
 * swapped in: acknowledgements went on into a file no restart would read. Every append now
 * checks that the path still names the open file and its size is the journal's: if not, the
 * record is refused, saying what happened, and nothing is written; put back, appends go on. */
static void test_moved_journal_refuses(void **state)
{
    (void)state;
    char path[512];
    char moved[512];
    char other[512];
    char message[512];
    seen_t seen;
    pgem_journal_info_t info;
    path_for(path, sizeof path, "journal_moving.lcmlog");
    path_for(moved, sizeof moved, "journal_moving.lcmlog.1");
    path_for(other, sizeof other, "journal_moving_other.lcmlog");
    pgem_journal_t *journal = reopen(path, &seen, &info);
    append_records(journal, 0, 3);
    assert_int_equal(pgem_journal_check(journal, message, sizeof message), 0);

    /* renamed: refused, nothing written; renamed back: accepted */
    assert_int_equal(rename(path, moved), 0);
    off_t size = file_size(moved);
    assert_int_equal(try_append(journal, 3, message, sizeof message), -1);
    assert_non_null(strstr(message, "journal_moving.lcmlog no longer names the journal (renamed "
                                    "or rotated away): put it back, or restart on its new name"));
    assert_int_equal(pgem_journal_check(journal, message, sizeof message), -1);
    assert_int_equal(file_size(moved), size);
    /* a new file at the path (logrotate's create) */
    spill(path, (const unsigned char *)"", 0);
    assert_int_equal(try_append(journal, 3, message, sizeof message), -1);
    assert_non_null(strstr(message, "names another file now"));
    assert_int_equal(file_size(path), 0);
    assert_int_equal(rename(moved, path), 0);
    append_records(journal, 3, 1);

    /* a symlink swapped in: not followed, its target unchanged */
    spill(other, (const unsigned char *)"other\n", 6);
    assert_int_equal(rename(path, moved), 0);
    assert_int_equal(symlink(other, path), 0);
    assert_int_equal(try_append(journal, 4, message, sizeof message), -1);
    assert_non_null(strstr(message, "is now a symbolic link, not the journal (not followed)"));
    assert_int_equal(file_size(other), 6);
    assert_int_equal(remove(path), 0);
    assert_int_equal(rename(moved, path), 0);

    /* cut behind its back (a rotation that copies and truncates) */
    assert_int_equal(truncate(path, 0), 0);
    assert_int_equal(try_append(journal, 4, message, sizeof message), -1);
    assert_non_null(strstr(message, "changed behind the bridge's back (0 bytes, it wrote "));
    assert_int_equal(file_size(path), 0);
    pgem_journal_close(journal);

    /* deleted: the message says where the records still are */
    journal = reopen(path, &seen, &info);
    append_records(journal, 0, 2);
    assert_int_equal(remove(path), 0);
    assert_int_equal(try_append(journal, 2, message, sizeof message), -1);
    assert_non_null(strstr(message, "journal_moving.lcmlog was deleted (its records are in "
                                    "/proc/"));
    pgem_journal_close(journal);
    remove(other);
}

/* Issue 31: a SNAPSHOT named like the journal, in --snapshot-dir, replaced the journal. The
 * bridge asks pgem_journal_is_named before it takes a SNAPSHOT's name: the journal's file
 * under any name (a hard link) and the journal's name in its folder are the journal. */
static void test_journal_is_named(void **state)
{
    (void)state;
    char path[512];
    char link_path[512];
    char message[256];
    path_for(path, sizeof path, "journal_named.lcmlog");
    path_for(link_path, sizeof link_path, "journal_named_link.lcmlog");
    pgem_journal_t *journal = pgem_journal_open(path, 0, NULL, NULL, NULL, NULL, message,
                                                sizeof message);
    assert_non_null(journal);
    const char *tmp = getenv("PGEM_TEST_TMP");
    int dir = open(tmp != NULL ? tmp : "/tmp", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    assert_true(dir >= 0);
    assert_int_equal(pgem_journal_is_named(journal, dir, "journal_named.lcmlog"), 1);
    assert_int_equal(pgem_journal_is_named(journal, dir, "journal_named.lcmlog.weights"), 0);
    assert_int_equal(pgem_journal_is_named(journal, dir, "map.g2o"), 0);
    assert_int_equal(link(path, link_path), 0);
    assert_int_equal(pgem_journal_is_named(journal, dir, "journal_named_link.lcmlog"), 1);
    remove(link_path);
    remove(path); /* gone, the name in its folder is still the journal's */
    assert_int_equal(pgem_journal_is_named(journal, dir, "journal_named.lcmlog"), 1);
    int root = open("/", O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    assert_true(root >= 0);
    assert_int_equal(pgem_journal_is_named(journal, root, "journal_named.lcmlog"), 0);
    close(root);
    close(dir);
    pgem_journal_close(journal);
}

/* A journal written with checksums, then appended to by a writer that numbers its events one
 * after the last (the bridge before issue 31 did, and was run again on a newer journal): its
 * records carry no checksum though their numbers are 2^32 and more, and are read as such. */
static void test_older_writer_appends(void **state)
{
    (void)state;
    char path[512];
    seen_t seen;
    pgem_journal_info_t info;
    path_for(path, sizeof path, "journal_older.lcmlog");
    pgem_journal_t *journal = reopen(path, &seen, &info);
    append_records(journal, 0, 5);
    pgem_journal_close(journal);
    size_t size = 0;
    unsigned char *bytes = slurp(path, &size);
    const unsigned char *last = bytes + record_offset(4);
    uint64_t event = 0;
    for (int k = 4; k < 12; ++k) {
        event = event << 8 | last[k];
    }
    FILE *file = fopen(path, "ab");
    assert_non_null(file);
    for (int i = 5; i < 8; ++i) {
        unsigned char header[28];
        unsigned char data[64];
        memset(data, i, sizeof data);
        char channel[16];
        snprintf(channel, sizeof channel, "CH%d", i % 3);
        put_be(header, 0xEDA1DA01u, 4);
        put_be(header + 4, ++event, 8);
        put_be(header + 12, (uint64_t)(1000 + i), 8);
        put_be(header + 20, strlen(channel), 4);
        put_be(header + 24, (uint64_t)(i % 60 + 1), 4);
        fwrite(header, 1, sizeof header, file);
        fwrite(channel, 1, strlen(channel), file);
        fwrite(data, 1, (size_t)(i % 60 + 1), file);
    }
    fclose(file);
    free(bytes);
    journal = reopen(path, &seen, &info);
    expect_records(&seen, 8);
    assert_int_equal(info.checked, 5);
    assert_int_equal(info.skipped, 0);
    append_records(journal, 8, 1); /* numbered after the older writer's, with a checksum */
    pgem_journal_close(journal);
    journal = reopen(path, &seen, &info);
    expect_records(&seen, 9);
    assert_int_equal(info.checked, 6);
    pgem_journal_close(journal);
    remove(path);
}

static void test_crc32(void **state)
{
    (void)state;
    assert_int_equal(pgem_journal_crc32(0, "123456789", 9), 0xCBF43926u); /* the check value */
    assert_int_equal(pgem_journal_crc32(pgem_journal_crc32(0, "1234", 4), "56789", 5),
                     0xCBF43926u);
    unsigned char bytes[256];
    for (int i = 0; i < 256; ++i) {
        bytes[i] = (unsigned char)(i * 37 + 11);
    }
    assert_int_equal(pgem_journal_crc32(0, bytes, sizeof bytes),
                     crc32_bitwise(0, bytes, sizeof bytes));
}

/* ---- a running bridge: its statuses acknowledge only what is journaled ------------------ */

/* The stream's length: 6000 poses, or 600 under valgrind (PGEM_TEST_VALGRIND, set by the
 * memcheck tests), where the bridge runs some fifty times slower and the full stream did not
 * finish in five minutes; the plain and sanitizer runs keep the long stream. */
static int64_t chain_poses = 6000;
#define CHAIN_POSES chain_poses

typedef struct watch {
    int statuses;
    int streaming;        /* published after a solve while the stream was still arriving */
    int ahead;            /* statuses counting more accepted items than journal records */
    int64_t worst;        /* by how many, at most */
    int64_t last_accepted;
} watch_t;

static volatile int bridge_stop_flag;

static int bridge_stop(void)
{
    return bridge_stop_flag;
}

typedef struct bridge_run {
    pgem_bridge_options_t options;
    int status;
    char message[1024];
} bridge_run_t;

static void *bridge_thread(void *user)
{
    bridge_run_t *run = user;
    run->status = pgem_bridge_run(&run->options, bridge_stop, run->message, sizeof run->message);
    return NULL;
}

/* Runs in the bridge's reception thread (it dispatches the memq:// messages). */
static void on_status(const lcm_recv_buf_t *buffer, const char *channel,
                      const pgem_status_t *status, void *user)
{
    (void)buffer;
    (void)channel;
    watch_t *watch = user;
    int64_t accepted = status->accepted_poses + status->accepted_edges;
    watch->statuses++;
    watch->streaming += status->solves > 0 && accepted < 2 * CHAIN_POSES - 1;
    if (accepted > status->journal_records) {
        watch->ahead++;
        if (accepted - status->journal_records > watch->worst) {
            watch->worst = accepted - status->journal_records;
        }
    }
    watch->last_accepted = accepted;
}

static void publish_chain(lcm_t *lcm)
{
    static char source[] = "chain";
    for (int64_t id = 0; id < CHAIN_POSES; ++id) {
        pgem_pose2_t pose;
        memset(&pose, 0, sizeof pose);
        pose.source = source;
        pose.id = id;
        pose.pose[0] = (double)id;
        assert_int_equal(pgem_pose2_t_publish(lcm, "PGEM_POSE2", &pose), 0);
        if (id == 0) {
            continue;
        }
        /* odometry, and every tenth pose a loop closure back to the start of its stretch */
        pgem_edge2_t edge;
        memset(&edge, 0, sizeof edge);
        edge.source = source;
        edge.sequence = id;
        edge.from = id % 10 == 0 ? id - 9 : id - 1;
        edge.to = id;
        edge.measurement[0] = (double)(edge.to - edge.from);
        edge.information[0] = edge.information[3] = edge.information[5] = 100.0;
        edge.kind = id % 10 == 0 ? PGEM_EDGE2_T_LOOP : PGEM_EDGE2_T_ODOMETRY;
        if (edge.kind == PGEM_EDGE2_T_LOOP) {
            /* keep the chain joined by odometry as well */
            pgem_edge2_t odometry = edge;
            odometry.sequence = CHAIN_POSES + id;
            odometry.from = id - 1;
            odometry.measurement[0] = 1.0;
            odometry.kind = PGEM_EDGE2_T_ODOMETRY;
            assert_int_equal(pgem_edge2_t_publish(lcm, "PGEM_EDGE2", &odometry), 0);
        }
        assert_int_equal(pgem_edge2_t_publish(lcm, "PGEM_EDGE2", &edge), 0);
    }
}

/* Regression: the solver thread publishes a status after every solve, and it used to read the
 * reception side's live counters, which can include an edge admitted a moment ago whose
 * journal record is not written yet; killed then, the bridge lost an edge it had acknowledged.
 * A stream that keeps the reception thread busy while solves finish makes that moment common:
 * no status may count more accepted poses and edges than the journal's records. */
static void test_status_counts_only_journaled(void **state)
{
    (void)state;
    if (getenv("PGEM_TEST_VALGRIND") != NULL) {
        chain_poses = 600;
    }
    char path[512];
    path_for(path, sizeof path, "pgem_test_status.lcmlog");
    lcm_t *lcm = lcm_create("memq://");
    assert_non_null(lcm);
    watch_t watch;
    memset(&watch, 0, sizeof watch);
    pgem_status_t_subscription_t *subscription =
        pgem_status_t_subscribe(lcm, "PGEM_STATUS", on_status, &watch);
    assert_non_null(subscription);

    bridge_run_t run;
    memset(&run, 0, sizeof run);
    run.options.lcm = lcm;
    run.options.journal = path;
    run.options.max_poses = (uint32_t)CHAIN_POSES;
    run.options.debounce = 1e-4;
    run.options.max_delay = 1e-3;
    run.options.max_rate = 1000.0;
    run.options.status_period = 1e-3;
    pgem_bridge_defaults(&run.options);
    bridge_stop_flag = 0;
    pthread_t thread;
    assert_int_equal(pthread_create(&thread, NULL, bridge_thread, &run), 0);
    /* the bridge subscribes, then handles messages: its first status says so (a fixed pause
     * lost the whole chain when valgrind slowed the start past it) */
    for (int wait = 0; wait < 6000 && watch.statuses == 0; ++wait) {
        struct timespec tick = {0, 10000000L};
        nanosleep(&tick, NULL);
    }
    publish_chain(lcm);
    /* until everything is counted (the status is published every millisecond); the bound is
     * generous for a slow run (valgrind on a busy machine needed more than 30 s) */
    int64_t expected = 2 * (int64_t)CHAIN_POSES - 1 + (CHAIN_POSES - 1) / 10;
    for (int wait = 0; wait < 6000 && watch.last_accepted < expected; ++wait) {
        struct timespec tick = {0, 50000000L};
        nanosleep(&tick, NULL);
    }
    bridge_stop_flag = 1;
    pthread_join(thread, NULL);
    assert_int_equal(run.status, 0);
    pgem_status_t_unsubscribe(lcm, subscription);
    lcm_destroy(lcm);
    remove(path);
    print_message("%d statuses, %d of them after a solve during the stream; %d ahead of the "
                  "journal (by up to %lld)\n", watch.statuses, watch.streaming,
                  watch.ahead, (long long)watch.worst);
    assert_int_equal(watch.last_accepted, expected);
    assert_true(watch.streaming > 0);
    assert_int_equal(watch.ahead, 0);
}

/* The latest status of a bridge, for the full-journal test. */
typedef struct latest {
    pthread_mutex_t lock;
    int64_t received;
    int64_t accepted;         /* poses and edges */
    int64_t journal_records;
    int64_t refused;          /* rejected, reason journal */
    int64_t ahead;            /* statuses that acknowledged more than the journal held */
    char message[400];
} latest_t;

static void on_latest(const lcm_recv_buf_t *buffer, const char *channel,
                      const pgem_status_t *status, void *user)
{
    (void)buffer;
    (void)channel;
    latest_t *latest = user;
    pthread_mutex_lock(&latest->lock);
    latest->received = status->received;
    latest->accepted = status->accepted_poses + status->accepted_edges;
    latest->journal_records = status->journal_records;
    latest->ahead += latest->accepted > status->journal_records;
    latest->refused = 0;
    for (int32_t r = 0; r < status->num_reasons; ++r) {
        if (strcmp(status->reasons[r], "journal") == 0) {
            latest->refused = status->rejected[r];
        }
    }
    snprintf(latest->message, sizeof latest->message, "%s", status->message);
    pthread_mutex_unlock(&latest->lock);
}

/* Waits up to a minute for the latest status to have received `received` messages. */
static void wait_received(latest_t *latest, int64_t received)
{
    for (int wait = 0; wait < 1200; ++wait) {
        pthread_mutex_lock(&latest->lock);
        int done = latest->received >= received;
        pthread_mutex_unlock(&latest->lock);
        if (done) {
            return;
        }
        struct timespec tick = {0, 50000000L};
        nanosleep(&tick, NULL);
    }
    fail_msg("no status counted %lld received messages", (long long)received);
}

static void publish_poses(lcm_t *lcm, int64_t first, int64_t count)
{
    static char source[] = "fe";
    for (int64_t id = first; id < first + count; ++id) {
        pgem_pose2_t pose;
        memset(&pose, 0, sizeof pose);
        pose.source = source;
        pose.id = id;
        pose.pose[0] = (double)id;
        assert_int_equal(pgem_pose2_t_publish(lcm, "PGEM_POSE2", &pose), 0);
    }
}

/* Issue 17: on a full journal disk the status said 600 accepted where the journal held 520
 * records, and a restart brought back fewer than acknowledged. A message the journal cannot
 * take is now refused (reason journal) and changes nothing: the status never counts more than
 * the journal holds, says why, and the front-end's resend is accepted once there is room. */
static void test_full_journal_refuses_and_recovers(void **state)
{
    (void)state;
    char path[512];
    path_for(path, sizeof path, "pgem_test_full.lcmlog");
    lcm_t *lcm = lcm_create("memq://");
    assert_non_null(lcm);
    latest_t latest;
    memset(&latest, 0, sizeof latest);
    pthread_mutex_init(&latest.lock, NULL);
    pgem_status_t_subscription_t *subscription =
        pgem_status_t_subscribe(lcm, "PGEM_STATUS", on_latest, &latest);
    bridge_run_t run;
    memset(&run, 0, sizeof run);
    run.options.lcm = lcm;
    run.options.journal = path;
    run.options.max_poses = 1000;
    run.options.status_period = 1e-3;
    pgem_bridge_defaults(&run.options);
    bridge_stop_flag = 0;
    pthread_t thread;
    assert_int_equal(pthread_create(&thread, NULL, bridge_thread, &run), 0);
    struct timespec pause = {0, 50000000L};
    nanosleep(&pause, NULL);
    publish_poses(lcm, 0, 100);
    wait_received(&latest, 100);
    /* the disk is full: a file size limit at the journal's size fails every append */
    struct rlimit saved;
    assert_int_equal(getrlimit(RLIMIT_FSIZE, &saved), 0);
    struct rlimit full = saved;
    full.rlim_cur = (rlim_t)file_size(path);
    void (*previous)(int) = signal(SIGXFSZ, SIG_IGN);
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &full), 0);
    publish_poses(lcm, 100, 50);
    wait_received(&latest, 150);
    nanosleep(&pause, NULL); /* a status after the last message */
    pthread_mutex_lock(&latest.lock);
    int64_t accepted_full = latest.accepted;
    int64_t refused = latest.refused;
    char during[sizeof latest.message];
    memcpy(during, latest.message, sizeof during);
    pthread_mutex_unlock(&latest.lock);
    /* room again: the front-end resends what was not acknowledged */
    assert_int_equal(setrlimit(RLIMIT_FSIZE, &saved), 0);
    signal(SIGXFSZ, previous);
    publish_poses(lcm, 100, 50);
    wait_received(&latest, 200);
    nanosleep(&pause, NULL);
    bridge_stop_flag = 1;
    pthread_join(thread, NULL);
    assert_int_equal(run.status, 0);
    print_message("full journal: %lld accepted, %lld refused; then %lld accepted, %lld journal "
                  "records; %lld statuses ahead of the journal; status: %s\n",
                  (long long)accepted_full, (long long)refused, (long long)latest.accepted,
                  (long long)latest.journal_records, (long long)latest.ahead, during);
    assert_int_equal(accepted_full, 100);
    assert_int_equal(refused, 50);
    assert_non_null(strstr(during, "rejected (journal): 2D pose 149: not accepted, it could not "
                                   "be journaled ("));
    assert_non_null(strstr(during, "write failed: File too large); nothing changed, resend it"));
    assert_int_equal(latest.accepted, 150);
    assert_int_equal(latest.journal_records, 150);
    assert_int_equal(latest.ahead, 0);
    /* a restart on the journal has everything that was acknowledged */
    seen_t seen;
    pgem_journal_info_t info;
    char message[256];
    memset(&seen, 0, sizeof seen);
    pgem_journal_t *journal = pgem_journal_open(path, 0, NULL, NULL, NULL, &info, message,
                                                sizeof message);
    assert_non_null(journal);
    assert_int_equal(info.records, 150);
    assert_int_equal(info.torn_bytes, 0);
    pgem_journal_close(journal);
    pgem_status_t_unsubscribe(lcm, subscription);
    lcm_destroy(lcm);
    pthread_mutex_destroy(&latest.lock);
    remove(path);
}

/* Log lines of a bridge, counted. */
typedef struct lines {
    int count;
    int refused;  /* "journal record refused on replay" lines */
} lines_t;

static void count_line(void *user, const char *line)
{
    lines_t *lines = user;
    lines->count++;
    lines->refused += strstr(line, "refused on replay") != NULL;
}

/* Issue 17: restarted with a smaller --max-poses, a bridge printed a line for each of 17,332
 * records it refused and then claimed all 64,282 replayed, running with part of its map. A
 * journal whose records do not fit the bridge's capacities or dimension stops the start, says
 * how many and why in one message, and is left as it was. */
static void test_journal_that_does_not_fit(void **state)
{
    (void)state;
    char path[512];
    char message[512];
    path_for(path, sizeof path, "pgem_test_fit.lcmlog");
    pgem_journal_t *journal = pgem_journal_open(path, 0, NULL, NULL, NULL, NULL, message,
                                                sizeof message);
    assert_non_null(journal);
    static char source[] = "fe";
    for (int64_t id = 0; id < 100; ++id) {
        pgem_pose2_t pose;
        memset(&pose, 0, sizeof pose);
        pose.source = source;
        pose.id = id;
        unsigned char bytes[256];
        int size = pgem_pose2_t_encode(bytes, 0, sizeof bytes, &pose);
        assert_int_equal(pgem_journal_append(journal, "PGEM_POSE2", bytes, (size_t)size, id,
                                             message, sizeof message), 0);
    }
    pgem_journal_close(journal);
    off_t size = file_size(path);
    for (int dimension = 2; dimension <= 3; ++dimension) {
        lines_t lines = {0, 0};
        bridge_run_t run;
        memset(&run, 0, sizeof run);
        run.options.lcm = lcm_create("memq://");
        run.options.journal = path;
        run.options.dimension = dimension;
        run.options.max_poses = dimension == 2 ? 40 : 1000;
        run.options.log = count_line;
        run.options.log_user = &lines;
        pgem_bridge_defaults(&run.options);
        bridge_stop_flag = 1;
        run.status = pgem_bridge_run(&run.options, bridge_stop, run.message, sizeof run.message);
        lcm_destroy(run.options.lcm);
        print_message("%dD: %s (%d log lines, %d refusals logged)\n", dimension, run.message,
                      lines.count, lines.refused);
        assert_int_equal(run.status, -1);
        assert_non_null(strstr(run.message, dimension == 2
                                                ? "60 of its 100 records do not fit this bridge "
                                                  "(capacity 60; the first, capacity: 2D pose 40: "
                                                  "the bridge holds its maximum of 40 poses"
                                                : "100 of its 100 records do not fit this bridge "
                                                  "(dimension 100; the first, dimension: a 2D pose "
                                                  "reached a 3D bridge)"));
        assert_non_null(strstr(run.message, "start it with the --dimension, --max-poses and "
                                            "--max-edges the journal was written with"));
        assert_true(lines.refused <= 20);
        assert_int_equal(file_size(path), size);
    }
    remove(path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_torn_tail_is_cut),
        cmocka_unit_test(test_damage_is_skipped_and_reported),
        cmocka_unit_test(test_not_a_journal_is_refused),
        cmocka_unit_test(test_failed_append_is_taken_back),
        cmocka_unit_test(test_lcm_reads_the_journal),
        cmocka_unit_test(test_journal_reads_lcm_logs),
        cmocka_unit_test(test_open_errors),
        cmocka_unit_test(test_crc32),
        cmocka_unit_test(test_older_writer_appends),
        cmocka_unit_test(test_damage_sweep_checksummed),
        cmocka_unit_test(test_damage_sweep_lcm_logger),
        cmocka_unit_test(test_bad_length_is_not_a_torn_tail),
        cmocka_unit_test(test_damaged_last_record),
        cmocka_unit_test(test_second_open_is_refused),
        cmocka_unit_test(test_symlink_is_refused),
        cmocka_unit_test(test_moved_journal_refuses),
        cmocka_unit_test(test_journal_is_named),
        cmocka_unit_test(test_status_counts_only_journaled),
        cmocka_unit_test(test_full_journal_refuses_and_recovers),
        cmocka_unit_test(test_journal_that_does_not_fit),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
