/* Fuzz target: the bridge's reception state machine (lib/bridge/ingest.h), no threads or
 * network. A header chooses the dimension and small capacities; then each record is one
 * message on a channel (pose, edge, command, or any, as a journal replays): raw bytes, a
 * message built from fields in the input and encoded with the lcm-gen encoders (ids, values,
 * information, kinds, sources, commands, so the state machine is reached), such a message
 * then damaged (truncated, extended, a byte flipped, a lying string length), or an exact
 * repeat of an earlier record. Message k arrives at time k (microseconds), the header picks a
 * pending timeout of a few messages, whether SNAPSHOT is on and whether the admit hook (the
 * journal) refuses some messages. Checks:
 * - every message gets exactly one verdict and one counter moves for it: accepted (pose or
 *   edge), replay, rejected with a reason and a message, a command, or ignored (channel "any"
 *   only), besides edges that expired (they move from accepted to `expired`); `received`
 *   counts the pose and edge channels' messages;
 * - a message the admit hook refused changed nothing but its own counter;
 * - the pending list and the capacity reservations stay within their limits;
 * - every emitted item fits a core instance of the bridge's capacities (pgem_add_pose,
 *   pgem_add_edge and pgem_fix_pose accept it; RESET starts a new one): an admitted item is
 *   never refused by the core;
 * - feeding only the accepted messages and RESET commands again, in order and with their
 *   times, to a new state machine on channel "any" with no admit hook (what the journal replay
 *   does) emits exactly the same items. */
#include "fuzz.h"
#include "fuzz_input.h"
#include "ingest.h"
#include "pgem/pgem.h"
#include "pgem_command_t.h"
#include "pgem_edge2_t.h"
#include "pgem_edge3_t.h"
#include "pgem_pose2_t.h"
#include "pgem_pose3_t.h"

#define MAX_MESSAGES 256u
#define MESSAGE_MAX 2048u   /* bytes of one message (a command with a 1 KiB path fits) */
#define MAX_ITEMS 1024u
#define ID_RANGE 24u        /* small pose ids */
#define SEQUENCE_RANGE 16u  /* small sequence numbers */

/* ---- what the state machine emits -------------------------------------------------------- */

typedef struct sink {
    pgem_item_t items[MAX_ITEMS];
    char sources[MAX_ITEMS][PGEM_SOURCE_MAX];  /* the name behind each item's source index */
    uint32_t count;
    const pgem_ingest_t *ingest;
    int dimension;
    pgem_config_t config;
    unsigned char *block;                      /* the core instance items are added to */
    size_t block_size;
    pgem_t *core;
    uint32_t poses_since_reset;
    uint32_t edges_since_reset;
} sink_t;

static void core_reset(sink_t *sink)
{
    FUZZ_CHECK(pgem_init(&sink->core, &sink->config, sink->block, sink->block_size) == PGEM_OK);
    sink->poses_since_reset = 0;
    sink->edges_since_reset = 0;
}

