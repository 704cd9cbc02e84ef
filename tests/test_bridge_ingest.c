/* The bridge's reception state machine: decoding, validation, replays, conflicts, pending
 * edges (ageing and fairness), sources, the admit hook, capacity, commands and determinism, on
 * messages encoded with the lcm-gen types. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "bridge.h"
#include "ingest.h"
#include "pgem_command_t.h"
#include "pgem_edge2_t.h"
#include "pgem_edge3_t.h"
#include "pgem_graph_t.h"
#include "pgem_pose2_t.h"
#include "pgem_pose3_t.h"

/* ---- a recording emit callback ------------------------------------------------------------ */

#define MAX_ITEMS 4096

typedef struct sink {
    pgem_item_t items[MAX_ITEMS];
    int count;
} sink_t;

static void record(void *user, const pgem_item_t *item)
{
    sink_t *sink = user;
    assert_true(sink->count < MAX_ITEMS);
    sink->items[sink->count++] = *item;
}

/* The receive time every message is fed with (microseconds). */
static int64_t test_clock = 0;

static pgem_ingest_t *make_ingest(int dimension, uint32_t poses, uint32_t edges,
                                  uint32_t pending, sink_t *sink)
{
    memset(sink, 0, sizeof *sink);
    test_clock = 0;
    pgem_ingest_config_t config = {dimension, poses, edges, pending, 4, 0, 1, 0};
    pgem_ingest_t *ingest = pgem_ingest_create(&config, record, sink);
    assert_non_null(ingest);
    return ingest;
}

/* ---- message builders ----------------------------------------------------------------------- */

typedef struct wire {
    unsigned char bytes[2048];
    size_t size;
} wire_t;

static char default_source[] = "fe";

static wire_t pose2(int64_t id, double x, double y, double theta)
{
    pgem_pose2_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = 1;
    msg.source = default_source;
    msg.id = id;
    msg.pose[0] = x;
    msg.pose[1] = y;
    msg.pose[2] = theta;
    wire_t w;
    w.size = (size_t)pgem_pose2_t_encode(w.bytes, 0, sizeof w.bytes, &msg);
    return w;
}

static pgem_edge2_t edge2_msg(int64_t sequence, int64_t from, int64_t to)
{
    pgem_edge2_t msg;
    memset(&msg, 0, sizeof msg);
    msg.utime = 2;
    msg.source = default_source;
    msg.sequence = sequence;
    msg.from = from;
    msg.to = to;
    msg.measurement[0] = 1.0;
    msg.information[0] = 100.0; /* xx */
    msg.information[3] = 100.0; /* yy */
    msg.information[5] = 400.0; /* tt */
    msg.kind = (to - from == 1 || from - to == 1) ? PGEM_EDGE2_T_ODOMETRY : PGEM_EDGE2_T_LOOP;
    return msg;
}

static wire_t encode_edge2(const pgem_edge2_t *msg)
{
    wire_t w;
    w.size = (size_t)pgem_edge2_t_encode(w.bytes, 0, sizeof w.bytes, msg);
    return w;
}

static wire_t edge2(int64_t sequence, int64_t from, int64_t to)
{
    pgem_edge2_t msg = edge2_msg(sequence, from, to);
    return encode_edge2(&msg);
}

static wire_t command(int8_t what, const char *path)
{
    char text[256];
    strncpy(text, path, sizeof text - 1);
    text[sizeof text - 1] = '\0';
    pgem_command_t msg;
    msg.utime = 3;
    msg.command = what;
    msg.path = text;
    wire_t w;
    w.size = (size_t)pgem_command_t_encode(w.bytes, 0, sizeof w.bytes, &msg);
    return w;
}

static pgem_ingest_result_t feed(pgem_ingest_t *ingest, pgem_role_t role, wire_t w)
{
    pgem_ingest_result_t result;
    pgem_ingest_message(ingest, role, w.bytes, w.size, test_clock, &result);
    return result;
}

static void expect_rejected(pgem_ingest_t *ingest, pgem_role_t role, wire_t w,
                            pgem_reject_t reason)
{
    pgem_ingest_result_t result = feed(ingest, role, w);
    assert_int_equal(result.verdict, PGEM_VERDICT_REJECTED);
    assert_int_equal(result.reason, reason);
    assert_true(strlen(result.message) > 0);
}

/* ---- tests ------------------------------------------------------------------------------- */

static void test_in_order_stream(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(1, 1, 0, 0)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1));
    assert_int_equal(r.verdict, PGEM_VERDICT_ACCEPTED);
    assert_int_equal(r.pending, 0);
    assert_int_equal(sink.count, 3);
    assert_int_equal(sink.items[2].type, PGEM_ITEM_EDGE);
    assert_true(sink.items[2].from == 0 && sink.items[2].to == 1);
    assert_int_equal(sink.items[2].kind, PGEM_EDGE_ODOMETRY);
    assert_true(sink.items[2].information[5] == 400.0);
    assert_int_equal(pgem_ingest_source_count(ingest), 1);
    assert_string_equal(pgem_ingest_source_name(ingest, sink.items[2].source), "fe");
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.received, 3);
    assert_int_equal(counts.accepted_poses, 2);
    assert_int_equal(counts.accepted_edges, 1);
    pgem_ingest_destroy(ingest);
}

static void test_edges_wait_for_poses(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(5, 0, 2)).pending, 1);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(3, 1, 2)).pending, 1);
    assert_int_equal(sink.count, 0);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.pending, 2);
    feed(ingest, PGEM_ROLE_POSE, pose2(2, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 0, 0, 0));
    /* pose 2, pose 1, then edge 3 (1 -> 2) is released; edge 5 still waits for pose 0 */
    assert_int_equal(sink.count, 3);
    assert_int_equal(sink.items[2].sequence, 3);
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    assert_int_equal(sink.count, 5);
    assert_int_equal(sink.items[3].type, PGEM_ITEM_POSE);
    assert_int_equal(sink.items[4].sequence, 5);
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.pending, 0);
    pgem_ingest_destroy(ingest);
}

static void test_pending_is_bounded(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 2, &sink);
    feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1));
    feed(ingest, PGEM_ROLE_EDGE, edge2(1, 1, 2));
    expect_rejected(ingest, PGEM_ROLE_EDGE, edge2(2, 2, 3), PGEM_REJECT_PENDING_FULL);
    /* a rejected edge reserved nothing: once poses arrive it can be sent again */
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(2, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(3, 0, 0, 0));
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(2, 2, 3)).verdict, PGEM_VERDICT_ACCEPTED);
    pgem_ingest_destroy(ingest);
}

static void test_replays_and_conflicts(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 1, 0, 0));
    feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1));
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1)).verdict, PGEM_VERDICT_REPLAY);
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(1, 1, 0, 0)).verdict,
                     PGEM_VERDICT_REPLAY);
    expect_rejected(ingest, PGEM_ROLE_POSE, pose2(1, 2, 0, 0), PGEM_REJECT_CONFLICT);
    pgem_edge2_t other = edge2_msg(0, 0, 1);
    other.measurement[0] = 1.5;
    expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&other), PGEM_REJECT_CONFLICT);
    /* the same sequence from another source is another edge */
    char second[] = "other-front-end";
    other.source = second;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&other)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    assert_int_equal(sink.count, 4);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.replays, 2);
    assert_int_equal(counts.rejected[PGEM_REJECT_CONFLICT], 2);
    pgem_ingest_destroy(ingest);
}

