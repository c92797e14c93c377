/* Emitted radiance per light against the truth (see emitter_radiance.h). */
#include "eval/emitter_radiance.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "eval/emitter_strength.h"
#include "io/file.h"
#include "render/view.h"

/* Whether pixel (x, y) and its 4 neighbours are all inside the mask (grey channel 0 > 1/2). */
static int inside_eroded(const struct esr_image *mask, int x, int y)
{
    static const int dx[5] = {0, 1, -1, 0, 0}, dy[5] = {0, 0, 0, 1, -1};
    for (int k = 0; k < 5; k++) {
        const int u = x + dx[k], v = y + dy[k];
        if (u < 0 || v < 0 || u >= mask->width || v >= mask->height)
            return 0;
        if (mask->data[((size_t)v * (size_t)mask->width + (size_t)u) * (size_t)mask->channels] <= 0.5f)
            return 0;
    }
    return 1;
}

/* Sums over a light's mask: the eroded mask's and the whole mask's. */
struct mask_sums {
    double eroded[3], whole[3];
    long n_eroded, n_whole;
};

/* Adds light K's pixels of one frame to *s. */
static int add_frame(const struct esr_dataset *ds, const struct esr_frame *f, int light,
                     const struct esr_image *emission, struct mask_sums *s)
{
    char path[ESR_PATH_MAX * 2];
    esr_frame_light_mask_path(ds, f, light, path, sizeof path);
    if (!path[0] || !esr_file_exists(path))
        return ESR_OK;
    struct esr_image mask = {0};
    ESR_TRY(esr_png_read(path, &mask));
    int rc = ESR_OK;
    if (mask.width != emission->width || mask.height != emission->height)
        rc = ESR_FAIL("%s: %dx%d, but the rendered emission is %dx%d", path, mask.width,
                      mask.height, emission->width, emission->height);
    for (int y = 0; rc == ESR_OK && y < mask.height; y++)
        for (int x = 0; x < mask.width; x++) {
            const size_t p = (size_t)y * (size_t)mask.width + (size_t)x;
            if (mask.data[p * (size_t)mask.channels] <= 0.5f)
                continue;
            const float *e = emission->data + p * (size_t)emission->channels;
            const int in = inside_eroded(&mask, x, y);
            for (int c = 0; c < 3; c++) {
                s->whole[c] += e[c];
                s->eroded[c] += in ? e[c] : 0.0;
            }
            s->n_whole++;
            s->n_eroded += in;
        }
    esr_image_free(&mask);
    return rc;
}

int esr_emitter_radiance_eval(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx,
                              int n, const char *render_dir, struct esr_emitter_radiance_result *out)
{
    memset(out, 0, sizeof(*out));
    const int lights = ds->n_lights < ds->n_true_lights ? ds->n_lights : ds->n_true_lights;
    if (lights <= 0)
        return ESR_OK;
    struct mask_sums sums[ESR_MAX_TRUE_LIGHTS];
    memset(sums, 0, sizeof sums);
    const struct esr_phase *ph = &ds->phases[phase];
    int rc = ESR_OK;
    for (int i = 0; i < n && rc == ESR_OK; i++) {
        const struct esr_frame *f = &ph->frames[idx[i]];
        char path[ESR_PATH_MAX];
        if (esr_view_path(path, sizeof path, render_dir, f->name, "_emission.exr") != ESR_OK ||
            !esr_file_exists(path))
            continue;
        struct esr_image em = {0};
        rc = esr_exr_read(path, &em);
        for (int k = 0; k < lights && rc == ESR_OK; k++)
            rc = add_frame(ds, f, k, &em, &sums[k]);
        esr_image_free(&em);
    }
    long seen = 0; /* mask pixels of any light in the views with an emission image (0: not scored) */
    for (int k = 0; k < lights; k++)
        seen += sums[k].n_whole;
    for (int k = 0; k < lights && rc == ESR_OK && seen > 0; k++) {
        const struct mask_sums *s = &sums[k];
        struct esr_emitter_radiance *r = &out->lights[out->n++];
        r->light = k;
        snprintf(r->name, sizeof r->name, "%s", ds->true_lights[k].name);
        /* a light too small for the eroded mask keeps its place, scored on its whole mask */
        r->eroded = s->n_eroded > 0;
        r->pixels = r->eroded ? s->n_eroded : s->n_whole;
        r->mask_pixels = s->n_whole;
        r->power = r->truth_power = r->power_ratio = NAN; /* eval/emitter_strength.c's */
        double d2 = 0.0, t2 = 0.0, m2 = 0.0;
        for (int c = 0; c < 3; c++) {
            const double sum = r->eroded ? s->eroded[c] : s->whole[c];
            r->mean[c] = r->pixels > 0 ? sum / (double)r->pixels : NAN;
            r->truth[c] = ds->true_lights[k].radiance[c];
            d2 += (r->mean[c] - r->truth[c]) * (r->mean[c] - r->truth[c]);
            t2 += r->truth[c] * r->truth[c];
            m2 += r->mean[c] * r->mean[c];
        }
        r->error_pct = t2 > 0.0 ? 100.0 * sqrt(d2 / t2) : NAN;
        r->ratio = t2 > 0.0 ? sqrt(m2 / t2) : NAN;
        r->lum_ratio = esr_emitter_luminance_ratio(r->mean, r->truth);
    }
    return rc;
}