static void emit(void *user, const pgem_item_t *item)
{
    sink_t *sink = user;
    FUZZ_CHECK(sink->count < MAX_ITEMS);
    sink->items[sink->count] = *item;
    const char *source = item->type == PGEM_ITEM_EDGE
                             ? pgem_ingest_source_name(sink->ingest, item->source) : "";
    snprintf(sink->sources[sink->count], PGEM_SOURCE_MAX, "%s", source);
    sink->count++;
    if (item->type == PGEM_ITEM_RESET) {
        core_reset(sink);
        return;
    }
    if (item->type == PGEM_ITEM_POSE) {
        int status = pgem_add_pose(sink->core, item->from, item->value);
        if (status == PGEM_OK && item->kind) {
            status = pgem_fix_pose(sink->core, item->from, 1);
        }
        if (status != PGEM_OK) {
            fprintf(stderr, "core refused pose %llu: %s\n", (unsigned long long)item->from,
                    pgem_last_error(sink->core));
        }
        FUZZ_CHECK(status == PGEM_OK);
        sink->poses_since_reset++;
        return;
    }
    FUZZ_CHECK(item->type == PGEM_ITEM_EDGE);
    FUZZ_CHECK(source[0] != '\0');
    double information[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    pgem_upper_to_full(item->information, PGEM_TANGENT_SIZE(sink->dimension), information);
    int status = pgem_add_edge(sink->core, item->from, item->to, item->value, information,
                               (pgem_edge_kind_t)item->kind, NULL);
    if (status != PGEM_OK) {
        fprintf(stderr, "core refused edge %llu -> %llu: %s\n", (unsigned long long)item->from,
                (unsigned long long)item->to, pgem_last_error(sink->core));
    }
    FUZZ_CHECK(status == PGEM_OK);
    sink->edges_since_reset++;
}

static void sink_init(sink_t *sink, const pgem_ingest_config_t *config)
{
    memset(sink, 0, sizeof *sink);
    sink->dimension = config->dimension;
    sink->config.dimension = config->dimension;
    sink->config.max_poses = config->max_poses;
    sink->config.max_edges = config->max_edges;
    sink->block_size = pgem_memory_size(&sink->config);
    sink->block = malloc(sink->block_size);
    FUZZ_CHECK(sink->block != NULL);
    core_reset(sink);
}

/* ---- building messages ------------------------------------------------------------------- */

typedef struct message {
    pgem_role_t role;
    int64_t utime;  /* when it arrived */
    uint8_t bytes[MESSAGE_MAX];
    size_t size;
} message_t;

static const char *source_name(uint8_t b)
{
    static const char *const names[] = {
        "fe", "a", "robot_1", "b", "", "\x7f\xfe",
        "xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx",   /* 63 bytes */
        "yyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyyy"}; /* 64 bytes */
    return names[b % (sizeof names / sizeof names[0])];
}

/* A pose or measurement; mode bit 0 normalises a 3D quaternion. */
static void read_values(fuzz_input_t *in, int dimension, uint8_t mode, double *values)
{
    for (int k = 0; k < PGEM_POSE_SIZE(dimension); ++k) {
        values[k] = fuzz_value(in);
    }
    if (dimension == 3 && (mode & 1u)) {
        double *q = values + 3;
        double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
        if (isfinite(norm) && norm > 0.0) {
            for (int k = 0; k < 4; ++k) {
                q[k] /= norm;
            }
        }
    }
}

/* An upper triangle: a scaled identity, a diagonal, or every value from the input. */
static void read_upper(fuzz_input_t *in, int dimension, double *upper)
{
    const int n = PGEM_TANGENT_SIZE(dimension);
    uint8_t mode = fuzz_byte(in) % 3u;
    double scale = mode == 0 ? fuzz_value(in) : 0.0;
    int k = 0;
    for (int i = 0; i < n; ++i) {
        for (int j = i; j < n; ++j, ++k) {
            upper[k] = mode == 2 ? fuzz_value(in) : i != j ? 0.0 : mode == 0 ? scale : fuzz_value(in);
        }
    }
}

static void build_pose(fuzz_input_t *in, int dimension, int64_t utime, message_t *m)
{
    char source[PGEM_SOURCE_MAX + 1];
    snprintf(source, sizeof source, "%s", source_name(fuzz_byte(in)));
    int64_t id = (int64_t)fuzz_id(in, ID_RANGE);
    uint8_t mode = fuzz_byte(in);
    int size;
    if (dimension == 2) {
        pgem_pose2_t pose = {utime, source, id, {0}, (int8_t)((mode >> 1) & 1u)};
        read_values(in, 2, mode, pose.pose);
        size = pgem_pose2_t_encode(m->bytes, 0, (int)sizeof m->bytes, &pose);
    } else {
        pgem_pose3_t pose = {utime, source, id, {0}, (int8_t)((mode >> 1) & 1u)};
        read_values(in, 3, mode, pose.pose);
        size = pgem_pose3_t_encode(m->bytes, 0, (int)sizeof m->bytes, &pose);
    }
    FUZZ_CHECK(size > 0);
    m->size = (size_t)size;
}

static void build_edge(fuzz_input_t *in, int dimension, int64_t utime, message_t *m)
{
    char source[PGEM_SOURCE_MAX + 1];
    snprintf(source, sizeof source, "%s", source_name(fuzz_byte(in)));
    int64_t sequence = (int64_t)fuzz_id(in, SEQUENCE_RANGE);
    int64_t from = (int64_t)fuzz_id(in, ID_RANGE);
    int64_t to = (int64_t)fuzz_id(in, ID_RANGE);
    uint8_t kind_byte = fuzz_byte(in);
    int8_t kind = kind_byte < 0xF0u ? (int8_t)(kind_byte & 1u) : (int8_t)kind_byte;
    uint8_t mode = fuzz_byte(in);
    int size;
    if (dimension == 2) {
        pgem_edge2_t edge;
        memset(&edge, 0, sizeof edge);
        edge.utime = utime;
        edge.source = source;
        edge.sequence = sequence;
        edge.from = from;
        edge.to = to;
        edge.kind = kind;
        read_values(in, 2, mode, edge.measurement);
        read_upper(in, 2, edge.information);
        size = pgem_edge2_t_encode(m->bytes, 0, (int)sizeof m->bytes, &edge);
    } else {
        pgem_edge3_t edge;
        memset(&edge, 0, sizeof edge);
        edge.utime = utime;
        edge.source = source;
        edge.sequence = sequence;
        edge.from = from;
        edge.to = to;
        edge.kind = kind;
        read_values(in, 3, mode, edge.measurement);
        read_upper(in, 3, edge.information);
        size = pgem_edge3_t_encode(m->bytes, 0, (int)sizeof m->bytes, &edge);
    }
    FUZZ_CHECK(size > 0);
    m->size = (size_t)size;
}

static void build_command(fuzz_input_t *in, int64_t utime, message_t *m)
{
    static char path[PGEM_PATH_MAX + 1];
    uint8_t what = fuzz_byte(in);
    uint8_t path_choice = fuzz_byte(in) % 4u;
    size_t length = path_choice == 0 ? 0 : path_choice == 1 ? 7 : PGEM_PATH_MAX - 3 + path_choice;
    memset(path, 'p', length);
    path[length] = '\0';
    pgem_command_t command = {utime, what < 0xF0u ? (int8_t)(1 + what % 3u) : (int8_t)what, path};
    int size = pgem_command_t_encode(m->bytes, 0, (int)sizeof m->bytes, &command);
    FUZZ_CHECK(size > 0);
    m->size = (size_t)size;
}

/* Damages an encoded message: cut its end, add bytes, flip a byte, or overwrite the string's
 * length field (a lying length). */
static void damage(fuzz_input_t *in, message_t *m, int is_command)
{
    uint8_t op = fuzz_byte(in) % 4u;
    uint8_t amount = fuzz_byte(in);
    if (op == 0) {
        size_t cut = 1u + amount % 32u;
        m->size = m->size > cut ? m->size - cut : 0;
    } else if (op == 1) {
        for (unsigned i = 0; i <= amount % 16u && m->size < MESSAGE_MAX; ++i) {
            m->bytes[m->size++] = fuzz_byte(in);
        }
    } else if (op == 2) {
        if (m->size > 0) {
            m->bytes[(size_t)amount * 7u % m->size] ^= (uint8_t)(fuzz_byte(in) | 1u);
        }
    } else {
        size_t at = is_command ? 17u : 16u;
        for (size_t i = at; i < at + 4u && i < m->size; ++i) {
            m->bytes[i] = i == at + 3u ? amount : fuzz_byte(in);
        }
    }
}

/* ---- one run ----------------------------------------------------------------------------- */

enum { FORM_RAW = 0, FORM_BUILD = 1, FORM_DAMAGED = 2, FORM_REPEAT = 3 };
enum { BUILD_POSE2 = 0, BUILD_POSE3, BUILD_EDGE2, BUILD_EDGE3, BUILD_COMMAND, BUILD_EXPECTED };

typedef struct run {
    pgem_ingest_config_t config;
    message_t messages[MAX_MESSAGES];
    uint32_t message_count;
    message_t journal[MAX_MESSAGES];  /* accepted messages and RESET commands, in order */
    uint32_t journal_count;
    int64_t command_channel_rejections;
    unsigned refusals;                /* 0: the admit hook takes everything; else it refuses
                                         the messages whose number is 0 mod refusals + 1 */
    int refused_now;                  /* the hook refused the message being fed */
} run_t;

static run_t run;

/* Reads the next record into m; 0 when the input has no more. */
static int read_record(fuzz_input_t *in, message_t *m)
{
    if (!fuzz_more(in)) {
        return 0;
    }
    uint8_t selector = fuzz_byte(in);
    m->role = (pgem_role_t)(selector & 3u);
    unsigned form = (selector >> 2) & 3u;
    unsigned type = (selector >> 4) & 7u;
    int64_t utime = (int64_t)run.message_count + 1;
    if (form == FORM_REPEAT && run.message_count > 0) {
        *m = run.messages[fuzz_byte(in) % run.message_count];
        m->utime = utime;
        return 1;
    }
    m->utime = utime;
    if (form == FORM_RAW || form == FORM_REPEAT) {
        size_t length = fuzz_byte(in);
        length |= (size_t)fuzz_byte(in) << 8;
        length %= MESSAGE_MAX;
        m->size = 0;
        while (m->size < length && fuzz_more(in)) {
            m->bytes[m->size++] = fuzz_byte(in);
        }
        return 1;
    }
    if (type >= BUILD_EXPECTED) { /* the type this channel of this bridge takes */
        int three = run.config.dimension == 3;
        type = m->role == PGEM_ROLE_EDGE ? BUILD_EDGE2 + (unsigned)three
               : m->role == PGEM_ROLE_COMMAND ? BUILD_COMMAND : BUILD_POSE2 + (unsigned)three;
    }
    if (type == BUILD_POSE2 || type == BUILD_POSE3) {
        build_pose(in, type == BUILD_POSE2 ? 2 : 3, utime, m);
    } else if (type == BUILD_EDGE2 || type == BUILD_EDGE3) {
        build_edge(in, type == BUILD_EDGE2 ? 2 : 3, utime, m);
    } else {
        build_command(in, utime, m);
    }
    if (form == FORM_DAMAGED) {
        damage(in, m, type == BUILD_COMMAND);
    }
    return 1;
}

static int64_t rejected_total(const pgem_ingest_counts_t *counts)
{
    int64_t total = 0;
    for (int r = 0; r < PGEM_REJECT_COUNT; ++r) {
        total += counts->rejected[r];
    }
    return total;
}

/* One counter moved for the verdict, and only that one (edges that expired meanwhile moved
 * from accepted to expired). */
static void check_counts(const pgem_ingest_counts_t *a, const pgem_ingest_counts_t *b,
                         const pgem_ingest_result_t *result, pgem_role_t role)
{
    int64_t expired = b->rejected[PGEM_REJECT_EXPIRED] - a->rejected[PGEM_REJECT_EXPIRED];
    int64_t received = b->received - a->received;
    int64_t accepted = (b->accepted_poses - a->accepted_poses) +
                       (b->accepted_edges - a->accepted_edges) + expired;
    int64_t replays = b->replays - a->replays;
    int64_t commands = b->commands - a->commands;
    int64_t rejected = rejected_total(b) - rejected_total(a) - expired;
    FUZZ_CHECK(expired >= 0);
    FUZZ_CHECK(result->verdict != PGEM_VERDICT_REJECTED ||
               result->reason != PGEM_REJECT_EXPIRED);
    FUZZ_CHECK(run.refused_now == (result->verdict == PGEM_VERDICT_REJECTED &&
                                   result->reason == PGEM_REJECT_JOURNAL));
    FUZZ_CHECK(received == 0 || received == 1);
    switch (result->verdict) {
    case PGEM_VERDICT_ACCEPTED:
        FUZZ_CHECK(accepted == 1 && replays == 0 && rejected == 0 && commands == 0);
        FUZZ_CHECK(received == 1);
        break;
    case PGEM_VERDICT_REPLAY:
        FUZZ_CHECK(accepted == 0 && replays == 1 && rejected == 0 && commands == 0);
        FUZZ_CHECK(received == 1);
        break;
    case PGEM_VERDICT_REJECTED:
        FUZZ_CHECK((unsigned)result->reason < PGEM_REJECT_COUNT);
        FUZZ_CHECK(accepted == 0 && replays == 0 && rejected == 1);
        FUZZ_CHECK(b->rejected[result->reason] - a->rejected[result->reason] == 1);
        FUZZ_CHECK(commands == (result->reason == PGEM_REJECT_COMMAND ||
                                (result->reason == PGEM_REJECT_JOURNAL && received == 0)));
        if (received == 0) { /* the command channel: undecodable, a bad command, a RESET the
                                journal refused */
            FUZZ_CHECK(result->reason == PGEM_REJECT_DECODE ||
                       result->reason == PGEM_REJECT_COMMAND ||
                       result->reason == PGEM_REJECT_JOURNAL);
            run.command_channel_rejections++;
        }
        FUZZ_CHECK(result->message[0] != '\0');
        break;
    case PGEM_VERDICT_COMMAND:
        FUZZ_CHECK(accepted == 0 && replays == 0 && rejected == 0 && commands == 1);
        FUZZ_CHECK(received == 0);
        FUZZ_CHECK(memchr(result->path, '\0', sizeof result->path) != NULL);
        break;
    case PGEM_VERDICT_IGNORED:
        FUZZ_CHECK(role == PGEM_ROLE_ANY);
        FUZZ_CHECK(accepted == 0 && replays == 0 && rejected == 0 && commands == 0);
        FUZZ_CHECK(received == 0);
        break;
    default:
        FUZZ_CHECK(!"verdict out of range");
    }
    FUZZ_CHECK(!result->pending || result->verdict == PGEM_VERDICT_ACCEPTED);
    FUZZ_CHECK(memchr(result->message, '\0', sizeof result->message) != NULL);
    /* over the whole run: every pose or edge message is accounted for once */
    FUZZ_CHECK(b->received == b->accepted_poses + b->accepted_edges + b->replays +
                                  rejected_total(b) - run.command_channel_rejections);
}

static void check_limits(const sink_t *sink, const pgem_ingest_counts_t *counts)
{
    FUZZ_CHECK(counts->pending <= run.config.max_pending);
    FUZZ_CHECK(sink->poses_since_reset <= run.config.max_poses);
    FUZZ_CHECK(sink->edges_since_reset + counts->pending <= run.config.max_edges);
}

/* The admit hook: refuses every (refusals + 1)-th message offered, as a full journal would. */
static int admit(void *user, const void *data, size_t size, char *message, size_t message_size)
{
    (void)user;
    FUZZ_CHECK(data != NULL && size >= 8);
    if (run.refusals != 0 && run.message_count % (run.refusals + 1u) == 0) {
        run.refused_now = 1;
        snprintf(message, message_size, "the journal is full");
        return -1;
    }
    return 0;
}

static void feed(pgem_ingest_t *ingest, sink_t *sink, const message_t *m)
{
    pgem_ingest_counts_t before, after;
    pgem_ingest_result_t result;
    uint32_t emitted = sink->count;
    pgem_ingest_counts(ingest, &before);
    run.refused_now = 0;
    pgem_ingest_message(ingest, m->role, m->bytes, m->size, m->utime, &result);
    pgem_ingest_counts(ingest, &after);
    check_counts(&before, &after, &result, m->role);
    FUZZ_CHECK(!run.refused_now || sink->count == emitted);
    check_limits(sink, &after);
    if (result.verdict == PGEM_VERDICT_ACCEPTED ||
        (result.verdict == PGEM_VERDICT_COMMAND && result.command == PGEM_COMMAND_T_RESET)) {
        run.journal[run.journal_count] = *m;
        run.journal[run.journal_count].role = PGEM_ROLE_ANY;
        run.journal_count++;
    }
}

/* The journal replayed into a new state machine gives the same items, with the same source
 * names (indices may differ: a rejected edge can name a source). */
static void check_journal_replay(const sink_t *live)
{
    static sink_t again;
    sink_init(&again, &run.config);
    pgem_ingest_t *ingest = pgem_ingest_create(&run.config, emit, &again);
    FUZZ_CHECK(ingest != NULL);
    again.ingest = ingest;
    for (uint32_t i = 0; i < run.journal_count; ++i) {
        pgem_ingest_result_t result;
        pgem_ingest_message(ingest, PGEM_ROLE_ANY, run.journal[i].bytes, run.journal[i].size,
                            run.journal[i].utime, &result);
        FUZZ_CHECK(result.verdict == PGEM_VERDICT_ACCEPTED ||
                   result.verdict == PGEM_VERDICT_COMMAND);
    }
    FUZZ_CHECK(again.count == live->count);
    const int n = PGEM_TANGENT_SIZE(run.config.dimension);
    for (uint32_t i = 0; i < live->count; ++i) {
        const pgem_item_t *x = &live->items[i];
        const pgem_item_t *y = &again.items[i];
        FUZZ_CHECK(x->type == y->type && x->kind == y->kind && x->sequence == y->sequence);
        FUZZ_CHECK(x->from == y->from && x->to == y->to);
        FUZZ_CHECK(strcmp(live->sources[i], again.sources[i]) == 0);
        FUZZ_CHECK(memcmp(x->value, y->value, sizeof x->value) == 0);
        FUZZ_CHECK(memcmp(x->information, y->information,
                          sizeof(double) * (size_t)(n * (n + 1) / 2)) == 0);
    }
    pgem_ingest_destroy(ingest);
    free(again.block);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static sink_t sink;
    fuzz_input_t in = {data, size, 0};
    memset(&run.config, 0, sizeof run.config);
    run.message_count = 0;
    run.journal_count = 0;
    run.command_channel_rejections = 0;
    uint8_t h0 = fuzz_byte(&in), h1 = fuzz_byte(&in), h2 = fuzz_byte(&in);
    run.config.dimension = (h0 & 1u) ? 3 : 2;
    run.config.max_poses = 1u + (uint32_t)(h0 >> 1) % 16u;
    run.config.max_edges = 1u + (uint32_t)h1 % 24u;
    run.config.max_pending = 1u + (uint32_t)h2 % 8u;
    run.config.max_sources = 1u + (uint32_t)(h2 >> 3) % 4u;
    run.config.pending_timeout = 4 + (int64_t)((h2 >> 5) & 7u) * 8; /* in messages */
    run.config.snapshots = (h0 >> 5) & 1u;
    run.refusals = (h0 >> 6) & 3u;
    sink_init(&sink, &run.config);
    pgem_ingest_t *ingest = pgem_ingest_create(&run.config, emit, &sink);
    FUZZ_CHECK(ingest != NULL);
    pgem_ingest_set_admit(ingest, admit, NULL);
    sink.ingest = ingest;
    message_t m;
    while (run.message_count < MAX_MESSAGES && read_record(&in, &m)) {
        run.messages[run.message_count++] = m;
        feed(ingest, &sink, &m);
    }
    check_journal_replay(&sink);
    pgem_ingest_destroy(ingest);
    free(sink.block);
    return 0;
}

/* ---- seeds ------------------------------------------------------------------------------- */

static void put_bytes(fuzz_output_t *out, const uint8_t *bytes, size_t count)
{
    for (size_t i = 0; i < count; ++i) {
        fuzz_put(out, bytes[i]);
    }
}

/* A pose record built for the channel's expected type. */
static void put_pose(fuzz_output_t *out, int dimension, uint64_t id, double x, uint8_t fixed)
{
    fuzz_put(out, (uint8_t)(PGEM_ROLE_POSE | FORM_BUILD << 2 | BUILD_EXPECTED << 4));
    fuzz_put(out, 0); /* source "fe" */
    fuzz_put_id(out, id);
    fuzz_put(out, (uint8_t)(1u | fixed << 1));
    const double pose[PGEM_POSE_SIZE_MAX] = {x, 0.0, dimension == 3 ? 0.0 : 0.125, 0.0, 0.0,
                                             0.0, 1.0};
    for (int k = 0; k < PGEM_POSE_SIZE(dimension); ++k) {
        fuzz_put_value(out, pose[k]);
    }
}

static void put_edge(fuzz_output_t *out, int dimension, uint8_t form, uint64_t sequence,
                     uint64_t from, uint64_t to, double dx)
{
    fuzz_put(out, (uint8_t)(PGEM_ROLE_EDGE | form << 2 | BUILD_EXPECTED << 4));
    fuzz_put(out, 0);
    fuzz_put_id(out, sequence);
    fuzz_put_id(out, from);
    fuzz_put_id(out, to);
    fuzz_put(out, (from > to ? from - to : to - from) == 1 ? 0 : 1);
    fuzz_put(out, 1);
    const double measurement[PGEM_POSE_SIZE_MAX] = {dx, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0};
    for (int k = 0; k < PGEM_POSE_SIZE(dimension); ++k) {
        fuzz_put_value(out, measurement[k]);
    }
    fuzz_put(out, 0); /* identity information, scaled */
    fuzz_put_value(out, 4.0);
}

static void put_command(fuzz_output_t *out, uint8_t command, uint8_t path)
{
    fuzz_put(out, (uint8_t)(PGEM_ROLE_COMMAND | FORM_BUILD << 2 | BUILD_COMMAND << 4));
    fuzz_put(out, (uint8_t)(command - 1));
    fuzz_put(out, path);
}

/* Poses and edges out of order: an edge waits for its pose, a repeat is a replay, the same
 * sequence with other content a conflict, then OPTIMIZE, SNAPSHOT and RESET. */
static void seed_stream(fuzz_output_t *out, int dimension)
{
    const uint8_t header[] = {(uint8_t)((dimension == 3) | 11u << 1), 15, 3};
    put_bytes(out, header, sizeof header);
    put_pose(out, dimension, 0, 0.0, 1);
    put_edge(out, dimension, FORM_BUILD, 0, 0, 1, 1.0);  /* waits for pose 1 */
    put_pose(out, dimension, 1, 1.0, 0);
    put_pose(out, dimension, 2, 2.0, 0);
    put_edge(out, dimension, FORM_BUILD, 1, 1, 2, 1.0);
    put_edge(out, dimension, FORM_BUILD, 2, 2, 0, -2.0); /* loop closure */
    const uint8_t repeat[] = {PGEM_ROLE_EDGE | FORM_REPEAT << 2, 4};
    put_bytes(out, repeat, sizeof repeat);               /* replay of sequence 1 */
    put_edge(out, dimension, FORM_BUILD, 1, 1, 2, 1.5);  /* conflict */
    put_command(out, PGEM_COMMAND_T_OPTIMIZE, 0);
    put_command(out, PGEM_COMMAND_T_SNAPSHOT, 1);
    put_command(out, PGEM_COMMAND_T_SNAPSHOT, 0);        /* no path */
    put_command(out, PGEM_COMMAND_T_RESET, 0);
    put_pose(out, dimension, 0, 0.0, 0);
}

/* Damaged encodings, raw bytes, the other dimension's messages and the journal channel. */
static void seed_damage(fuzz_output_t *out)
{
    const uint8_t header[] = {2u << 1, 3, 0x19};
    put_bytes(out, header, sizeof header);
    put_pose(out, 2, 5, 0.0, 0);
    for (uint8_t op = 0; op < 4; ++op) { /* each damage once */
        put_edge(out, 2, FORM_DAMAGED, op, 5, 6, 1.0);
        fuzz_put(out, op);
        fuzz_put(out, (uint8_t)(3 + op));
        /* bytes the damage reads: appended (amount % 16 + 1), the flip mask, or the first
         * three bytes of the string length (amount is the last) */
        const int extra = op == 0 ? 0 : op == 1 ? 5 : op == 2 ? 1 : 3;
        for (int i = 0; i < extra; ++i) {
            fuzz_put(out, (uint8_t)(op == 1 ? 0x41 + i : 0x7F));
        }
    }
    const uint8_t pose3_on_2d[] = {PGEM_ROLE_POSE | FORM_BUILD << 2 | BUILD_POSE3 << 4, 1, 7, 1,
                                   112, 112, 112, 112, 112, 112, 128};
    put_bytes(out, pose3_on_2d, sizeof pose3_on_2d);
    const uint8_t raw[] = {PGEM_ROLE_ANY | FORM_RAW << 2, 10, 0, 'n', 'o', 't', ' ', 'a', ' ',
                           'p', 'g', 'e', 'm'};
    put_bytes(out, raw, sizeof raw);
    const uint8_t edge_on_pose_channel[] = {PGEM_ROLE_POSE | FORM_BUILD << 2 | BUILD_EDGE2 << 4,
                                            2, 3, 5, 6, 0, 0, 128, 112, 112, 0, 176};
    put_bytes(out, edge_on_pose_channel, sizeof edge_on_pose_channel);
}

size_t fuzz_seed(unsigned index, uint8_t *buffer, size_t capacity)
{
    fuzz_output_t out = {buffer, 0, capacity};
    switch (index) {
    case 0: seed_stream(&out, 2); break;
    case 1: seed_stream(&out, 3); break;
    case 2: seed_damage(&out); break;
    default: return 0;
    }
    FUZZ_CHECK(out.size <= capacity);
    return out.size;
}
