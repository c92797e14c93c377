/* Non-finite detection on the bit pattern: exponent all ones means Inf or NaN. Works under
 * -ffast-math too (isfinite may be folded away there). */
#include "nn/guard.h"

#include <stdint.h>
#include <string.h>

#include "core/simd.h"

#define GUARD_CHUNK 4096

/* 1 when any value of the chunk has an all-ones exponent. */
ESR_HOT static int chunk_has_nonfinite(const float *x, size_t n)
{
    uint32_t bad = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, x + i, sizeof(u));
        bad |= ((u & 0x7f800000u) == 0x7f800000u);
    }
    return bad != 0;
}

int esr_nn_all_finite(const float *x, size_t n)
{
    size_t n_chunks = (n + GUARD_CHUNK - 1) / GUARD_CHUNK;
    int bad = 0;
#pragma omp parallel for schedule(static) reduction(| : bad) if (n_chunks > 64)
    for (size_t c = 0; c < n_chunks; c++) {
        size_t b = c * GUARD_CHUNK, e = b + GUARD_CHUNK < n ? b + GUARD_CHUNK : n;
        bad |= chunk_has_nonfinite(x + b, e - b);
    }
    return !bad;
}

size_t esr_nn_first_nonfinite(const float *x, size_t n)
{
    for (size_t b = 0; b < n; b += GUARD_CHUNK) {
        size_t e = b + GUARD_CHUNK < n ? b + GUARD_CHUNK : n;
        if (!chunk_has_nonfinite(x + b, e - b))
            continue;
        for (size_t i = b; i < e; i++)
            if (chunk_has_nonfinite(x + i, 1))
                return i;
    }
    return n;
}
