/* LCM message bytes to decoded records, and the checks of their values (see wire.h). */
#include "wire.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pgem/geometry.h"
#include "pgem_pose2_t.h"
#include "pgem_pose3_t.h"
#include "utf8.h"

/* ---- layout and fingerprints -------------------------------------------------------------- */

static int64_t fingerprint(const void *data, size_t size)
{
    if (size < 8) {
        return 0;
    }
    const unsigned char *b = data;
    uint64_t value = 0;
    for (int i = 0; i < 8; ++i) {
        value = value << 8 | b[i];
    }
    return (int64_t)value;
}

/* lcm-gen's decoders trust a string's length field (they malloc it and never check the
 * terminating NUL), so every message is first checked against its exact layout: the type's
 * fingerprint, one string at string_offset (length 1 .. 64 KiB including a NUL that is its
 * only zero byte) and `tail` bytes after it, nothing more or less. */
static int wire_ok(const void *data, size_t size, int64_t type, size_t string_offset,
                   size_t tail)
{
    const unsigned char *bytes = data;
    if (fingerprint(data, size) != type || size < string_offset + 4) {
        return 0;
    }
    const unsigned char *p = bytes + string_offset;
    uint32_t length = (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
    if (length == 0 || length > 65536 || size != string_offset + 4 + length + tail) {
        return 0;
    }
    const unsigned char *text = p + 4;
    return text[length - 1] == 0 && memchr(text, 0, length - 1) == NULL;
}

/* Byte sizes of the fields after the string in each input type (see types/ *.lcm). */
#define POSE2_TAIL (8 + 3 * 8 + 1)
#define POSE3_TAIL (8 + 7 * 8 + 1)
#define EDGE2_TAIL (3 * 8 + 3 * 8 + 6 * 8 + 1)
#define EDGE3_TAIL (3 * 8 + 7 * 8 + 21 * 8 + 1)
#define STRING_AFTER_UTIME 16  /* fingerprint, utime */
#define COMMAND_STRING 17      /* fingerprint, utime, command */

#define DECODE(type, data, size, offset, tail, msg)                                  \
    (wire_ok(data, size, __##type##_get_hash(), offset, tail) &&                      \
     type##_decode(data, 0, (int)(size), msg) == (int)(size))

pgem_role_t pgem_wire_role(const void *data, size_t size)
{
    int64_t type = fingerprint(data, size);
    if (type == __pgem_pose2_t_get_hash() || type == __pgem_pose3_t_get_hash()) {
        return PGEM_ROLE_POSE;
    }
    if (type == __pgem_edge2_t_get_hash() || type == __pgem_edge3_t_get_hash()) {
        return PGEM_ROLE_EDGE;
    }
    if (type == __pgem_command_t_get_hash()) {
        return PGEM_ROLE_COMMAND;
    }
    return PGEM_ROLE_ANY;
}

pgem_role_t pgem_ingest_wire_role(const void *data, size_t size)
{
    if (wire_ok(data, size, __pgem_pose2_t_get_hash(), STRING_AFTER_UTIME, POSE2_TAIL) ||
        wire_ok(data, size, __pgem_pose3_t_get_hash(), STRING_AFTER_UTIME, POSE3_TAIL)) {
        return PGEM_ROLE_POSE;
    }
    if (wire_ok(data, size, __pgem_edge2_t_get_hash(), STRING_AFTER_UTIME, EDGE2_TAIL) ||
        wire_ok(data, size, __pgem_edge3_t_get_hash(), STRING_AFTER_UTIME, EDGE3_TAIL)) {
        return PGEM_ROLE_EDGE;
    }
    if (wire_ok(data, size, __pgem_command_t_get_hash(), COMMAND_STRING, 0)) {
        return PGEM_ROLE_COMMAND;
    }
    return PGEM_ROLE_ANY;
}

/* ---- decoding ----------------------------------------------------------------------------- */

enum { HELD_NONE = 0, HELD_EDGE2, HELD_EDGE3, HELD_COMMAND };

/* The fields an edge2_t and an edge3_t share, into an item (the kind is checked as the int8
 * it is on the wire before it is stored). */
#define EDGE_INTO_ITEM(edge, item)                                              \
    do {                                                                        \
        (item).from = (pgem_id_t)(edge).from;                                   \
        (item).to = (pgem_id_t)(edge).to;                                       \
        (item).sequence = (edge).sequence;                                      \
        memcpy((item).value, (edge).measurement, sizeof (edge).measurement);    \
        memcpy((item).information, (edge).information, sizeof (edge).information); \
    } while (0)

static int decode_pose(int dimension, const void *data, size_t size, pgem_item_t *item)
{
    item->type = PGEM_ITEM_POSE;
    if (dimension == 2) {
        pgem_pose2_t pose;
        if (DECODE(pgem_pose2_t, data, size, STRING_AFTER_UTIME, POSE2_TAIL, &pose)) {
            item->from = (pgem_id_t)pose.id;
            item->kind = pose.fixed ? 1 : 0;
            memcpy(item->value, pose.pose, sizeof pose.pose);
            pgem_pose2_t_decode_cleanup(&pose);
            return 1;
        }
    } else {
        pgem_pose3_t pose;
        if (DECODE(pgem_pose3_t, data, size, STRING_AFTER_UTIME, POSE3_TAIL, &pose)) {
            item->from = (pgem_id_t)pose.id;
            item->kind = pose.fixed ? 1 : 0;
            memcpy(item->value, pose.pose, sizeof pose.pose);
            pgem_pose3_t_decode_cleanup(&pose);
            return 1;
        }
    }
    return 0;
}

static int decode_edge(int dimension, const void *data, size_t size, pgem_wire_message_t *m)
{
    m->item.type = PGEM_ITEM_EDGE;
    if (dimension == 2) {
        if (DECODE(pgem_edge2_t, data, size, STRING_AFTER_UTIME, EDGE2_TAIL, &m->edge2)) {
            m->held = HELD_EDGE2;
            EDGE_INTO_ITEM(m->edge2, m->item);
            m->source = m->edge2.source;
            m->wire_kind = m->edge2.kind;
            return 1;
        }
    } else {
        if (DECODE(pgem_edge3_t, data, size, STRING_AFTER_UTIME, EDGE3_TAIL, &m->edge3)) {
            m->held = HELD_EDGE3;
            EDGE_INTO_ITEM(m->edge3, m->item);
            m->source = m->edge3.source;
            m->wire_kind = m->edge3.kind;
            return 1;
        }
    }
    return 0;
}

/* A message on the pose or edge channel that did not decode: of the other dimension, or not
 * the channel's type at all. */
static pgem_reject_t undecoded(int dimension, const void *data, size_t size,
                               int64_t other_dimension, const char *noun, char *text,
                               size_t text_size)
{
    if (fingerprint(data, size) == other_dimension) {
        snprintf(text, text_size, "a %dD %s reached a %dD bridge", 5 - dimension, noun,
                 dimension);
        return PGEM_REJECT_DIMENSION;
    }
    snprintf(text, text_size, "a %zu-byte message on the %s channel is not a pgem.%s%d_t", size,
             noun, noun, dimension);
    return PGEM_REJECT_DECODE;
}

int pgem_wire_decode(int dimension, pgem_role_t role, const void *data, size_t size,
                     pgem_wire_message_t *message, pgem_reject_t *reason, char *text,
                     size_t text_size)
{
    memset(message, 0, sizeof *message);
    message->role = role;
    message->path = "";
    if (role == PGEM_ROLE_COMMAND) {
        pgem_command_t *command = &message->command_message;
        if (!DECODE(pgem_command_t, data, size, COMMAND_STRING, 0, command)) {
            snprintf(text, text_size,
                     "a %zu-byte message on the command channel is not a pgem.command_t", size);
            *reason = PGEM_REJECT_DECODE;
            return 0;
        }
        message->held = HELD_COMMAND;
        message->command = (int)command->command; /* a signed 8-bit code on the wire */
        message->path = command->path != NULL ? command->path : "";
        return 1;
    }
    if (role == PGEM_ROLE_POSE) {
        if (decode_pose(dimension, data, size, &message->item)) {
            return 1;
        }
        *reason = undecoded(dimension, data, size,
                            dimension == 2 ? __pgem_pose3_t_get_hash() : __pgem_pose2_t_get_hash(),
                            "pose", text, text_size);
        return 0;
    }
    if (decode_edge(dimension, data, size, message)) {
        return 1;
    }
    *reason = undecoded(dimension, data, size,
                        dimension == 2 ? __pgem_edge3_t_get_hash() : __pgem_edge2_t_get_hash(),
                        "edge", text, text_size);
    return 0;
}

void pgem_wire_release(pgem_wire_message_t *message)
{
    if (message->held == HELD_EDGE2) {
        pgem_edge2_t_decode_cleanup(&message->edge2);
    } else if (message->held == HELD_EDGE3) {
        pgem_edge3_t_decode_cleanup(&message->edge3);
    } else if (message->held == HELD_COMMAND) {
        pgem_command_t_decode_cleanup(&message->command_message);
    }
    message->held = HELD_NONE;
    message->source = NULL;
    message->path = "";
}

/* ---- checks ------------------------------------------------------------------------------- */

static const char *const value_names_2d[] = {"x", "y", "theta"};
static const char *const value_names_3d[] = {"x", "y", "z", "qx", "qy", "qz", "qw"};

/* A number as the fewest digits that read back as it (1e+160, not 1.0000000000000001e+160). */
static void shortest(char *out, size_t size, double value)
{
    for (int digits = 1; digits <= 17; ++digits) {
        snprintf(out, size, "%.*g", digits, value);
        if (strtod(out, NULL) == value) {
            return;
        }
    }
}

pgem_reject_t pgem_wire_check_values(int dimension, const double *values, const char *what,
                                     const char *noun, char *text, size_t text_size)
{
    int bad = -1;
    int status = pgem_pose_check(values, dimension, &bad);
    const char *field = bad < 0 ? "" : dimension == 3 ? value_names_3d[bad] : value_names_2d[bad];
    if (status == PGEM_ERR_NOT_FINITE) {
        snprintf(text, text_size, "%s: NaN or Inf in the %s (field %s)", what, noun, field);
        return PGEM_REJECT_NOT_FINITE;
    }
    if (status == PGEM_ERR_OUT_OF_RANGE) {
        char value[32];
        shortest(value, sizeof value, values[bad]);
        snprintf(text, text_size, "%s: the %s's %s is %s m, beyond the translation limit of 1e8 m",
                 what, noun, field, value);
        return PGEM_REJECT_RANGE;
    }
    if (status != PGEM_OK) {
        snprintf(text, text_size, "%s: quaternion norm off 1 by more than %g", what,
                 PGEM_QUAT_NORM_TOLERANCE);
        return PGEM_REJECT_ROTATION;
    }
    return PGEM_REJECT_COUNT;
}

pgem_reject_t pgem_wire_check_edge(int dimension, const pgem_item_t *item, int wire_kind,
                                   const char *what, char *text, size_t text_size)
{
    int n = PGEM_TANGENT_SIZE(dimension);
    if (item->from == item->to) {
        snprintf(text, text_size, "%s: a self-loop", what);
        return PGEM_REJECT_SELF_LOOP;
    }
    if (wire_kind != PGEM_EDGE_ODOMETRY && wire_kind != PGEM_EDGE_LOOP) {
        snprintf(text, text_size, "%s: kind %d is neither ODOMETRY (0) nor LOOP (1)", what,
                 wire_kind);
        return PGEM_REJECT_KIND;
    }
    const pgem_reject_t values = pgem_wire_check_values(dimension, item->value, what,
                                                        "measurement", text, text_size);
    if (values != PGEM_REJECT_COUNT) {
        return values;
    }
    double full[PGEM_TANGENT_SIZE_MAX * PGEM_TANGENT_SIZE_MAX];
    pgem_upper_to_full(item->information, n, full);
    int entry = 0;
    int check = pgem_information_check(full, n, &entry);
    if (check == PGEM_ERR_OUT_OF_RANGE) {
        char value[32];
        shortest(value, sizeof value, full[entry]);
        snprintf(text, text_size,
                 "%s: information entry %d,%d is %s, beyond the information limit of 1e15", what,
                 entry / n, entry % n, value);
        return PGEM_REJECT_RANGE;
    }
    if (check == PGEM_ERR_INFORMATION && pgem_information_positive(full, n)) {
        snprintf(text, text_size,
                 "%s: information is positive definite but too badly conditioned to factor in "
                 "double precision (entry %d,%d: a condition number beyond about 1e15)", what,
                 entry / n, entry % n);
        return PGEM_REJECT_INFORMATION;
    }
    if (check != PGEM_OK) {
        int not_finite = check == PGEM_ERR_NOT_FINITE;
        snprintf(text, text_size, "%s: information %s (entry %d,%d)", what,
                 not_finite ? "has NaN or Inf" : "is not positive definite", entry / n,
                 entry % n);
        return not_finite ? PGEM_REJECT_NOT_FINITE : PGEM_REJECT_INFORMATION;
    }
    return PGEM_REJECT_COUNT;
}

int pgem_wire_source_ok(const char *name, char *text, size_t text_size)
{
    size_t length = name != NULL ? strlen(name) : 0;
    size_t bad = 0;
    char shown[128];
    if (length == 0 || length >= PGEM_SOURCE_MAX) {
        snprintf(text, text_size, "source name must have 1 to %d bytes, got %zu",
                 PGEM_SOURCE_MAX - 1, length);
        return 0;
    }
    if (!pgem_utf8_text_printable(name, &bad)) {
        snprintf(text, text_size,
                 "source name '%s' is not printable UTF-8 (byte %zu, 0x%02x): names appear in "
                 "logs and JSON", pgem_utf8_escape(shown, sizeof shown, name), bad,
                 (unsigned)(unsigned char)name[bad]);
        return 0;
    }
    return 1;
}

void pgem_upper_to_full(const double *upper, int n, double *full)
{
    int k = 0;
    for (int i = 0; i < n; ++i) {
        for (int j = i; j < n; ++j) {
            full[i * n + j] = upper[k];
            full[j * n + i] = upper[k];
            ++k;
        }
    }
}

int pgem_snapshot_name_ok(const char *name)
{
    size_t length = name != NULL ? strlen(name) : 0;
    if (length == 0 || length > PGEM_SNAPSHOT_NAME_MAX || name[0] == '.') {
        return 0;
    }
    return strspn(name, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789._-") ==
           length;
}