static void test_bad_values_rejected(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 0, 0, 0));
    expect_rejected(ingest, PGEM_ROLE_POSE, pose2(2, (double)NAN, 0, 0), PGEM_REJECT_NOT_FINITE);
    expect_rejected(ingest, PGEM_ROLE_POSE, pose2(3, 0, (double)INFINITY, 0), PGEM_REJECT_NOT_FINITE);
    pgem_edge2_t e = edge2_msg(1, 0, 1);
    e.measurement[2] = (double)NAN;
    expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_NOT_FINITE);
    e = edge2_msg(2, 0, 1);
    e.information[1] = (double)INFINITY;
    expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_NOT_FINITE);
    e = edge2_msg(3, 0, 1);
    e.information[5] = -1.0;
    expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_INFORMATION);
    e = edge2_msg(4, 0, 1);
    e.information[1] = 1000.0; /* |xy| > sqrt(xx yy): indefinite */
    expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_INFORMATION);
    expect_rejected(ingest, PGEM_ROLE_EDGE, edge2(5, 1, 1), PGEM_REJECT_SELF_LOOP);
    e = edge2_msg(6, 0, 1);
    e.kind = 7;
    expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_KIND);
    char empty[] = "";
    e = edge2_msg(7, 0, 1);
    e.source = empty;
    expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_SOURCE);
    char name[80];
    memset(name, 'a', sizeof name - 1);
    name[sizeof name - 1] = '\0';
    e.source = name;
    expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_SOURCE);
    /* a rejected message changed nothing: the good one after it gets sequence 1 */
    assert_int_equal(sink.count, 2);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(1, 0, 1)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    pgem_ingest_destroy(ingest);
}

static void test_too_many_sources(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 8, &sink); /* 4 sources */
    char names[5][8] = {"a", "b", "c", "d", "e"};
    for (int s = 0; s < 5; ++s) {
        pgem_edge2_t e = edge2_msg(0, 0, 1);
        e.source = names[s];
        pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
        assert_int_equal(r.verdict, s < 4 ? PGEM_VERDICT_ACCEPTED : PGEM_VERDICT_REJECTED);
    }
    assert_int_equal(pgem_ingest_source_count(ingest), 4);
    pgem_ingest_destroy(ingest);
}

/* Regression: a rejected edge used to register its source name before its checks, so a stream
 * of bad edges under changing names (a broken front-end, random bytes that decode) filled the
 * source table and every later front-end was refused. Only an admitted edge adds a source. */
static void test_rejected_edges_take_no_source(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 8, &sink); /* 4 sources */
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 1, 0, 0));
    char names[8][8] = {"n0", "n1", "n2", "n3", "n4", "n5", "n6", "n7"};
    for (int s = 0; s < 8; ++s) {
        pgem_edge2_t e = edge2_msg(s, 1, 1); /* a self-loop */
        e.source = names[s];
        expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_SELF_LOOP);
        e = edge2_msg(s, 0, 1);
        e.source = names[s];
        e.kind = 9;
        expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_KIND);
    }
    assert_int_equal(pgem_ingest_source_count(ingest), 0);
    char good[] = "late-front-end";
    pgem_edge2_t e = edge2_msg(0, 0, 1);
    e.source = good;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    assert_int_equal(pgem_ingest_source_count(ingest), 1);
    assert_string_equal(pgem_ingest_source_name(ingest, 0), good);
    assert_int_equal(sink.items[sink.count - 1].source, 0);
    pgem_ingest_destroy(ingest);
}

/* A front-end that restarts its numbering: its history resent as it was is all replays and
 * its new edges land; other edges under used numbers are conflicts whose message says what
 * happened and where to resume. */
static void test_restarted_numbering(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 8, &sink);
    for (int id = 0; id < 5; ++id) {
        feed(ingest, PGEM_ROLE_POSE, pose2(id, id, 0, 0));
    }
    for (int k = 0; k < 3; ++k) {
        assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(k, k, k + 1)).verdict,
                         PGEM_VERDICT_ACCEPTED);
    }
    /* restarted with its history: 0..2 again, the same, then 3 */
    for (int k = 0; k < 3; ++k) {
        assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(k, k, k + 1)).verdict,
                         PGEM_VERDICT_REPLAY);
    }
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(3, 3, 4)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    /* restarted without it: sequence 0 now names another edge */
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, edge2(0, 4, 0));
    assert_int_equal(r.verdict, PGEM_VERDICT_REJECTED);
    assert_int_equal(r.reason, PGEM_REJECT_CONFLICT);
    assert_non_null(strstr(r.message, "source 'fe', sequence 0"));
    assert_non_null(strstr(r.message, "its highest is 3"));
    assert_non_null(strstr(r.message, "number on from 4"));
    assert_non_null(strstr(r.message, "new source name"));
    /* resuming above the highest, or under a new name, is accepted */
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(4, 4, 0)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.accepted_edges, 5);
    assert_int_equal(counts.replays, 3);
    assert_int_equal(counts.rejected[PGEM_REJECT_CONFLICT], 1);
    pgem_ingest_destroy(ingest);
}

static void test_garbage_and_truncation(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    wire_t good = edge2(0, 0, 1);
    /* every strict prefix, and one extra byte, is a decode error and changes nothing */
    for (size_t size = 0; size < good.size; ++size) {
        pgem_ingest_result_t r;
        pgem_ingest_message(ingest, PGEM_ROLE_EDGE, good.bytes, size, test_clock, &r);
        assert_int_equal(r.verdict, PGEM_VERDICT_REJECTED);
        assert_int_equal(r.reason, PGEM_REJECT_DECODE);
    }
    wire_t longer = good;
    longer.bytes[longer.size++] = 0;
    expect_rejected(ingest, PGEM_ROLE_EDGE, longer, PGEM_REJECT_DECODE);
    /* a string length that lies (huge, negative, zero, without its NUL) */
    const uint32_t lies[] = {0x7FFFFFFFu, 0xFFFFFFFFu, 0u, 2u};
    for (size_t i = 0; i < sizeof lies / sizeof lies[0]; ++i) {
        wire_t bad = good;
        unsigned char *length = bad.bytes + 16; /* fingerprint, utime */
        length[0] = (unsigned char)(lies[i] >> 24);
        length[1] = (unsigned char)(lies[i] >> 16);
        length[2] = (unsigned char)(lies[i] >> 8);
        length[3] = (unsigned char)lies[i];
        expect_rejected(ingest, PGEM_ROLE_EDGE, bad, PGEM_REJECT_DECODE);
    }
    /* random bytes, and a pose on the edge channel */
    uint64_t seed = 12345;
    for (int trial = 0; trial < 2000; ++trial) {
        wire_t noise;
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        noise.size = (size_t)(seed >> 33) % 200;
        for (size_t b = 0; b < noise.size; ++b) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            noise.bytes[b] = (unsigned char)(seed >> 56);
        }
        pgem_ingest_result_t r = feed(ingest, (pgem_role_t)(trial % 3), noise);
        assert_int_equal(r.verdict, PGEM_VERDICT_REJECTED);
    }
    expect_rejected(ingest, PGEM_ROLE_EDGE, pose2(0, 0, 0, 0), PGEM_REJECT_DECODE);
    assert_int_equal(sink.count, 0);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, good).verdict, PGEM_VERDICT_ACCEPTED);
    pgem_ingest_destroy(ingest);
}

