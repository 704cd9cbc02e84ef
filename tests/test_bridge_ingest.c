/* The bridge's reception state machine: decoding, validation, replays, conflicts, pending
 * edges, capacity, commands and determinism, on messages encoded with the lcm-gen types. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

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

static pgem_ingest_t *make_ingest(int dimension, uint32_t poses, uint32_t edges,
                                  uint32_t pending, sink_t *sink)
{
    memset(sink, 0, sizeof *sink);
    pgem_ingest_config_t config = {dimension, poses, edges, pending, 4};
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
    pgem_ingest_message(ingest, role, w.bytes, w.size, &result);
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
        pgem_ingest_message(ingest, PGEM_ROLE_EDGE, good.bytes, size, &r);
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
    r = feed(ingest, PGEM_ROLE_COMMAND, command(PGEM_COMMAND_T_SNAPSHOT, "/tmp/x.g2o"));
    assert_int_equal(r.verdict, PGEM_VERDICT_COMMAND);
    assert_string_equal(r.path, "/tmp/x.g2o");
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
        cmocka_unit_test(test_ids_at_the_ends_of_the_range),
        cmocka_unit_test(test_commands),
        cmocka_unit_test(test_order_and_replay_determinism),
        cmocka_unit_test(test_any_role_ignores_other_types),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
