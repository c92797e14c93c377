#include "synth/noise.h"

#include <math.h>
#include <stdint.h>

#include "core/rng.h"

/* A value in [0, 1) fixed per lattice point (i, j, k) of octave o. */
static float lattice(int32_t i, int32_t j, int32_t k, int o)
{
    uint64_t key = (uint64_t)(uint32_t)i | (uint64_t)(uint32_t)j << 32;
    key = esr_mix64(key ^ esr_mix64((uint64_t)(uint32_t)k | (uint64_t)o << 32));
    return (float)(key >> 40) * (1.0f / 16777216.0f);
}

static float smooth(float t) { return t * t * (3.0f - 2.0f * t); }

/* One octave: the lattice values around x/cell blended trilinearly. */
static float octave(struct esr_vec3 x, float cell, int o)
{
    const float p[3] = {x.x / cell, x.y / cell, x.z / cell};
    int32_t i[3];
    float w[3];
    for (int a = 0; a < 3; a++) {
        const float f = floorf(p[a]);
        i[a] = (int32_t)f;
        w[a] = smooth(p[a] - f);
    }
    float v = 0.0f;
    for (int c = 0; c < 8; c++) {
        const int dx = c & 1, dy = c >> 1 & 1, dz = c >> 2;
        const float wc = (dx ? w[0] : 1.0f - w[0]) * (dy ? w[1] : 1.0f - w[1]) * (dz ? w[2] : 1.0f - w[2]);
        v += wc * lattice(i[0] + dx, i[1] + dy, i[2] + dz, o);
    }
    return v;
}

float esr_synth_noise(struct esr_vec3 x, float period)
{
    float v = 0.0f, amp = 0.5f, total = 0.0f, cell = period;
    for (int o = 0; o < 4; o++) {
        v += amp * octave(x, cell, o);
        total += amp;
        amp *= 0.5f;
        cell *= 0.5f;
    }
    /* octave sums bunch around 0.5: stretched (x5, clamped) into blotches of either colour with
     * short transitions, whose corners and edges a feature detector finds as on a real surface */
    const float w = 0.5f + 5.0f * (v / total - 0.5f);
    return w < 0.0f ? 0.0f : w > 1.0f ? 1.0f : w;
}
