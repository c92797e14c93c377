/* The environment map's starting brightness (see env_init.h). */
#include "train/env_init.h"

#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "core/rng.h"
#include "fields/background.h"

#define RAYS 8192
/* a ray sees a surface when its opacity exceeds this */
#define SURFACE_OPACITY 0.5f
/* the photos' estimate: more rays (a pixel costs a render only for its opacity), fully opaque */
#define PHOTO_RAYS 65536
#define PHOTO_OPACITY 0.99f

static void set_level(const double sum[3], long count, float level[3], float surface_mean[3])
{
    for (int c = 0; c < 3; c++) {
        surface_mean[c] = (float)(sum[c] / (double)count);
        level[c] = (surface_mean[c] > 1e-4f ? surface_mean[c] : 1e-4f) / ESR_ENV_INIT_AV;
    }
}

/* Where pick_and_render writes: origins and directions, the linear colour (may be NULL), the
 * opacity, each ray's index into the rays (may be NULL). */
struct picked {
    float *o, *d, *lin, *opac;
    size_t *pick;
};

/* count rays picked at random (stream `stream` of seed) into p's o and d, rendered lights-off by
 * prev. */
static int pick_and_render(const struct esr_model *prev, const struct esr_env_init_rays *rays, int count,
                           uint64_t seed, uint64_t stream, const struct picked *p)
{
    struct esr_rng rng = esr_rng_init(seed, stream);
    for (int i = 0; i < count; i++) {
        const size_t r = (size_t)(esr_rng_u64(&rng) % rays->n);
        if (p->pick)
            p->pick[i] = r;
        memcpy(p->o + i * 3, rays->orig3 + r * 3, 3 * sizeof(float));
        memcpy(p->d + i * 3, rays->dir3 + r * 3, 3 * sizeof(float));
    }
    struct esr_render_out out = {.linear = p->lin, .opacity = p->opac};
    return esr_model_render_rays(prev, p->o, p->d, (size_t)count, 0, &out);
}

/* from_photos 1: the photos' pixels where prev renders the ray opaque (its colour is not read). */
static int level_from_photos(const struct esr_model *prev, const struct esr_env_init_rays *rays,
                             uint64_t seed, float level[3], float surface_mean[3])
{
    const struct picked p = {malloc(PHOTO_RAYS * 3 * sizeof(float)), malloc(PHOTO_RAYS * 3 * sizeof(float)),
                             NULL, malloc(PHOTO_RAYS * sizeof(float)), malloc(PHOTO_RAYS * sizeof(size_t))};
    int rc = p.o && p.d && p.opac && p.pick ? ESR_OK : ESR_FAIL("environment level: out of memory");
    if (rc == ESR_OK)
        rc = pick_and_render(prev, rays, PHOTO_RAYS, seed, 0xe8, &p);
    double sum[3] = {0.0, 0.0, 0.0};
    long count = 0;
    for (int i = 0; rc == ESR_OK && i < PHOTO_RAYS; i++) {
        if (p.opac[i] <= PHOTO_OPACITY)
            continue;
        for (int c = 0; c < 3; c++)
            sum[c] += esr_linear_from_srgb(rays->rgb3[p.pick[i] * 3 + c]);
        count++;
    }
    if (rc == ESR_OK && count == 0)
        rc = ESR_FAIL("environment level: none of %d lights-off rays sees a surface", PHOTO_RAYS);
    if (rc == ESR_OK)
        set_level(sum, count, level, surface_mean);
    free(p.o), free(p.d), free(p.opac), free(p.pick);
    return rc;
}

int esr_env_init_level(const struct esr_model *prev, const struct esr_env_init_rays *rays,
                       uint64_t seed, int from_photos, float level[3], float surface_mean[3])
{
    if (rays->n == 0)
        return ESR_FAIL("environment level: no lights-off rays to measure it on");
    if (from_photos)
        return level_from_photos(prev, rays, seed, level, surface_mean);
    float *o = malloc(RAYS * 3 * sizeof(float)), *d = malloc(RAYS * 3 * sizeof(float));
    float *lin = malloc(RAYS * 3 * sizeof(float)), *opac = malloc(RAYS * sizeof(float));
    int rc = o && d && lin && opac ? ESR_OK : ESR_FAIL("environment level: out of memory");
    if (rc == ESR_OK) {
        const struct picked p = {o, d, lin, opac, NULL};
        rc = pick_and_render(prev, rays, RAYS, seed, 0xe7, &p);
    }
    /* what the render composited behind the surface: white, or the learned background */
    float *bg = NULL;
    if (rc == ESR_OK && esr_model_has(prev, ESR_COMP_BACKGROUND)) {
        bg = malloc(RAYS * 3 * sizeof(float));
        uint8_t *off = calloc(RAYS, 1);
        if (bg && off) {
            esr_background_fwd_linear(esr_model_values(prev, ESR_COMP_BACKGROUND), d, off, RAYS, bg, bg);
        } else {
            rc = ESR_FAIL("environment level: out of memory");
        }
        free(off);
    }
    double sum[3] = {0.0, 0.0, 0.0};
    long count = 0;
    for (int i = 0; rc == ESR_OK && i < RAYS; i++) {
        const float a = opac[i];
        if (a <= SURFACE_OPACITY)
            continue;
        for (int c = 0; c < 3; c++) /* the surface's own radiance: lin = a L + (1 - a) bg */
            sum[c] += (lin[i * 3 + c] - (1.0f - a) * (bg ? bg[i * 3 + c] : 1.0f)) / a;
        count++;
    }
    if (rc == ESR_OK && count == 0)
        rc = ESR_FAIL("environment level: none of %d lights-off rays sees a surface", RAYS);
    if (rc == ESR_OK)
        set_level(sum, count, level, surface_mean);
    free(o), free(d), free(lin), free(opac), free(bg);
    return rc;
}
