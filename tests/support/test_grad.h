/* Helpers for finite-difference gradient tests (header-only so any test program can use them). */
#ifndef ESR_TEST_GRAD_H
#define ESR_TEST_GRAD_H

#include <math.h>
#include <stddef.h>

#include "core/rng.h"

/* Fills x[0..n) with uniform values in [lo, hi) from a fixed stream. */
static inline void test_fill_uniform(float *x, size_t n, float lo, float hi, uint64_t seed)
{
    struct esr_rng rng = esr_rng_init(seed, 0);
    for (size_t i = 0; i < n; i++)
        x[i] = lo + (hi - lo) * esr_rng_float(&rng);
}

/* |a - b| <= atol + rtol * max(|a|, |b|). */
static inline int test_close(double a, double b, double atol, double rtol)
{
    return fabs(a - b) <= atol + rtol * fmax(fabs(a), fabs(b));
}

/* Sum of x[i] * y[i] in double. */
static inline double test_dot(const float *x, const float *y, size_t n)
{
    double s = 0.0;
    for (size_t i = 0; i < n; i++)
        s += (double)x[i] * (double)y[i];
    return s;
}

#endif
