/* Monotonic seconds and sleeping until a deadline, for the test programs that pace LCM traffic
 * (lcm_hostile, lcm_malformed). */
#ifndef PGEM_TEST_CLOCK_H
#define PGEM_TEST_CLOCK_H

#include <time.h>

static inline double now_seconds(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static inline void sleep_until(double deadline)
{
    double left = deadline - now_seconds();
    if (left > 0.0) {
        struct timespec pause;
        pause.tv_sec = (time_t)left;
        pause.tv_nsec = (long)((left - (double)pause.tv_sec) * 1e9);
        nanosleep(&pause, NULL);
    }
}

#endif /* PGEM_TEST_CLOCK_H */
