/* The wire side of reception: an LCM message's bytes to a decoded record, and the checks of
 * its values, with no state (ingest.c, the admission state machine, calls them in the order
 * its verdicts need). Each check returns PGEM_REJECT_COUNT when the value passes, else the
 * reason, with the message written (naming `what`, the message's ids). */
#ifndef PGEM_BRIDGE_WIRE_H
#define PGEM_BRIDGE_WIRE_H

#include <stddef.h>
#include <stdint.h>

#include "ingest.h"
#include "pgem_command_t.h"
#include "pgem_edge2_t.h"
#include "pgem_edge3_t.h"

/* One message decoded. The strings point into the decoded message: pgem_wire_release frees
 * them. */
typedef struct pgem_wire_message {
    pgem_role_t role;         /* POSE, EDGE or COMMAND */
    pgem_item_t item;         /* a pose's or an edge's fields; a pose's kind is its fixed flag,
                                 an edge's is set once its wire kind passed the checks */
    int8_t wire_kind;         /* an edge's kind as sent */
    const char *source;       /* an edge's source name as sent (unchecked) */
    int command;              /* a command's code (pgem_command_t's constant, as sent) */
    const char *path;         /* a command's path ("" when none) */
    int held;                 /* which of these holds the strings (0: none) */
    pgem_edge2_t edge2;
    pgem_edge3_t edge3;
    pgem_command_t command_message;
} pgem_wire_message_t;

/* The role the bytes claim by their type fingerprint: POSE, EDGE or COMMAND (of either
 * dimension), ANY when none (a journal's replay passes such messages over). */
pgem_role_t pgem_wire_role(const void *data, size_t size);

/* Decodes a message of `role` for a bridge of `dimension`, first checked against its type's
 * exact layout (lcm-gen's decoders trust a string's length field). 1, or 0 with the reason
 * (`decode`, or `dimension` for the other dimension's type) and the message. */
int pgem_wire_decode(int dimension, pgem_role_t role, const void *data, size_t size,
                     pgem_wire_message_t *message, pgem_reject_t *reason, char *text,
                     size_t text_size);
void pgem_wire_release(pgem_wire_message_t *message);

/* A pose estimate or a measurement (`noun`): the core's pose check (finite, translation
 * within PGEM_TRANSLATION_LIMIT, in 3D a unit quaternion). */
pgem_reject_t pgem_wire_check_values(int dimension, const double *values, const char *what,
                                     const char *noun, char *text, size_t text_size);
/* An edge's own values: not a self-loop, a known kind, its measurement, its information
 * (within PGEM_INFORMATION_LIMIT, positive definite, conditioned to factor). */
pgem_reject_t pgem_wire_check_edge(int dimension, const pgem_item_t *item, int wire_kind,
                                   const char *what, char *text, size_t text_size);
/* A source name: 1 to PGEM_SOURCE_MAX - 1 bytes of printable UTF-8. 1, or 0 with the
 * message (reason `source`). */
int pgem_wire_source_ok(const char *name, char *text, size_t text_size);

#endif /* PGEM_BRIDGE_WIRE_H */
