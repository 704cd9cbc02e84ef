/* A test program of the LCM fault tests: publishes malformed messages on a 2D bridge's input
 * channels, each built so that exactly one rejection reason applies, and prints what the
 * bridge's status must show for them.
 *
 *   lcm_malformed COUNT RATE SEED
 *
 * COUNT messages at RATE messages per second (absolute deadlines, so no drift; 0: as fast as
 * possible) on PGEM_POSE2, PGEM_EDGE2 and PGEM_COMMAND of LCM_DEFAULT_URL. The kinds, chosen
 * by a generator seeded with SEED: truncated, padded, wrong fingerprint, a lying string
 * length, a string without its NUL, random bytes, the other dimension's type, NaN or Inf in
 * an estimate, measurement or information, information not positive definite, self-loops,
 * unknown edge kinds, empty or over-long source names, unknown commands, SNAPSHOT without a
 * path; and (issue 17) translations or information beyond the core's limits, source names that
 * are not printable UTF-8, SNAPSHOT paths that are not a plain name. None can be accepted, and
 * none names a pose or (source, sequence) of a real front-end: they use the source "malformed"
 * and ids from 1e12 on.
 *
 * Prints "sent N malformed messages ..." and then the counts the bridge must add up to:
 * "expect received R" (pose and edge channel messages), "expect commands C" (commands that
 * decoded) and one "expect rejected REASON N" per reason. Exit 0, 1 when LCM fails, 2 on a
 * bad command line. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <lcm/lcm.h>

#include "test_clock.h"

#include "channels.h"
#include "ingest.h"
#include "pgem_command_t.h"
#include "pgem_edge2_t.h"
#include "pgem_edge3_t.h"
#include "pgem_pose2_t.h"
#include "pgem_pose3_t.h"
#include "random.h"

#define FIRST_ID 1000000000000LL /* far above any real pose id of the tests */
#define MESSAGE_MAX 1024
#define STRING_OFFSET 16 /* fingerprint, utime: where an input type's string starts */

typedef struct message {
    unsigned char bytes[MESSAGE_MAX];
    size_t size;
    int channel; /* 0 pose, 1 edge, 2 command */
    pgem_reject_t reason;
} message_t;

typedef struct tally {
    int64_t sent[3];
    int64_t received;
    int64_t commands;
    int64_t rejected[PGEM_REJECT_COUNT];
} tally_t;

static uint64_t rng_state;

static uint64_t next_random(void)
{
    return pgem_random_next(&rng_state); /* the same stream everywhere for a seed */
}

static size_t below(size_t n)
{
    return (size_t)(next_random() % n);
}

static char source_name[] = "malformed";
static char empty_name[] = "";
static char long_name[] = "a-source-name-longer-than-the-sixty-three-bytes-a-bridge-allows-it";

/* A well-formed edge between two ids of no real graph; the kinds below break one thing. */
static pgem_edge2_t base_edge(int64_t k)
{
    pgem_edge2_t edge;
    memset(&edge, 0, sizeof edge);
    edge.utime = k;
    edge.source = source_name;
    edge.sequence = k;
    edge.from = FIRST_ID + k;
    edge.to = FIRST_ID + k + 1;
    edge.measurement[0] = 1.0;
    edge.information[0] = 100.0; /* xx */
    edge.information[3] = 100.0; /* yy */
    edge.information[5] = 400.0; /* tt */
    edge.kind = PGEM_EDGE2_T_LOOP;
    return edge;
}

static void encode_edge(message_t *m, const pgem_edge2_t *edge)
{
    m->size = (size_t)pgem_edge2_t_encode(m->bytes, 0, MESSAGE_MAX, edge);
    m->channel = 1;
}

static void encode_pose(message_t *m, int64_t k, double x)
{
    pgem_pose2_t pose;
    memset(&pose, 0, sizeof pose);
    pose.utime = k;
    pose.source = source_name;
    pose.id = FIRST_ID + k;
    pose.pose[0] = x;
    m->size = (size_t)pgem_pose2_t_encode(m->bytes, 0, MESSAGE_MAX, &pose);
    m->channel = 0;
}

static void encode_command(message_t *m, int8_t what, char *path)
{
    pgem_command_t command = {1, what, path};
    m->size = (size_t)pgem_command_t_encode(m->bytes, 0, MESSAGE_MAX, &command);
    m->channel = 2;
}

static void random_bytes(message_t *m, int channel)
{
    m->size = below(300);
    for (size_t i = 0; i < m->size; ++i) {
        m->bytes[i] = (unsigned char)next_random();
    }
    m->channel = channel;
    m->reason = PGEM_REJECT_DECODE;
}

