/* e^x for x <= 0 in plain float arithmetic, so loops that call it vectorise (libm's expf is an
 * opaque call without -ffast-math): Cody-Waite reduction x = n ln 2 + r with |r| <= ln 2 / 2,
 * Cephes' expf polynomial for e^r (relative error ~1e-7, as expf), 2^n put into the exponent
 * bits. Shared by the BRDF's specular lobe and the environment map's spherical Gaussians. */
#ifndef ESR_CORE_FAST_EXP_H
#define ESR_CORE_FAST_EXP_H

#include <stdint.h>

#include "core/simd.h"

/* x must lie in [-87, 0] (the caller clamps: e^-87 ~ 1.6e-38, 2^n stays a normal float). */
ESR_INLINE float esr_exp_nonpos(float x)
{
    union {
        float f;
        int32_t i;
    } t, scale;
    t.f = x * 1.44269504088896341f + 12582912.0f; /* 1.5 * 2^23: n lands in the low bits */
    float n = t.f - 12582912.0f;
    float r = (x - n * 0.693359375f) + n * 2.12194440e-4f;
    float p = 1.9875691500e-4f;
    p = p * r + 1.3981999507e-3f;
    p = p * r + 8.3334519073e-3f;
    p = p * r + 4.1665795894e-2f;
    p = p * r + 1.6666665459e-1f;
    p = p * r + 5.0000001201e-1f;
    scale.i = (t.i - 0x4B400000 + 127) << 23;
    return (p * r * r + r + 1.0f) * scale.f;
}

#endif
