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

/* from_photos 1: the photos' pixels where prev renders the ray opaque. */
static int level_from_photos(const struct esr_model *prev, const struct esr_env_init_rays *rays,
                             uint64_t seed, float level[3], float surface_mean[3])
{
    float *o = malloc(PHOTO_RAYS * 3 * sizeof(float)), *d = malloc(PHOTO_RAYS * 3 * sizeof(float));
    float *lin = malloc(PHOTO_RAYS * 3 * sizeof(float)), *opac = malloc(PHOTO_RAYS * sizeof(float));
    size_t *pick = malloc(PHOTO_RAYS * sizeof(size_t));
    int rc = o && d && lin && opac && pick ? ESR_OK : ESR_FAIL("environment level: out of memory");
    struct esr_rng rng = esr_rng_init(seed, 0xe8);
    for (int i = 0; rc == ESR_OK && i < PHOTO_RAYS; i++) {
        pick[i] = (size_t)(esr_rng_u64(&rng) % rays->n);
        memcpy(o + i * 3, rays->orig3 + pick[i] * 3, 3 * sizeof(float));
        memcpy(d + i * 3, rays->dir3 + pick[i] * 3, 3 * sizeof(float));
    }
    if (rc == ESR_OK) {
        struct esr_render_out out = {.linear = lin, .opacity = opac};
        rc = esr_model_render_rays(prev, o, d, PHOTO_RAYS, 0, &out);
    }
    double sum[3] = {0.0, 0.0, 0.0};
    long count = 0;
    for (int i = 0; rc == ESR_OK && i < PHOTO_RAYS; i++) {
        if (opac[i] <= PHOTO_OPACITY)
            continue;
        for (int c = 0; c < 3; c++)
            sum[c] += esr_linear_from_srgb(rays->rgb3[pick[i] * 3 + c]);
        count++;
    }
    if (rc == ESR_OK && count == 0)
        rc = ESR_FAIL("environment level: none of %d lights-off rays sees a surface", PHOTO_RAYS);
    if (rc == ESR_OK)
        set_level(sum, count, level, surface_mean);
    free(o), free(d), free(lin), free(opac), free(pick);
    return rc;
}

int esr_env_init_level(const struct esr_model *prev, const struct esr_env_init_rays *rays,
                       uint64_t seed, int from_photos, float level[3], float surface_mean[3])
{
    const size_t n = rays->n;
    if (n == 0)
        return ESR_FAIL("environment level: no lights-off rays to measure it on");
    if (from_photos)
        return level_from_photos(prev, rays, seed, level, surface_mean);
    const float *orig3 = rays->orig3, *dir3 = rays->dir3;
    float *o = malloc(RAYS * 3 * sizeof(float)), *d = malloc(RAYS * 3 * sizeof(float));
    float *lin = malloc(RAYS * 3 * sizeof(float)), *opac = malloc(RAYS * sizeof(float));
    int rc = o && d && lin && opac ? ESR_OK : ESR_FAIL("environment level: out of memory");
    struct esr_rng rng = esr_rng_init(seed, 0xe7);
    for (int i = 0; rc == ESR_OK && i < RAYS; i++) {
        const size_t r = (size_t)(esr_rng_u64(&rng) % n);
        for (int c = 0; c < 3; c++) {
            o[i * 3 + c] = orig3[r * 3 + c];
            d[i * 3 + c] = dir3[r * 3 + c];
        }
    }
    if (rc == ESR_OK) {
        struct esr_render_out out = {.linear = lin, .opacity = opac};
        rc = esr_model_render_rays(prev, o, d, RAYS, 0, &out);
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
