/* Two-pass ray marching: count the kept samples of every ray, prefix-sum, then write them. */
#include "volume/sampler.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/rng.h"
#include "volume/ray.h"

void esr_sample_params_init(struct esr_sample_params *p, const float bmin[3], const float bmax[3],
                            float step)
{
    memset(p, 0, sizeof(*p));
    for (int a = 0; a < 3; a++) {
        p->bmin[a] = bmin[a];
        p->bmax[a] = bmax[a];
    }
    p->near = 0.0f; /* the box clips: a camera close to (or inside) it marches from where it enters */
    p->far = 1e30f;
    p->step = step;
}

int esr_samples_alloc(struct esr_samples *s, size_t capacity, int max_rays)
{
    memset(s, 0, sizeof(*s));
    if (max_rays < 1 || capacity < 1)
        return ESR_FAIL("ray samples: capacity %zu and max rays %d must be >= 1", capacity, max_rays);
    s->ray = (int32_t *)malloc(capacity * sizeof(int32_t));
    s->t = (float *)malloc(capacity * sizeof(float));
    s->pos = (float *)malloc(capacity * 3 * sizeof(float));
    s->ray_start = (size_t *)malloc(((size_t)max_rays + 1) * sizeof(size_t));
    if (!s->ray || !s->t || !s->pos || !s->ray_start) {
        esr_samples_free(s);
        return ESR_FAIL("ray samples: out of memory for %zu samples", capacity);
    }
    s->capacity = capacity;
    s->max_rays = max_rays;
    return ESR_OK;
}

void esr_samples_free(struct esr_samples *s)
{
    free(s->ray);
    free(s->t);
    free(s->pos);
    free(s->ray_start);
    memset(s, 0, sizeof(*s));
}

/* Marches one ray; writes kept samples to (ray, t, pos) when out_t is non-NULL. Returns the count.
 * Both passes call this with the same RNG stream, so they agree sample for sample. occ_box (with
 * a mask; NULL: none) bounds the points the mask keeps: the steps outside it are skipped, their
 * draws too, so the samples are those of the whole march. */
static size_t march(const struct esr_sample_params *p, const float occ_box[2][3], const float o[3],
                    const float d[3], int r, int32_t *out_ray, float *out_t, float *out_pos)
{
    float t0, t1, near = p->near, far = p->far;
    if (p->t_min && p->t_min[r] > near)
        near = p->t_min[r];
    if (p->t_max && p->t_max[r] < far)
        far = p->t_max[r];
    if (!(near <= far) || !esr_ray_box_clip(o, d, p->bmin, p->bmax, near, far, &t0, &t1))
        return 0;
    struct esr_rng rng =
        esr_rng_init(p->seed, p->streams ? p->streams[r] : p->stream_base + (uint64_t)r);
    size_t kept = 0;
    long steps = (long)ceilf((t1 - t0) / p->step), k = 0;
    if (occ_box) {
        float ta, tb;
        if (!esr_ray_box_clip(o, d, occ_box[0], occ_box[1], t0, t1, &ta, &tb))
            return 0;
        /* a step's sample lies in [t0 + k step, t0 + (k + 1) step): keep one step either side */
        const long k_end = (long)ceilf((tb - t0) / p->step) + 1;
        k = (long)floorf((ta - t0) / p->step) - 1;
        k = k < 0 ? 0 : k;
        steps = k_end < steps ? k_end : steps;
        if (p->jitter)
            esr_rng_skip(&rng, (uint64_t)k);
    }
    for (; k < steps; k++) {
        float u = p->jitter ? esr_rng_float(&rng) : 0.5f;
        float t = t0 + ((float)k + u) * p->step;
        if (t > t1)
            break;
        float q[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
        if (p->mask && !esr_mask_query(p->mask, q))
            continue;
        if (out_t) {
            out_ray[kept] = r;
            out_t[kept] = t;
            out_pos[kept * 3 + 0] = q[0];
            out_pos[kept * 3 + 1] = q[1];
            out_pos[kept * 3 + 2] = q[2];
        }
        if (++kept == (size_t)p->max_per_ray)
            break;
    }
    return kept;
}

int esr_sample_rays(const struct esr_sample_params *p, const float *origins, const float *dirs,
                    int n_rays, struct esr_samples *out)
{
    out->count = 0;
    out->n_rays = 0;
    if (!(p->step > 0.0f) || !(p->near <= p->far) || p->max_per_ray < 0)
        return ESR_FAIL("ray sampling: bad parameters (step %g, near %g, far %g, max per ray %d)",
                        (double)p->step, (double)p->near, (double)p->far, p->max_per_ray);
    if (n_rays < 0 || n_rays > out->max_rays)
        return ESR_FAIL("ray sampling: %d rays, buffer holds at most %d", n_rays, out->max_rays);
    size_t *start = out->ray_start;
    float box[2][3];
    const float(*occ_box)[3] = NULL;
    if (p->mask) {
        if (!esr_mask_occupied_box(p->mask, box[0], box[1])) { /* nothing is kept */
            for (int r = 0; r <= n_rays; r++)
                start[r] = 0;
            out->n_rays = n_rays;
            return ESR_OK;
        }
        occ_box = (const float(*)[3])box;
    }
#pragma omp parallel for schedule(dynamic, 64)
    for (int r = 0; r < n_rays; r++)
        start[r + 1] = march(p, occ_box, origins + (size_t)r * 3, dirs + (size_t)r * 3, r, NULL,
                             NULL, NULL);
    start[0] = 0;
    for (int r = 0; r < n_rays; r++)
        start[r + 1] += start[r];
    out->count = start[n_rays];
    if (out->count > out->capacity)
        return ESR_FAIL("ray sampling: %zu samples needed, buffer holds %zu", out->count,
                        out->capacity);
#pragma omp parallel for schedule(dynamic, 64)
    for (int r = 0; r < n_rays; r++) {
        size_t s0 = start[r];
        march(p, occ_box, origins + (size_t)r * 3, dirs + (size_t)r * 3, r, out->ray + s0,
              out->t + s0, out->pos + s0 * 3);
    }
    out->n_rays = n_rays;
    return ESR_OK;
}