/* The string length field, big-endian, after the fingerprint and utime. */
static void set_string_length(message_t *m, uint32_t length)
{
    unsigned char *p = m->bytes + STRING_OFFSET;
    p[0] = (unsigned char)(length >> 24);
    p[1] = (unsigned char)(length >> 16);
    p[2] = (unsigned char)(length >> 8);
    p[3] = (unsigned char)length;
}

static double bad_number(void)
{
    return below(2) ? (double)NAN : (below(2) ? (double)INFINITY : -(double)INFINITY);
}

#define KINDS 23

static char unprintable_names[4][24] = {"fe\xff", "fe\nrejected (x): forged", "\x1b[2Jfe",
                                        "rtl\xe2\x80\xae\146\145"}; /* ...fe */
static char escaping_paths[4][24] = {"../escaped.g2o", "/tmp/escaped.g2o", "sub/x.g2o",
                                     ".hidden.g2o"};

/* Message number k of the given kind (0 .. KINDS-1). */
static void build(message_t *m, int kind, int64_t k)
{
    pgem_edge2_t edge = base_edge(k);
    m->reason = PGEM_REJECT_DECODE;
    switch (kind) {
    case 0: /* truncated edge */
        encode_edge(m, &edge);
        m->size = below(m->size);
        break;
    case 1: /* padded edge */
        encode_edge(m, &edge);
        for (size_t extra = 1 + below(16); extra > 0; --extra) {
            m->bytes[m->size++] = (unsigned char)next_random();
        }
        break;
    case 2: /* wrong fingerprint: a byte of it changed, or a pose on the edge channel */
        if (below(2)) {
            encode_edge(m, &edge);
            m->bytes[below(8)] ^= (unsigned char)(1 + below(255));
        } else {
            encode_pose(m, k, 0.0);
        }
        m->channel = 1;
        break;
    case 3: { /* a string length that lies */
        encode_edge(m, &edge);
        uint32_t truth = (uint32_t)strlen(source_name) + 1;
        uint32_t lie = (uint32_t)next_random();
        set_string_length(m, lie == truth ? truth + 1 : lie);
        break;
    }
    case 4: /* the string's NUL replaced */
        encode_edge(m, &edge);
        m->bytes[STRING_OFFSET + 4 + strlen(source_name)] = 'x';
        break;
    case 5:
        random_bytes(m, 1); /* (a known fingerprint by chance: 1 in 2^64) */
        break;
    case 6: { /* a 3D edge reaching the 2D bridge */
        pgem_edge3_t edge3;
        memset(&edge3, 0, sizeof edge3);
        edge3.source = source_name;
        edge3.from = FIRST_ID;
        edge3.to = FIRST_ID + 1;
        edge3.measurement[6] = 1.0;
        m->size = (size_t)pgem_edge3_t_encode(m->bytes, 0, MESSAGE_MAX, &edge3);
        m->channel = 1;
        m->reason = PGEM_REJECT_DIMENSION;
        break;
    }
    case 7: /* NaN or Inf in the measurement */
        edge.measurement[below(3)] = bad_number();
        encode_edge(m, &edge);
        m->reason = PGEM_REJECT_NOT_FINITE;
        break;
    case 8: /* NaN or Inf in the information */
        edge.information[below(6)] = bad_number();
        encode_edge(m, &edge);
        m->reason = PGEM_REJECT_NOT_FINITE;
        break;
    case 9: /* information not positive definite: a diagonal entry <= 0, or |xy| too large */
        if (below(2)) {
            static const int diagonal[3] = {0, 3, 5};
            edge.information[diagonal[below(3)]] = -(double)below(1000);
        } else {
            edge.information[1] = 1000.0;
        }
        encode_edge(m, &edge);
        m->reason = PGEM_REJECT_INFORMATION;
        break;
    case 10:
        edge.to = edge.from;
        encode_edge(m, &edge);
        m->reason = PGEM_REJECT_SELF_LOOP;
        break;
    case 11: /* kind neither ODOMETRY nor LOOP */
        edge.kind = (int8_t)(2 + below(120));
        if (below(2)) {
            edge.kind = (int8_t)-edge.kind;
        }
        encode_edge(m, &edge);
        m->reason = PGEM_REJECT_KIND;
        break;
    case 12:
        edge.source = below(2) ? empty_name : long_name;
        encode_edge(m, &edge);
        m->reason = PGEM_REJECT_SOURCE;
        break;
    case 13: /* truncated pose */
        encode_pose(m, k, 0.0);
        m->size = below(m->size);
        break;
    case 14:
        encode_pose(m, k, bad_number());
        m->reason = PGEM_REJECT_NOT_FINITE;
        break;
    case 15: { /* a 3D pose reaching the 2D bridge */
        pgem_pose3_t pose3;
        memset(&pose3, 0, sizeof pose3);
        pose3.source = source_name;
        pose3.id = FIRST_ID + k;
        pose3.pose[6] = 1.0;
        m->size = (size_t)pgem_pose3_t_encode(m->bytes, 0, MESSAGE_MAX, &pose3);
        m->channel = 0;
        m->reason = PGEM_REJECT_DIMENSION;
        break;
    }
    case 16:
        random_bytes(m, 0);
        break;
    case 17: /* unknown command */
        encode_command(m, (int8_t)(4 + below(100)), empty_name);
        m->reason = PGEM_REJECT_COMMAND;
        break;
    case 18:
        encode_command(m, PGEM_COMMAND_T_SNAPSHOT, empty_name);
        m->reason = PGEM_REJECT_COMMAND;
        break;
    case 19: /* beyond the magnitude limits: a translation (1e8 m) or information (1e15) */
        if (below(3) == 0) {
            encode_pose(m, k, below(2) ? 1e160 : -1.5e8);
        } else {
            if (below(2)) {
                edge.measurement[below(2)] = below(2) ? 1e160 : -2e8;
            } else {
                edge.information[below(6)] = below(2) ? 2e15 : -1e300;
            }
            encode_edge(m, &edge);
        }
        m->reason = PGEM_REJECT_RANGE;
        break;
    case 20: /* a source name that is not printable UTF-8 */
        edge.source = unprintable_names[below(4)];
        encode_edge(m, &edge);
        m->reason = PGEM_REJECT_SOURCE;
        break;
    case 21: /* SNAPSHOT with a path out of the snapshot folder (or SNAPSHOT off) */
        encode_command(m, PGEM_COMMAND_T_SNAPSHOT, escaping_paths[below(4)]);
        m->reason = PGEM_REJECT_COMMAND;
        break;
    default: /* truncated command */
        encode_command(m, PGEM_COMMAND_T_OPTIMIZE, empty_name);
        m->size = below(m->size);
        break;
    }
}

