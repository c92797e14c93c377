/* Training ray precomputation and batch drawing (see rays.h). */
#include "train/rays.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "core/limits.h"
#include "core/rng.h"

void esr_ray_set_free(struct esr_ray_set *rs)
{
    free(rs->orig3);
    free(rs->dir3);
    free(rs->rgb3);
    memset(rs, 0, sizeof(*rs));
}

/* Appends one frame's rays at ray index `at`. */
static int add_frame(struct esr_ray_set *rs, const struct esr_dataset *ds, const struct esr_frame *f,
                     size_t at)
{
    struct esr_image rgb, alpha;
    ESR_TRY(esr_frame_load_rgb(ds, f, &rgb, &alpha));
    esr_camera_pixel_rays(&f->camera, rs->orig3 + at * 3, rs->dir3 + at * 3);
    const size_t n = (size_t)ds->width * (size_t)ds->height;
    memcpy(rs->rgb3 + at * 3, rgb.data, n * 3 * sizeof(float));
    for (size_t i = 0; i < n && !rs->transparent; i++)
        rs->transparent = alpha.data[i] < 0.999f;
    esr_image_free(&rgb);
    esr_image_free(&alpha);
    return ESR_OK;
}

size_t esr_ray_set_bytes(size_t n_rays)
{
    return n_rays * 9 * sizeof(float); /* origin, direction, colour */
}

int esr_ray_set_build(struct esr_ray_set *rs, const struct esr_dataset *ds, enum esr_phase_id phase)
{
    memset(rs, 0, sizeof(*rs));
    const struct esr_phase *ph = &ds->phases[phase];
    if (!ph->present || ph->n_frames < 1)
        return ESR_FAIL("dataset %s: phase '%s' has no frames to train on", ds->root,
                        esr_phase_name(phase));
    size_t per = (size_t)ds->width * (size_t)ds->height, n = per * (size_t)ph->n_frames;
    char what[1400];
    snprintf(what, sizeof what, "the training rays of dataset %s (%d frames of %d x %d pixels)", ds->root,
             ph->n_frames, ds->width, ds->height);
    ESR_TRY(esr_limits_check_memory(0, esr_ray_set_bytes(n), what));
    rs->orig3 = malloc(n * 3 * sizeof(float));
    rs->dir3 = malloc(n * 3 * sizeof(float));
    rs->rgb3 = malloc(n * 3 * sizeof(float));
    if (!rs->orig3 || !rs->dir3 || !rs->rgb3) {
        esr_ray_set_free(rs);
        return ESR_FAIL("dataset %s: out of memory for %zu training rays", ds->root, n);
    }
    size_t at = 0;
    for (int pass = 0; pass < 2; pass++)
        for (int i = 0; i < ph->n_frames; i++) {
            if (ph->frames[i].lights_on != pass)
                continue;
            if (add_frame(rs, ds, &ph->frames[i], at) != ESR_OK) {
                esr_ray_set_free(rs);
                return ESR_ERR;
            }
            at += per;
            if (pass == 0)
                rs->n_off = at;
        }
    rs->n = n;
    return ESR_OK;
}

void esr_ray_set_draw(const struct esr_ray_set *rs, uint64_t seed, long step, int n, float *orig3,
                      float *dir3, float *rgb3, uint8_t *lights_on)
{
    int n_off = (int)llround((double)n * (double)rs->n_off / (double)rs->n);
    if (rs->n_off > 0 && n_off == 0)
        n_off = 1;
    if (rs->n_off < rs->n && n_off == n)
        n_off = n - 1;
    const size_t n_on_rays = rs->n - rs->n_off;
#pragma omp parallel for schedule(static)
    for (int i = 0; i < n; i++) {
        struct esr_rng rng = esr_rng_init(seed, (uint64_t)step * (uint64_t)n + (uint64_t)i);
        uint64_t u = esr_rng_u64(&rng);
        size_t r = i < n_off ? (size_t)(u % rs->n_off) : rs->n_off + (size_t)(u % n_on_rays);
        lights_on[i] = i >= n_off;
        for (int c = 0; c < 3; c++) {
            orig3[i * 3 + c] = rs->orig3[r * 3 + c];
            dir3[i * 3 + c] = rs->dir3[r * 3 + c];
            rgb3[i * 3 + c] = rs->rgb3[r * 3 + c];
        }
    }
}