static void test_wrong_dimension(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(3, 10, 10, 4, &sink);
    expect_rejected(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0), PGEM_REJECT_DIMENSION);
    expect_rejected(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1), PGEM_REJECT_DIMENSION);
    pgem_pose3_t p;
    memset(&p, 0, sizeof p);
    p.source = default_source;
    p.pose[6] = 1.0;
    wire_t w;
    w.size = (size_t)pgem_pose3_t_encode(w.bytes, 0, sizeof w.bytes, &p);
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, w).verdict, PGEM_VERDICT_ACCEPTED);
    p.id = 1;
    p.pose[6] = 0.9; /* |q| off 1 by 10% */
    w.size = (size_t)pgem_pose3_t_encode(w.bytes, 0, sizeof w.bytes, &p);
    expect_rejected(ingest, PGEM_ROLE_POSE, w, PGEM_REJECT_ROTATION);
    pgem_edge3_t e;
    memset(&e, 0, sizeof e);
    e.source = default_source;
    e.from = 0;
    e.to = 1;
    e.measurement[6] = 1.0;
    for (int i = 0, k = 0; i < 6; ++i) {
        for (int j = i; j < 6; ++j, ++k) {
            e.information[k] = i == j ? 10.0 : 0.0;
        }
    }
    w.size = (size_t)pgem_edge3_t_encode(w.bytes, 0, sizeof w.bytes, &e);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, w).pending, 1); /* pose 1 was refused */
    pgem_ingest_destroy(ingest);
}

/* Ids travel as int64 and are read as unsigned 64-bit: -1 is 2^64 - 1 and INT64_MIN is 2^63,
 * every value is a valid id (none is reserved), and the messages name them that way. Bad values
 * are rejected with a message naming the pose or edge and the field. */
static void test_ids_at_the_ends_of_the_range(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    const int64_t wire_ids[] = {INT64_MAX, INT64_MIN, -2, -1};
    const pgem_id_t ids[] = {UINT64_C(9223372036854775807), UINT64_C(9223372036854775808),
                             UINT64_C(18446744073709551614), UINT64_C(18446744073709551615)};
    for (int k = 0; k < 4; ++k) {
        assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(wire_ids[k], k, 0, 0)).verdict,
                         PGEM_VERDICT_ACCEPTED);
        assert_true(sink.items[k].from == ids[k]);
    }
    /* INT64_MAX -> INT64_MIN and -2 -> -1 differ by one as unsigned ids (set by hand: their
     * difference overflows int64) */
    pgem_edge2_t top = edge2_msg(0, 0, 1);
    top.from = INT64_MAX;
    top.to = INT64_MIN;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&top)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(1, -2, -1)).verdict, PGEM_VERDICT_ACCEPTED);
    assert_int_equal(sink.count, 6);
    assert_true(sink.items[4].from == ids[0] && sink.items[4].to == ids[1]);
    assert_true(sink.items[5].from == ids[2] && sink.items[5].to == ids[3]);
    /* the same id twice: a replay, or a conflict naming it */
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(-1, 3, 0, 0)).verdict, PGEM_VERDICT_REPLAY);
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_POSE, pose2(-1, 4, 0, 0));
    assert_int_equal(r.reason, PGEM_REJECT_CONFLICT);
    assert_string_equal(r.message, "2D pose 18446744073709551615: the pose already exists with "
                                   "another estimate");
    r = feed(ingest, PGEM_ROLE_EDGE, edge2(2, -1, -1));
    assert_int_equal(r.reason, PGEM_REJECT_SELF_LOOP);
    assert_string_equal(r.message, "edge 18446744073709551615 -> 18446744073709551615 (source "
                                   "'fe', sequence 2): a self-loop");
    r = feed(ingest, PGEM_ROLE_POSE, pose2(7, 0, (double)NAN, 0));
    assert_int_equal(r.reason, PGEM_REJECT_NOT_FINITE);
    assert_string_equal(r.message, "2D pose 7: NaN or Inf in the estimate (field y)");
    pgem_edge2_t e = edge2_msg(3, -2, -1);
    e.measurement[2] = -(double)INFINITY;
    r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_int_equal(r.reason, PGEM_REJECT_NOT_FINITE);
    assert_string_equal(r.message, "edge 18446744073709551614 -> 18446744073709551615 (source "
                                   "'fe', sequence 3): NaN or Inf in the measurement (field theta)");
    e = edge2_msg(4, -2, -1);
    e.information[4] = (double)NAN; /* yt */
    r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_int_equal(r.reason, PGEM_REJECT_NOT_FINITE);
    assert_non_null(strstr(r.message, "information has NaN or Inf (entry 1,2)"));
    e = edge2_msg(5, -2, -1);
    e.information[0] = 0.0;
    r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_int_equal(r.reason, PGEM_REJECT_INFORMATION);
    assert_non_null(strstr(r.message, "(source 'fe', sequence 5): information is not positive "
                                      "definite (entry 0,0)"));
    /* an edge naming a pose that never comes waits, counted, and is not lost */
    r = feed(ingest, PGEM_ROLE_EDGE, edge2(6, -1, 42));
    assert_int_equal(r.verdict, PGEM_VERDICT_ACCEPTED);
    assert_int_equal(r.pending, 1);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.pending, 1);
    assert_int_equal(sink.count, 6);
    pgem_ingest_destroy(ingest);
}

/* A compacting bridge whose compaction can free nothing says so: poses and edges beyond the
 * block are refused as "full" with the reason, replays still recognised; once a compaction
 * frees room the configured capacity holds again. */
static void test_full_block(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 6, 6, 4, &sink);
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 0, 0, 0));
    pgem_ingest_set_full(ingest, 2, 1, "every pose is held");
    expect_rejected(ingest, PGEM_ROLE_POSE, pose2(2, 0, 0, 0), PGEM_REJECT_FULL);
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_POSE, pose2(3, 0, 0, 0));
    assert_non_null(strstr(r.message, "compaction can free nothing (every pose is held)"));
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(1, 0, 0, 0)).verdict, PGEM_VERDICT_REPLAY);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1)).verdict, PGEM_VERDICT_ACCEPTED);
    expect_rejected(ingest, PGEM_ROLE_EDGE, edge2(1, 1, 0), PGEM_REJECT_FULL);
    pgem_ingest_set_full(ingest, 0, 0, NULL);
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(2, 0, 0, 0)).verdict, PGEM_VERDICT_ACCEPTED);
    assert_string_equal(pgem_reject_name(PGEM_REJECT_FULL), "full");
    pgem_ingest_destroy(ingest);
}

static void test_capacity(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 2, 1, 4, &sink);
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 0, 0, 0));
    expect_rejected(ingest, PGEM_ROLE_POSE, pose2(2, 0, 0, 0), PGEM_REJECT_CAPACITY);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    expect_rejected(ingest, PGEM_ROLE_EDGE, edge2(1, 1, 0), PGEM_REJECT_CAPACITY);
    pgem_ingest_destroy(ingest);
}

