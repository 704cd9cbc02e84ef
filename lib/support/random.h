/* The one deterministic random generator of the tools and tests (lib/support, private;
 * splitmix64): the same stream for a seed on every platform, uniform and Gaussian numbers drawn
 * from it. Header only. */
#ifndef PGEM_SUPPORT_RANDOM_H
#define PGEM_SUPPORT_RANDOM_H

#include <math.h>
#include <stdint.h>

/* The next 64 random bits; *state advances by the golden-ratio increment. */
static inline uint64_t pgem_random_next(uint64_t *state)
{
    uint64_t z = (*state += UINT64_C(0x9e3779b97f4a7c15));
    z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
    return z ^ (z >> 31);
}

/* Uniform in [0, 1): the top 53 bits. */
static inline double pgem_random_uniform(uint64_t *state)
{
    return (double)(pgem_random_next(state) >> 11) * (1.0 / 9007199254740992.0);
}

/* Standard normal (Box-Muller, one of the pair). */
static inline double pgem_random_gaussian(uint64_t *state)
{
    double u = pgem_random_uniform(state), v = pgem_random_uniform(state);
    return sqrt(-2.0 * log(u + 1e-300)) * cos(6.283185307179586 * v);
}

#endif /* PGEM_SUPPORT_RANDOM_H */