static void count(tally_t *tally, const message_t *m)
{
    tally->sent[m->channel]++;
    if (m->channel < 2) {
        tally->received++;
    } else if (m->reason == PGEM_REJECT_COMMAND) {
        tally->commands++; /* decoded, then refused */
    }
    tally->rejected[m->reason]++;
}

static int parse(const char *text, double *value)
{
    char *end = NULL;
    *value = strtod(text, &end);
    return end != text && *end == '\0' && *value >= 0.0 && isfinite(*value);
}

int main(int argc, char **argv)
{
    double count_arg = 0.0;
    double rate = 0.0;
    double seed = 0.0;
    if (argc != 4 || !parse(argv[1], &count_arg) || !parse(argv[2], &rate) ||
        !parse(argv[3], &seed)) {
        fprintf(stderr, "usage: lcm_malformed COUNT RATE SEED\n");
        return 2;
    }
    rng_state = (uint64_t)seed;
    pgem_channels_t channels;
    pgem_channels_init(&channels, NULL, 2);
    const char *names[3] = {channels.pose, channels.edge, channels.command};
    lcm_t *lcm = lcm_create(NULL);
    if (lcm == NULL) {
        fprintf(stderr, "lcm_malformed: cannot open LCM\n");
        return 1;
    }
    tally_t tally;
    memset(&tally, 0, sizeof tally);
    int64_t total = (int64_t)count_arg;
    double start = now_seconds();
    for (int64_t k = 0; k < total; ++k) {
        if (rate > 0.0) {
            sleep_until(start + (double)k / rate);
        }
        message_t m;
        build(&m, (int)below(KINDS), k);
        if (lcm_publish(lcm, names[m.channel], m.bytes, (unsigned)m.size) != 0) {
            fprintf(stderr, "lcm_malformed: publishing on %s failed\n", names[m.channel]);
            lcm_destroy(lcm);
            return 1;
        }
        count(&tally, &m);
    }
    printf("sent %lld malformed messages (pose %lld, edge %lld, command %lld) in %.2f s\n",
           (long long)total, (long long)tally.sent[0], (long long)tally.sent[1],
           (long long)tally.sent[2], now_seconds() - start);
    printf("expect received %lld\n", (long long)tally.received);
    printf("expect commands %lld\n", (long long)tally.commands);
    for (int r = 0; r < PGEM_REJECT_COUNT; ++r) {
        printf("expect rejected %s %lld\n", pgem_reject_name((pgem_reject_t)r),
               (long long)tally.rejected[r]);
    }
    lcm_destroy(lcm);
    return 0;
}