static void test_commands(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 4, 4, 4, &sink);
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_OPTIMIZE, ""));
    assert_int_equal(r.verdict, PGEM_VERDICT_COMMAND);
    assert_int_equal(r.command, PGEM_COMMAND_T_OPTIMIZE);
    r = feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_SNAPSHOT, "map-1_x.g2o"));
    assert_int_equal(r.verdict, PGEM_VERDICT_COMMAND);
    assert_string_equal(r.path, "map-1_x.g2o");
    expect_rejected(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_SNAPSHOT, ""),
                    PGEM_REJECT_COMMAND);
    expect_rejected(ingest, PGEM_ROLE_COMMAND, command(9, ""), PGEM_REJECT_COMMAND);
    expect_rejected(ingest, PGEM_ROLE_COMMAND, pose2(0, 0, 0, 0), PGEM_REJECT_DECODE);
    /* RESET forgets poses, edges and their keys (capacity is free again) */
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 0, 0, 0));
    feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1));
    feed(ingest, PGEM_ROLE_EDGE, edge2(1, 2, 3)); /* pending */
    r = feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_RESET, ""));
    assert_int_equal(r.verdict, PGEM_VERDICT_COMMAND);
    assert_int_equal(sink.items[sink.count - 1].type, PGEM_ITEM_RESET);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.pending, 0);
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(1, 5, 0, 0)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    pgem_ingest_destroy(ingest);
}

/* A small graph: 6 poses on a line, odometry, two loop closures; all 13 messages. */
static int small_graph(wire_t *messages, pgem_role_t *roles)
{
    int n = 0;
    for (int i = 0; i < 6; ++i) {
        roles[n] = PGEM_ROLE_POSE;
        messages[n++] = pose2(i, i, 0, 0);
    }
    for (int i = 0; i < 5; ++i) {
        roles[n] = PGEM_ROLE_EDGE;
        messages[n++] = edge2(i, i, i + 1);
    }
    roles[n] = PGEM_ROLE_EDGE;
    messages[n++] = edge2(5, 0, 5);
    roles[n] = PGEM_ROLE_EDGE;
    messages[n++] = edge2(6, 1, 4);
    return n;
}

static int compare_items(const void *a, const void *b)
{
    const pgem_item_t *x = a;
    const pgem_item_t *y = b;
    if (x->type != y->type) {
        return x->type < y->type ? -1 : 1;
    }
    if (x->type == PGEM_ITEM_EDGE && x->sequence != y->sequence) {
        return x->sequence < y->sequence ? -1 : 1;
    }
    if (x->from != y->from) {
        return x->from < y->from ? -1 : 1;
    }
    return 0;
}

/* Issue 17: a loop closure with dx = 1e160 was admitted and journaled, and no solve finished
 * again, also after a restart. Translations and information beyond the core's limits are
 * refused (reason range) by name, and reserve nothing. */
static void test_magnitudes_beyond_the_limits(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(3000, 1, 0, 0));
    pgem_edge2_t e = edge2_msg(9, 3000, 0);
    e.measurement[0] = 1e160;
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_int_equal(r.reason, PGEM_REJECT_RANGE);
    assert_string_equal(r.message, "edge 3000 -> 0 (source 'fe', sequence 9): the measurement's x "
                                   "is 1e+160 m, beyond the translation limit of 1e8 m");
    r = feed(ingest, PGEM_ROLE_POSE, pose2(5, 0, -2e8, 0));
    assert_int_equal(r.reason, PGEM_REJECT_RANGE);
    assert_string_equal(r.message, "2D pose 5: the estimate's y is -2e+08 m, beyond the "
                                   "translation limit of 1e8 m");
    e = edge2_msg(10, 3000, 0);
    e.information[4] = -3e15; /* yt */
    r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_int_equal(r.reason, PGEM_REJECT_RANGE);
    assert_non_null(strstr(r.message, "information entry 1,2 is -3e+15, beyond the information "
                                      "limit of 1e15"));
    pgem_pose3_t p;
    memset(&p, 0, sizeof p);
    p.source = default_source;
    p.pose[2] = 1e9;
    p.pose[6] = 1.0;
    wire_t w;
    w.size = (size_t)pgem_pose3_t_encode(w.bytes, 0, sizeof w.bytes, &p);
    pgem_ingest_t *ingest3 = make_ingest(3, 4, 4, 4, &sink);
    expect_rejected(ingest3, PGEM_ROLE_POSE, w, PGEM_REJECT_RANGE);
    pgem_ingest_destroy(ingest3);
    /* at the limits: accepted, the same sequence number still free */
    e = edge2_msg(9, 3000, 0);
    e.measurement[0] = 1e8;
    e.information[0] = 1e15;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.rejected[PGEM_REJECT_RANGE], 3);
    assert_int_equal(counts.accepted_edges, 1);
    pgem_ingest_destroy(ingest);
}

/* Issue 17: a source name that is not UTF-8 was kept, and pgem-lcm-dump's JSON no longer
 * parsed; a newline in it forged log lines. Names must be printable UTF-8; the message shows
 * a refused one escaped. */
static void test_source_names_are_printable_utf8(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 1, 0, 0));
    char *bad[] = {(char *)"fe\xff", (char *)"fe\nrejected (x): forged", (char *)"a\xc3",
                   (char *)"\xc0\xaf", (char *)"rtl\xe2\x80\xae\145vil", (char *)"del\x7f",
                   (char *)"c1\xc2\x85", (char *)"\xed\xa0\x80"};
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
        pgem_edge2_t e = edge2_msg((int64_t)k, 0, 1);
        e.source = bad[k];
        pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
        assert_int_equal(r.reason, PGEM_REJECT_SOURCE);
        assert_null(strchr(r.message, '\n'));
        assert_non_null(strstr(r.message, "is not printable UTF-8"));
    }
    pgem_edge2_t e = edge2_msg(0, 0, 1);
    e.source = bad[1];
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_non_null(strstr(r.message, "edge 0 -> 1 (source 'fe\\x0arejected (x): forged', "
                                      "sequence 0): source name 'fe\\x0arejected"));
    e.source = bad[0];
    r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_string_equal(r.message, "edge 0 -> 1 (source 'fe\\xff', sequence 0): source name "
                                   "'fe\\xff' is not printable UTF-8 (byte 2, 0xff): names appear "
                                   "in logs and JSON");
    assert_int_equal(pgem_ingest_source_count(ingest), 0);
    char good[] = "Roboter-M\xc3\xbcnchen \xe6\x9c\xba\xf0\x9f\xa4\x96";
    e.source = good;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    assert_string_equal(pgem_ingest_source_name(ingest, 0), good);
    pgem_ingest_destroy(ingest);
}

/* Issue 17: kind -1 was reported as "kind 255" (the wire's int8 read as unsigned). */
static void test_kind_named_as_sent(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    pgem_edge2_t e = edge2_msg(0, 0, 1);
    e.kind = -1;
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_int_equal(r.reason, PGEM_REJECT_KIND);
    assert_non_null(strstr(r.message, ": kind -1 is neither ODOMETRY (0) nor LOOP (1)"));
    pgem_ingest_destroy(ingest);
}

/* Issue 17: SNAPSHOT took any path from the network, so any sender could overwrite any file the
 * bridge could write. It is off unless the bridge has a snapshot folder, and then takes a
 * plain file name only. */
