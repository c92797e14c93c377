/* Free space seen by the cameras (see free_space.h). */
#include "volume/free_space.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "fields/trilerp.h"
#include "volume/first_hit.h"
#include "volume/ray.h"

#define CARVE_CHUNK 65536

int esr_free_space_carve(const struct esr_grid *g, const float *sdf, const float *orig3,
                         const float *dir3, size_t n, float margin_voxels, uint8_t *free_out)
{
    memset(free_out, 0, esr_grid_voxels(g));
    if (n == 0)
        return ESR_OK;
    const size_t stride = (n + ESR_FREE_SPACE_MAX_RAYS - 1) / ESR_FREE_SPACE_MAX_RAYS;
    const size_t used = (n + stride - 1) / stride;
    const size_t cap = used < CARVE_CHUNK ? used : CARVE_CHUNK;
    float *o = malloc(cap * 3 * sizeof(float)), *d = malloc(cap * 3 * sizeof(float));
    float *t = malloc(cap * sizeof(float));
    uint8_t *flags = malloc(cap);
    if (!o || !d || !t || !flags) {
        free(o), free(d), free(t), free(flags);
        return ESR_FAIL("free space: out of memory for %zu rays", cap);
    }
    const float h = esr_grid_voxel_size(g, 0), step = 0.5f * h, margin = margin_voxels * h;
    struct esr_first_hit_params hp;
    esr_first_hit_params_init(&hp, g);
    int rc = ESR_OK;
    for (size_t r0 = 0; r0 < used && rc == ESR_OK; r0 += cap) {
        const size_t c = used - r0 < cap ? used - r0 : cap;
        for (size_t i = 0; i < c; i++) {
            memcpy(o + i * 3, orig3 + (r0 + i) * stride * 3, 3 * sizeof(float));
            memcpy(d + i * 3, dir3 + (r0 + i) * stride * 3, 3 * sizeof(float));
        }
        const struct esr_first_hit_rays rays = {o, d, NULL, NULL, c};
        const struct esr_first_hit_out out = {t, flags, NULL, NULL};
        rc = esr_first_hit(g, sdf, &hp, &rays, &out);
#pragma omp parallel for schedule(dynamic, 256)
        for (size_t i = 0; i < c; i++) {
            if (rc != ESR_OK || (flags[i] & ESR_FIRST_HIT_STARTED_INSIDE))
                continue;
            float t0, t1;
            if (!esr_ray_box_clip(o + i * 3, d + i * 3, g->bmin, g->bmax, 0.0f, INFINITY, &t0, &t1))
                continue;
            if (flags[i] & ESR_FIRST_HIT_HIT)
                t1 = t[i] - margin;
            else if (flags[i] & ESR_FIRST_HIT_OUT_OF_STEPS)
                continue; /* where the surface is is unknown */
            for (float s = t0; s <= t1; s += step) {
                float p[3];
                for (int a = 0; a < 3; a++)
                    p[a] = o[i * 3 + a] + s * d[i * 3 + a];
                /* racing stores of the same byte: relaxed atomics make them defined */
                __atomic_store_n(free_out + esr_trilerp_nearest(g, p), (uint8_t)1, __ATOMIC_RELAXED);
            }
        }
    }
    free(o), free(d), free(t), free(flags);
    return rc;
}

int esr_free_space_at(const struct esr_grid *g, const uint8_t *free_mask, const float p[3])
{
    for (int a = 0; a < 3; a++)
        if (!(p[a] >= g->bmin[a] && p[a] <= g->bmax[a]))
            return 0;
    struct esr_trilerp t;
    esr_trilerp_locate(g, p, &t);
    for (int c = 0; c < 8; c++)
        if (free_mask[t.base + (c & 1) * t.stride[0] + (c >> 1 & 1) * t.stride[1] +
                      (c >> 2 & 1) * t.stride[2]])
            return 1;
    return 0;
}
