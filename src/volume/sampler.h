/* Ray marching sample generation: the points at fixed steps (0.5 voxel in the method) where each
 * ray of a batch lies inside the scene box and the mask cache says "possibly occupied", written
 * as a compact structure-of-arrays list grouped by ray. Caller-owned buffers (the mask's block
 * summary is allocated on the first call with a mask, and regrown only for a larger mask), so the
 * same code serves primary rays and the LTS loss's secondary rays. */
#ifndef ESR_VOLUME_SAMPLER_H
#define ESR_VOLUME_SAMPLER_H

#include <stddef.h>
#include <stdint.h>

#include "fields/mask.h"

#ifdef __cplusplus
extern "C" {
#endif

struct esr_sample_params {
    float bmin[3], bmax[3];      /* scene box (samples only inside it) */
    float near, far;             /* ray parameter range before clipping by the box (default 0 and
                                    1e30: the box alone decides, whatever the camera distance) */
    float step;                  /* distance between samples along t (world units for unit d) */
    int jitter;                  /* 0: t = t0 + (k + 0.5) step; 1: t = t0 + (k + u) step, one
                                    random u per ray */
    uint64_t seed;               /* jitter randomness: stream = stream_base + ray index */
    uint64_t stream_base;
    int max_per_ray;             /* cap on samples of one ray (0 = no cap) */
    const struct esr_mask *mask; /* NULL: keep every in-box sample */
    const float *t_min, *t_max;  /* per ray [n_rays], or NULL: near / far for every ray (each
                                    narrows [near, far]; secondary and shadow rays) */
    const uint64_t *streams;     /* per-ray jitter stream [n_rays], or NULL: stream_base + ray */
};

struct esr_samples {
    size_t capacity;    /* entries in ray / t / pos */
    int max_rays;       /* entries - 1 in ray_start */
    size_t count;       /* samples written by the last call */
    int n_rays;         /* rays of the last call */
    int32_t *ray;       /* [capacity] ray index of each sample */
    float *t;           /* [capacity] ray parameter of each sample (increasing within a ray) */
    float *pos;         /* [capacity * 3] world position xyz */
    size_t *ray_start;  /* [max_rays + 1]: ray r owns samples ray_start[r] .. ray_start[r+1]-1 */
    uint8_t *blocks;    /* [blocks_cap] scratch: the mask's empty blocks (esr_mask_blocks) */
    size_t blocks_cap;
};

/* Parameters for marching the box [bmin, bmax] at `step` from t = 0 (no near or far beyond the
 * box), no jitter, no cap and no mask; callers then adjust fields. */
void esr_sample_params_init(struct esr_sample_params *p, const float bmin[3], const float bmax[3],
                            float step);

/* Allocates buffers for up to `capacity` samples over up to `max_rays` rays. */
int esr_samples_alloc(struct esr_samples *s, size_t capacity, int max_rays);
void esr_samples_free(struct esr_samples *s);

/* Marches n_rays rays (origins / dirs: n_rays * 3 floats) and fills *out. Two parallel passes
 * (count, then write) so the output order is ray order and the result does not depend on the
 * thread count. Fails, with out->count set to the number needed, when it exceeds out->capacity
 * or n_rays exceeds out->max_rays; fails on bad parameters (step <= 0, near > far). */
int esr_sample_rays(const struct esr_sample_params *p, const float *origins, const float *dirs,
                    int n_rays, struct esr_samples *out);

#ifdef __cplusplus
}
#endif
#endif