static void test_snapshot_takes_a_plain_name(void **state)
{
    (void)state;
    sink_t sink;
    memset(&sink, 0, sizeof sink);
    pgem_ingest_config_t off = {2, 4, 4, 4, 4, 0, 0, 0};
    pgem_ingest_t *ingest = pgem_ingest_create(&off, record, &sink);
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_SNAPSHOT, "map.g2o"));
    assert_int_equal(r.reason, PGEM_REJECT_COMMAND);
    assert_non_null(strstr(r.message, "SNAPSHOT is off: start the bridge with --snapshot-dir"));
    pgem_ingest_destroy(ingest);
    ingest = make_ingest(2, 4, 4, 4, &sink);
    const char *refused[] = {"/etc/passwd", "../map.g2o", "a/b", ".hidden", "..", "map g2o",
                             "map\n", "caf\xc3\xa9", ""};
    for (size_t k = 0; k < sizeof refused / sizeof refused[0]; ++k) {
        r = feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_SNAPSHOT, refused[k]));
        assert_int_equal(r.verdict, PGEM_VERDICT_REJECTED);
        assert_int_equal(r.reason, PGEM_REJECT_COMMAND);
        assert_null(strchr(r.message, '\n'));
    }
    char longest[PGEM_SNAPSHOT_NAME_MAX + 2];
    memset(longest, 'a', sizeof longest);
    longest[PGEM_SNAPSHOT_NAME_MAX] = '\0';
    assert_true(pgem_snapshot_name_ok(longest));
    longest[PGEM_SNAPSHOT_NAME_MAX] = 'a';
    longest[PGEM_SNAPSHOT_NAME_MAX + 1] = '\0';
    assert_false(pgem_snapshot_name_ok(longest));
    assert_true(pgem_snapshot_name_ok("Map_2024-01.01.g2o"));
    pgem_ingest_destroy(ingest);
}

/* Issue 31: a SNAPSHOT named like the journal replaced it. The ingest offers a plain name to
 * the bridge's SNAPSHOT hook; a refusal there is reason command with the hook's message, and
 * a name the hook lets through is the command as before. */
static int refuse_journal_name(void *user, const char *name, char *message, size_t size)
{
    int *asked = user;
    (*asked)++;
    if (strcmp(name, "j.lcmlog") != 0) {
        return 0;
    }
    snprintf(message, size, "SNAPSHOT %s refused: snapshots/%s is the bridge's journal", name,
             name);
    return -1;
}

static void test_snapshot_hook(void **state)
{
    (void)state;
    sink_t sink;
    int asked = 0;
    pgem_ingest_t *ingest = make_ingest(2, 4, 4, 4, &sink);
    pgem_ingest_set_snapshot_check(ingest, refuse_journal_name, &asked);
    pgem_ingest_result_t r =
        feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_SNAPSHOT, "j.lcmlog"));
    assert_int_equal(r.verdict, PGEM_VERDICT_REJECTED);
    assert_int_equal(r.reason, PGEM_REJECT_COMMAND);
    assert_string_equal(r.message, "SNAPSHOT j.lcmlog refused: snapshots/j.lcmlog is the "
                                   "bridge's journal");
    r = feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_SNAPSHOT, "map.g2o"));
    assert_int_equal(r.verdict, PGEM_VERDICT_COMMAND);
    assert_string_equal(r.path, "map.g2o");
    r = feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_SNAPSHOT, "../j.lcmlog"));
    assert_int_equal(r.reason, PGEM_REJECT_COMMAND); /* not a plain name: not even asked */
    assert_int_equal(asked, 2);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.rejected[PGEM_REJECT_COMMAND], 2);
    pgem_ingest_destroy(ingest);
}

/* What the journal's replay asks of a record without a checksum before resuming at it after
 * damage: the exact layout of an input type, any of them, and nothing else. */
static void test_wire_role(void **state)
{
    (void)state;
    wire_t pose = pose2(1, 0, 0, 0);
    wire_t edge = edge2(0, 0, 1);
    wire_t snapshot = command(PGEM_COMMAND_T_SNAPSHOT, "map.g2o");
    assert_int_equal(pgem_ingest_wire_role(pose.bytes, pose.size), PGEM_ROLE_POSE);
    assert_int_equal(pgem_ingest_wire_role(edge.bytes, edge.size), PGEM_ROLE_EDGE);
    assert_int_equal(pgem_ingest_wire_role(snapshot.bytes, snapshot.size), PGEM_ROLE_COMMAND);
    assert_int_equal(pgem_ingest_wire_role(pose.bytes, pose.size - 1), PGEM_ROLE_ANY);
    assert_int_equal(pgem_ingest_wire_role(edge.bytes, edge.size + 1), PGEM_ROLE_ANY);
    edge.bytes[3] ^= 0x10; /* the fingerprint */
    assert_int_equal(pgem_ingest_wire_role(edge.bytes, edge.size), PGEM_ROLE_ANY);
    assert_int_equal(pgem_ingest_wire_role(NULL, 0), PGEM_ROLE_ANY);
}

/* The admit hook (the bridge's journal): a refusal is reason journal, and nothing changes, so
 * the front-end's resend is accepted once the journal takes it. */
typedef struct gate {
    int refuse;   /* refuse everything offered */
    int offered;  /* messages offered */
} gate_t;

static int gate_admit(void *user, const void *data, size_t size, char *message,
                      size_t message_size)
{
    gate_t *gate = user;
    assert_non_null(data);
    assert_true(size > 8);
    gate->offered++;
    if (gate->refuse) {
        snprintf(message, message_size, "j.lcmlog: write failed: No space left on device");
        return -1;
    }
    return 0;
}

static void test_admit_hook_refusal_changes_nothing(void **state)
{
    (void)state;
    sink_t sink;
    gate_t gate = {1, 0};
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    pgem_ingest_set_admit(ingest, gate_admit, &gate);
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    assert_int_equal(r.reason, PGEM_REJECT_JOURNAL);
    assert_string_equal(r.message, "2D pose 0: not accepted, it could not be journaled "
                                   "(j.lcmlog: write failed: No space left on device); nothing "
                                   "changed, resend it");
    expect_rejected(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1), PGEM_REJECT_JOURNAL); /* pending */
    expect_rejected(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_RESET, ""),
                    PGEM_REJECT_JOURNAL);
    /* what does not change the graph is not offered */
    expect_rejected(ingest, PGEM_ROLE_EDGE, edge2(1, 1, 1), PGEM_REJECT_SELF_LOOP);
    assert_int_equal(feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_OPTIMIZE, "")).verdict,
                     PGEM_VERDICT_COMMAND);
    assert_int_equal(gate.offered, 3);
    assert_int_equal(sink.count, 0);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_true(counts.accepted_poses == 0 && counts.accepted_edges == 0 && counts.pending == 0);
    assert_int_equal(counts.rejected[PGEM_REJECT_JOURNAL], 3);
    assert_int_equal(pgem_ingest_source_count(ingest), 0);
    /* the journal has room again: the resends land, none of them a replay */
    gate.refuse = 0;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1)).pending, 1);
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0)).verdict, PGEM_VERDICT_ACCEPTED);
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(1, 1, 0, 0)).verdict, PGEM_VERDICT_ACCEPTED);
    assert_int_equal(sink.count, 3);
    pgem_ingest_counts(ingest, &counts);
    assert_true(counts.accepted_poses == 2 && counts.accepted_edges == 1 && counts.replays == 0);
    pgem_ingest_destroy(ingest);
}

/* Issue 17: 4096 edges to poses that never come filled the pending list for good. An edge now
 * waits at most the pending timeout: then it expires, named and counted, its capacity and key
 * are free (a resend is a new edge) and the accepted count gives it back. */
