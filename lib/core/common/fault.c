/* Fault injection, compiled only into the test copy of the core (PGEM_FAULT_INJECTION; see
 * common/common.h): the chosen carve or allocation fails, or the chosen downdate of the
 * incremental factor breaks. One instance at a time: the tests are single-threaded. */
#include "common/common.h"

#ifdef PGEM_FAULT_INJECTION
static long pgem_fault_target = -1;
static long pgem_fault_count;
static long pgem_downdate_target = -1;
static long pgem_downdate_count;

void pgem_fault_arm(long index)
{
    pgem_fault_target = index;
    pgem_fault_count = 0;
}

long pgem_fault_seen(void)
{
    return pgem_fault_count;
}

int pgem_fault_next(void)
{
    return pgem_fault_count++ == pgem_fault_target;
}

void pgem_fault_arm_downdate(long index)
{
    pgem_downdate_target = index;
    pgem_downdate_count = 0;
}

long pgem_fault_downdates_seen(void)
{
    return pgem_downdate_count;
}

int pgem_fault_downdate(void)
{
    return pgem_downdate_count++ == pgem_downdate_target;
}
#else
typedef int pgem_fault_unused_t; /* ISO C wants a translation unit to declare something */
#endif
