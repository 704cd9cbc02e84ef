/* Fault injection, compiled only into the test copy of the core (PGEM_FAULT_INJECTION; see
 * common/common.h): the chosen carve or allocation fails, or the chosen downdate of the
 * incremental factor breaks. One instance at a time: the tests are single-threaded. */
#include "common/common.h"

#ifdef PGEM_FAULT_INJECTION
/* One channel: the request `target` fails; `count` requests were asked since it was armed. */
typedef struct pgem_fault_channel {
    long target;
    long count;
} pgem_fault_channel_t;

static pgem_fault_channel_t pgem_fault_carves = {-1, 0};
static pgem_fault_channel_t pgem_fault_downdates = {-1, 0};

static void pgem_fault_channel_arm(pgem_fault_channel_t *channel, long index)
{
    channel->target = index;
    channel->count = 0;
}

static int pgem_fault_channel_next(pgem_fault_channel_t *channel)
{
    return channel->count++ == channel->target;
}

void pgem_fault_arm(long index)
{
    pgem_fault_channel_arm(&pgem_fault_carves, index);
}

long pgem_fault_seen(void)
{
    return pgem_fault_carves.count;
}

int pgem_fault_next(void)
{
    return pgem_fault_channel_next(&pgem_fault_carves);
}

void pgem_fault_arm_downdate(long index)
{
    pgem_fault_channel_arm(&pgem_fault_downdates, index);
}

long pgem_fault_downdates_seen(void)
{
    return pgem_fault_downdates.count;
}

int pgem_fault_downdate(void)
{
    return pgem_fault_channel_next(&pgem_fault_downdates);
}
#else
typedef int pgem_fault_unused_t; /* ISO C wants a translation unit to declare something */
#endif