static void test_pending_edges_expire(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 3, 2, &sink);
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 7)).pending, 1);
    test_clock = 30000000;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(1, 0, 8)).pending, 1);
    expect_rejected(ingest, PGEM_ROLE_EDGE, edge2(2, 0, 9), PGEM_REJECT_PENDING_FULL);
    pgem_ingest_counts_t counts;
    test_clock = PGEM_PENDING_TIMEOUT_DEFAULT; /* exactly the timeout: still waiting */
    assert_int_equal(pgem_ingest_expire(ingest, test_clock), 0);
    test_clock = PGEM_PENDING_TIMEOUT_DEFAULT + 1;
    assert_int_equal(pgem_ingest_expire(ingest, test_clock), 1);
    assert_string_equal(pgem_ingest_last_expiry(ingest),
                        "edge 0 -> 7 (source 'fe', sequence 0) expired: it waited 60.0 s for "
                        "pose 7 (--pending-timeout 60 s)");
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.pending, 1);
    assert_int_equal(counts.accepted_edges, 1);
    assert_int_equal(counts.rejected[PGEM_REJECT_EXPIRED], 1);
    assert_int_equal(counts.received, counts.accepted_poses + counts.accepted_edges +
                                          counts.replays + counts.rejected[PGEM_REJECT_PENDING_FULL] +
                                          counts.rejected[PGEM_REJECT_EXPIRED]);
    /* a message expires what is due before it is handled */
    test_clock = 30000000 + PGEM_PENDING_TIMEOUT_DEFAULT + 1;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(2, 0, 9)).pending, 1);
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.rejected[PGEM_REJECT_EXPIRED], 2);
    /* the expired edge is not a replay when it comes back, and lands once its pose does */
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 7)).verdict, PGEM_VERDICT_ACCEPTED);
    feed(ingest, PGEM_ROLE_POSE, pose2(7, 0, 0, 0));
    assert_int_equal(sink.items[sink.count - 1].sequence, 0);
    pgem_ingest_destroy(ingest);
}

/* A sender that floods the pending list only displaces its own edges: when the list is full, a
 * source holding fewer waiting edges takes the place of the oldest edge of the one holding the
 * most, so both end with an equal share. */
static void test_pending_flood_is_shared_fairly(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 40, 40, 8, &sink);
    char flood[] = "flood";
    for (int k = 0; k < 8; ++k) {
        pgem_edge2_t e = edge2_msg(k, 100 + k, 200 + k);
        e.source = flood;
        assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).pending, 1);
    }
    pgem_edge2_t e = edge2_msg(8, 100, 300);
    e.source = flood;
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_int_equal(r.reason, PGEM_REJECT_PENDING_FULL);
    /* a legitimate front-end's out-of-order edges still wait, up to half the list */
    for (int k = 0; k < 5; ++k) {
        r = feed(ingest, PGEM_ROLE_EDGE, edge2(k, k, k + 1));
        if (k < 4) {
            assert_int_equal(r.pending, 1);
            assert_non_null(strstr(pgem_ingest_last_expiry(ingest),
                                   "(source 'flood', sequence "));
        } else {
            assert_int_equal(r.reason, PGEM_REJECT_PENDING_FULL);
        }
    }
    r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)); /* the flood gets no more room */
    assert_int_equal(r.reason, PGEM_REJECT_PENDING_FULL);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.pending, 8);
    assert_int_equal(counts.rejected[PGEM_REJECT_EXPIRED], 4);
    /* the oldest flood edges went first: 0..3 are free again, 4..7 still wait */
    e = edge2_msg(0, 100, 200);
    e.source = flood;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).reason, PGEM_REJECT_PENDING_FULL);
    e = edge2_msg(4, 104, 204);
    e.source = flood;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).verdict, PGEM_VERDICT_REPLAY);
    for (int id = 0; id < 5; ++id) {
        feed(ingest, PGEM_ROLE_POSE, pose2(id, id, 0, 0));
    }
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.pending, 4); /* the front-end's four edges went into the graph */
    assert_int_equal(sink.count, 9);
    pgem_ingest_destroy(ingest);
}

/* The source table holds sources with an edge in the graph or waiting: one whose edges all
 * expired without ever reaching the graph leaves it, so names that never complete cannot
 * fill it for good; one with an edge in the graph stays. */
static void test_sources_age_out(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 8, &sink); /* 4 sources */
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 1, 0, 0));
    char names[5][8] = {"kept", "h1", "h2", "h3", "late"};
    pgem_edge2_t e = edge2_msg(0, 0, 1);
    e.source = names[0];
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).verdict, PGEM_VERDICT_ACCEPTED);
    for (int s = 1; s < 4; ++s) {
        e = edge2_msg(0, 0, 50 + s); /* waits for a pose that never comes */
        e.source = names[s];
        assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).pending, 1);
    }
    e = edge2_msg(0, 0, 1);
    e.source = names[4];
    expect_rejected(ingest, PGEM_ROLE_EDGE, encode_edge2(&e), PGEM_REJECT_SOURCE);
    e = edge2_msg(1, 1, 60);
    e.source = names[0];
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).pending, 1);
    test_clock = PGEM_PENDING_TIMEOUT_DEFAULT + 1;
    assert_int_equal(pgem_ingest_expire(ingest, test_clock), 4);
    assert_int_equal(pgem_ingest_source_count(ingest), 1); /* "kept" has an edge in the graph */
    assert_string_equal(pgem_ingest_source_name(ingest, 0), "kept");
    e = edge2_msg(0, 0, 1);
    e.source = names[4];
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).verdict, PGEM_VERDICT_ACCEPTED);
    assert_string_equal(pgem_ingest_source_name(ingest, 1), "late");
    assert_int_equal(sink.items[sink.count - 1].source, 1);
    pgem_ingest_destroy(ingest);
}

static void test_order_and_replay_determinism(void **state)
{
    (void)state;
    wire_t messages[16];
    pgem_role_t roles[16];
    int n = small_graph(messages, roles);
    sink_t in_order;
    pgem_ingest_t *a = make_ingest(2, 8, 8, 8, &in_order);
    for (int i = 0; i < n; ++i) {
        feed(a, roles[i], messages[i]);
    }
    /* reversed and doubled: the same items (as a set), every copy a replay */
    static sink_t reversed;
    pgem_ingest_t *b = make_ingest(2, 8, 8, 8, &reversed);
    for (int i = n - 1; i >= 0; --i) {
        feed(b, roles[i], messages[i]);
        assert_int_equal(feed(b, roles[i], messages[i]).verdict, PGEM_VERDICT_REPLAY);
    }
    assert_int_equal(in_order.count, n);
    assert_int_equal(reversed.count, n);
    qsort(in_order.items, (size_t)n, sizeof(pgem_item_t), compare_items);
    qsort(reversed.items, (size_t)n, sizeof(pgem_item_t), compare_items);
    assert_memory_equal(in_order.items, reversed.items, (size_t)n * sizeof(pgem_item_t));
    /* the accepted messages fed again, by fingerprint (as a journal replay does), give the
     * identical item sequence */
    static sink_t first;
    static sink_t again;
    pgem_ingest_t *c = make_ingest(2, 8, 8, 8, &first);
    pgem_ingest_t *d = make_ingest(2, 8, 8, 8, &again);
    for (int i = n - 1; i >= 0; --i) {
        feed(c, roles[i], messages[i]);
        feed(d, PGEM_ROLE_ANY, messages[i]);
    }
    assert_int_equal(first.count, again.count);
    assert_memory_equal(first.items, again.items, (size_t)first.count * sizeof(pgem_item_t));
    pgem_ingest_destroy(a);
    pgem_ingest_destroy(b);
    pgem_ingest_destroy(c);
    pgem_ingest_destroy(d);
}

