/* Counter-based random numbers: every value is a pure function of (seed, stream, counter), so
 * results do not depend on thread count or scheduling. Give each pixel / ray its own stream. */
#ifndef ESR_CORE_RNG_H
#define ESR_CORE_RNG_H

#include <math.h>
#include <stdint.h>

#include "core/simd.h"

struct esr_rng {
    uint64_t key;     /* hash of (seed, stream) */
    uint64_t counter; /* advanced by every draw */
};

/* SplitMix64 finaliser: a bijective 64-bit mixer with full avalanche. */
ESR_INLINE uint64_t esr_mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

ESR_INLINE struct esr_rng esr_rng_init(uint64_t seed, uint64_t stream)
{
    struct esr_rng rng;
    rng.key = esr_mix64(esr_mix64(seed ^ 0x9e3779b97f4a7c15ULL) + stream);
    rng.counter = 0;
    return rng;
}

ESR_INLINE uint32_t esr_rng_u32(struct esr_rng *rng)
{
    return (uint32_t)(esr_mix64(rng->key + 0x9e3779b97f4a7c15ULL * ++rng->counter) >> 32);
}

/* 64 random bits: the first draw is the high half. (Two draws in one expression would leave their
 * order to the compiler.) */
ESR_INLINE uint64_t esr_rng_u64(struct esr_rng *rng)
{
    const uint64_t hi = esr_rng_u32(rng);
    return hi << 32 | esr_rng_u32(rng);
}

/* Uniform in [0, 1): 24 random mantissa bits, never returns 1.0f. */
ESR_INLINE float esr_rng_float(struct esr_rng *rng)
{
    return (float)(esr_rng_u32(rng) >> 8) * (1.0f / 16777216.0f);
}

/* A standard normal value by Box-Muller (u1 in (0, 1] keeps the log finite). */
ESR_INLINE float esr_rng_normal(struct esr_rng *rng)
{
    const float u1 = 1.0f - esr_rng_float(rng), u2 = esr_rng_float(rng);
    return sqrtf(-2.0f * logf(u1)) * cosf(6.2831853f * u2);
}

/* Uniform integer in [0, n), n > 0 (Lemire's multiply-shift; bias < n / 2^32). */
ESR_INLINE uint32_t esr_rng_below(struct esr_rng *rng, uint32_t n)
{
    return (uint32_t)(((uint64_t)esr_rng_u32(rng) * n) >> 32);
}

#endif
