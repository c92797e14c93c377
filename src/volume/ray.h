/* Ray / axis-aligned box clipping (slab test), per ray, pure. */
#ifndef ESR_VOLUME_RAY_H
#define ESR_VOLUME_RAY_H

#include <math.h>

#include "core/simd.h"

/* Intersects o + t d, t in [near, far], with the box [bmin, bmax]. On a hit (non-empty interval)
 * returns 1 and sets *t0 <= *t1; otherwise returns 0. Zero direction components are handled
 * (the ray is then inside or outside that slab for every t); d need not be unit length. */
ESR_INLINE int esr_ray_box_clip(const float o[3], const float d[3], const float bmin[3],
                                const float bmax[3], float near, float far, float *t0, float *t1)
{
    float lo = near, hi = far;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0f) {
            if (o[a] < bmin[a] || o[a] > bmax[a])
                return 0;
            continue;
        }
        float inv = 1.0f / d[a];
        float ta = (bmin[a] - o[a]) * inv;
        float tb = (bmax[a] - o[a]) * inv;
        lo = fmaxf(lo, fminf(ta, tb));
        hi = fminf(hi, fmaxf(ta, tb));
    }
    *t0 = lo;
    *t1 = hi;
    return lo <= hi;
}

#endif