static void test_any_role_ignores_other_types(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 4, 4, 4, &sink);
    pgem_graph_t graph;
    memset(&graph, 0, sizeof graph);
    char empty[] = "";
    graph.stats.trigger = empty;
    graph.stats.message = empty;
    wire_t w;
    w.size = (size_t)pgem_graph_t_encode(w.bytes, 0, sizeof w.bytes, &graph);
    assert_int_equal(feed(ingest, PGEM_ROLE_ANY, w).verdict, PGEM_VERDICT_IGNORED);
    assert_int_equal(feed(ingest, PGEM_ROLE_ANY, pose2(0, 0, 0, 0)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.received, 1);
    pgem_ingest_destroy(ingest);
}

/* The bridge's robust options: zeroed means EM; --robust none keeps kernel NONE; any
 * kernel given, and the options beside it, pass through unchanged. */
static void test_robust_option_defaults(void **state)
{
    pgem_bridge_options_t options;
    (void)state;
    memset(&options, 0, sizeof options);
    pgem_bridge_defaults(&options);
    assert_int_equal(options.robust.kernel, PGEM_KERNEL_EM);
    memset(&options, 0, sizeof options);
    options.robust.kernel = PGEM_KERNEL_NONE;
    pgem_bridge_defaults(&options);
    assert_int_equal(options.robust.kernel, PGEM_KERNEL_NONE);
    memset(&options, 0, sizeof options);
    options.robust.kernel = PGEM_KERNEL_DCS;
    options.robust.restart = 1;
    options.robust.dormant_threshold = -1.0;
    pgem_bridge_defaults(&options);
    assert_int_equal(options.robust.kernel, PGEM_KERNEL_DCS);
    assert_int_equal(options.robust.restart, 1);
    assert_true(options.robust.dormant_threshold == -1.0);
}

/* Issue 31, row 5: the wire cannot vouch for itself. An edge sent as ODOMETRY is odometry for
 * the robust layer (weight 1, never pruned) only when it is a step of its source's chain: its
 * poses' ids differ by one, and no odometry edge joins those two poses yet. Otherwise it
 * enters as a loop closure, accepted and named; a source's honest chain is unaffected,
 * whatever the order of arrival. */
static void test_odometry_checked_against_the_chain(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 40, 40, 8, &sink);
    for (int id = 0; id <= 25; ++id) {
        feed(ingest, PGEM_ROLE_POSE, pose2(id, id, 0, 0));
    }
    for (int k = 0; k < 25; ++k) {
        assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(k, k, k + 1)).verdict,
                         PGEM_VERDICT_ACCEPTED);
        assert_int_equal(sink.items[sink.count - 1].kind, PGEM_EDGE_ODOMETRY);
    }
    assert_string_equal(pgem_ingest_last_odometry_note(ingest), "");
    /* a new source claims odometry between poses 2 and 25, with a false measurement */
    char intruder[] = "intruder";
    pgem_edge2_t attack = edge2_msg(0, 2, 25);
    attack.source = intruder;
    attack.kind = PGEM_EDGE2_T_ODOMETRY;
    attack.measurement[0] = 40.0;
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&attack));
    assert_int_equal(r.verdict, PGEM_VERDICT_ACCEPTED);
    const pgem_item_t *item = &sink.items[sink.count - 1];
    assert_true(item->from == 2 && item->to == 25);
    assert_int_equal(item->kind, PGEM_EDGE_LOOP);
    assert_string_equal(pgem_ingest_last_odometry_note(ingest),
                        "edge 2 -> 25 (source 'intruder', sequence 0) was sent as ODOMETRY "
                        "but poses 2 and 25 are not consecutive ids: it enters as a loop "
                        "closure");
    /* the same source again as a replay: still a replay (the kind sent is its content) */
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&attack)).verdict,
                     PGEM_VERDICT_REPLAY);
    /* a step another source already made: a second opinion, so a loop closure */
    pgem_edge2_t step = edge2_msg(1, 3, 4);
    step.source = intruder;
    step.measurement[0] = -3.0;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&step)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    assert_int_equal(sink.items[sink.count - 1].kind, PGEM_EDGE_LOOP);
    assert_non_null(strstr(pgem_ingest_last_odometry_note(ingest),
                           "edge 3 -> 4 (source 'intruder', sequence 1) was sent as ODOMETRY "
                           "but poses 3 and 4 are already joined by odometry of source 'fe'"));
    /* the source's own step again, under another number, or reversed: the same */
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(100, 6, 5)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    assert_int_equal(sink.items[sink.count - 1].kind, PGEM_EDGE_LOOP);
    assert_non_null(strstr(pgem_ingest_last_odometry_note(ingest), "of source 'fe'"));
    /* sent as LOOP: nothing to say */
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(101, 1, 20)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    assert_int_equal(sink.items[sink.count - 1].kind, PGEM_EDGE_LOOP);
    pgem_ingest_counts_t counts;
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.odometry_as_loops, 3);
    assert_int_equal(counts.accepted_edges, 29);
    /* a second front-end's chain, arriving before its poses (and backwards), is odometry */
    char second[] = "fe-2";
    for (int k = 2; k >= 0; --k) {
        pgem_edge2_t e = edge2_msg(k, 30 + k, 31 + k);
        e.source = second;
        assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e)).pending, 1);
    }
    pgem_edge2_t bridge_step = edge2_msg(3, 25, 30);
    bridge_step.source = second;
    bridge_step.kind = PGEM_EDGE2_T_ODOMETRY; /* not consecutive: waits, then a loop */
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&bridge_step)).pending, 1);
    int before = sink.count;
    for (int id = 33; id >= 30; --id) {
        feed(ingest, PGEM_ROLE_POSE, pose2(id, id, 0, 0));
    }
    assert_int_equal(sink.count, before + 8);
    int odometry = 0;
    for (int i = before; i < sink.count; ++i) {
        if (sink.items[i].type == PGEM_ITEM_EDGE) {
            odometry += sink.items[i].kind == PGEM_EDGE_ODOMETRY;
            assert_int_equal(sink.items[i].kind, sink.items[i].from == 25 ? PGEM_EDGE_LOOP
                                                                          : PGEM_EDGE_ODOMETRY);
        }
    }
    assert_int_equal(odometry, 3);
    pgem_ingest_counts(ingest, &counts);
    assert_int_equal(counts.odometry_as_loops, 4);
    /* RESET forgets the steps: the intruder's step is odometry in a new graph */
    feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_RESET, ""));
    feed(ingest, PGEM_ROLE_POSE, pose2(3, 3, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(4, 4, 0, 0));
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&step)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    assert_int_equal(sink.items[sink.count - 1].kind, PGEM_EDGE_ODOMETRY);
    pgem_ingest_destroy(ingest);
}

/* Issue 32: after a compaction the ingest frees the removed poses' capacity and keys; a later
 * edge naming a removed pose enters on its anchor (the measurement composed with where the
 * anchor lies in the removed pose's frame, through an anchor removed since too), as a loop
 * closure; a pose message with a removed id is refused as removed; a resend of a kept edge is
 * still a replay. */
static void test_release_and_anchors(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 4, 8, 4, &sink);
    for (int64_t id = 0; id < 4; ++id) {
        feed(ingest, PGEM_ROLE_POSE, pose2(id, (double)id, 0, 0));
    }
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(0, 0, 1)).verdict, PGEM_VERDICT_ACCEPTED);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(1, 1, 2)).verdict, PGEM_VERDICT_ACCEPTED);
    expect_rejected(ingest, PGEM_ROLE_POSE, pose2(4, 4, 0, 0), PGEM_REJECT_CAPACITY);
    /* poses 1 and 2 removed: 1 anchored on 0 (1 m behind it), 2 on 1 (1 m behind) */
    const pgem_id_t ids[2] = {1, 2}, anchors[2] = {0, 1};
    const double relative[6] = {-1.0, 0.0, 0.0, -1.0, 0.0, 0.0};
    const pgem_ingest_released_t edges[1] = {{0, 1}};
    pgem_ingest_release(ingest, ids, anchors, relative, 2, edges, 1);
    assert_int_equal(feed(ingest, PGEM_ROLE_POSE, pose2(4, 4, 0, 0)).verdict, PGEM_VERDICT_ACCEPTED);
    expect_rejected(ingest, PGEM_ROLE_POSE, pose2(2, 2, 0, 0), PGEM_REJECT_REMOVED);
    const int before = sink.count;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(7, 3, 2)).verdict, PGEM_VERDICT_ACCEPTED);
    assert_int_equal(sink.count, before + 1);
    const pgem_item_t *moved = &sink.items[sink.count - 1];
    assert_int_equal(moved->from, 3);
    assert_int_equal(moved->to, 0);   /* 2 -> 1 -> 0 */
    assert_int_equal(moved->kind, PGEM_EDGE_LOOP);
    assert_true(fabs(moved->value[0] - (1.0 - 2.0)) < 1e-12); /* 1 m, then 2 m back */
    assert_int_equal(pgem_ingest_reanchored(ingest), 1);
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(7, 3, 2)).verdict, PGEM_VERDICT_REPLAY);
    pgem_ingest_destroy(ingest);
}

/* Issue 32: the ingest remembers 4 x max_poses removed ids; an edge naming one it has forgotten
 * is refused as forgotten, naming the pose, instead of waiting for a pose that never comes; an
 * edge to an id beyond every forgotten range still waits for its pose. */
static void test_forgotten_anchor(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 2, 8, 4, &sink); /* remembers 8 removed ids */
    feed(ingest, PGEM_ROLE_POSE, pose2(100, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(50, 0, 0, 0));
    pgem_id_t ids[12], anchors[12];
    double relative[36] = {0.0};
    for (int i = 0; i < 12; ++i) {
        ids[i] = (pgem_id_t)i;
        anchors[i] = 50;
        feed(ingest, PGEM_ROLE_POSE, pose2(i, (double)i, 0, 0));
        pgem_ingest_release(ingest, ids + i, anchors + i, relative + 3 * i, 1, NULL, 0);
    }
    /* 0..3 forgotten, 4..11 remembered */
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, edge2(1, 100, 2));
    assert_int_equal(r.verdict, PGEM_VERDICT_REJECTED);
    assert_int_equal(r.reason, PGEM_REJECT_FORGOTTEN);
    assert_non_null(strstr(r.message, "pose 2 was removed from the map long ago"));
    assert_string_equal(pgem_reject_name(PGEM_REJECT_FORGOTTEN), "forgotten");
    const int before = sink.count;
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(2, 100, 9)).verdict, PGEM_VERDICT_ACCEPTED);
    assert_int_equal(sink.count, before + 1); /* on its anchor, 50 */
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(3, 100, 500)).verdict,
                     PGEM_VERDICT_ACCEPTED); /* waits for pose 500 */
    assert_int_equal(sink.count, before + 1);
    pgem_ingest_destroy(ingest);
}

/* Issue 31, row 9 (c): the conflict message after sequence INT64_MAX computed "number on from
 * INT64_MAX + 1", a signed overflow. */
static void test_conflict_at_the_highest_sequence(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    feed(ingest, PGEM_ROLE_POSE, pose2(0, 0, 0, 0));
    feed(ingest, PGEM_ROLE_POSE, pose2(1, 1, 0, 0));
    assert_int_equal(feed(ingest, PGEM_ROLE_EDGE, edge2(INT64_MAX, 0, 1)).verdict,
                     PGEM_VERDICT_ACCEPTED);
    pgem_edge2_t other = edge2_msg(INT64_MAX, 0, 1);
    other.measurement[0] = 2.0;
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&other));
    assert_int_equal(r.reason, PGEM_REJECT_CONFLICT);
    assert_non_null(strstr(r.message, "its highest is 9223372036854775807, the largest there "
                                      "is: a restarted front-end must use a new source name"));
    assert_null(strstr(r.message, "number on from"));
    pgem_ingest_destroy(ingest);
}

/* Issue 31, row 9 (g): an information that is positive definite but beyond double
 * precision's reach is named as such, not "not positive definite". */
static void test_information_badly_conditioned(void **state)
{
    (void)state;
    sink_t sink;
    pgem_ingest_t *ingest = make_ingest(2, 10, 10, 4, &sink);
    pgem_edge2_t e = edge2_msg(0, 0, 1);
    e.information[0] = 1e15;
    e.information[3] = 1e15;
    e.information[5] = 1e-3;
    pgem_ingest_result_t r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_int_equal(r.reason, PGEM_REJECT_INFORMATION);
    assert_string_equal(r.message, "edge 0 -> 1 (source 'fe', sequence 0): information is "
                                   "positive definite but too badly conditioned to factor in "
                                   "double precision (entry 2,2: a condition number beyond "
                                   "about 1e15)");
    e.information[5] = 0.0;
    r = feed(ingest, PGEM_ROLE_EDGE, encode_edge2(&e));
    assert_non_null(strstr(r.message, "information is not positive definite (entry 2,2)"));
    pgem_ingest_destroy(ingest);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_in_order_stream),
        cmocka_unit_test(test_edges_wait_for_poses),
        cmocka_unit_test(test_pending_is_bounded),
        cmocka_unit_test(test_replays_and_conflicts),
        cmocka_unit_test(test_bad_values_rejected),
        cmocka_unit_test(test_too_many_sources),
        cmocka_unit_test(test_rejected_edges_take_no_source),
        cmocka_unit_test(test_restarted_numbering),
        cmocka_unit_test(test_garbage_and_truncation),
        cmocka_unit_test(test_wrong_dimension),
        cmocka_unit_test(test_capacity),
        cmocka_unit_test(test_full_block),
        cmocka_unit_test(test_forgotten_anchor),
        cmocka_unit_test(test_ids_at_the_ends_of_the_range),
        cmocka_unit_test(test_commands),
        cmocka_unit_test(test_magnitudes_beyond_the_limits),
        cmocka_unit_test(test_source_names_are_printable_utf8),
        cmocka_unit_test(test_kind_named_as_sent),
        cmocka_unit_test(test_snapshot_takes_a_plain_name),
        cmocka_unit_test(test_snapshot_hook),
        cmocka_unit_test(test_wire_role),
        cmocka_unit_test(test_admit_hook_refusal_changes_nothing),
        cmocka_unit_test(test_pending_edges_expire),
        cmocka_unit_test(test_pending_flood_is_shared_fairly),
        cmocka_unit_test(test_sources_age_out),
        cmocka_unit_test(test_order_and_replay_determinism),
        cmocka_unit_test(test_any_role_ignores_other_types),
        cmocka_unit_test(test_robust_option_defaults),
        cmocka_unit_test(test_odometry_checked_against_the_chain),
        cmocka_unit_test(test_conflict_at_the_highest_sequence),
        cmocka_unit_test(test_release_and_anchors),
        cmocka_unit_test(test_information_badly_conditioned),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
