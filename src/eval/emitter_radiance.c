/* Emitted radiance per light against the truth (see emitter_radiance.h). */
#include "eval/emitter_radiance.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
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

/* Adds light K's pixels of one frame to sum[3] / *count. */
static int add_frame(const struct esr_dataset *ds, const struct esr_frame *f, int light,
                     const struct esr_image *emission, double sum[3], long *count)
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
            if (!inside_eroded(&mask, x, y))
                continue;
            const float *e = emission->data + ((size_t)y * (size_t)emission->width + (size_t)x) *
                                                  (size_t)emission->channels;
            for (int c = 0; c < 3; c++)
                sum[c] += e[c];
            (*count)++;
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
    double sum[ESR_MAX_TRUE_LIGHTS][3];
    long count[ESR_MAX_TRUE_LIGHTS];
    memset(sum, 0, sizeof sum);
    memset(count, 0, sizeof count);
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
            rc = add_frame(ds, f, k, &em, sum[k], &count[k]);
        esr_image_free(&em);
    }
    for (int k = 0; k < lights && rc == ESR_OK; k++) {
        if (count[k] == 0)
            continue;
        struct esr_emitter_radiance *r = &out->lights[out->n++];
        r->light = k;
        snprintf(r->name, sizeof r->name, "%s", ds->true_lights[k].name);
        r->pixels = count[k];
        double d2 = 0.0, t2 = 0.0, m2 = 0.0;
        for (int c = 0; c < 3; c++) {
            r->mean[c] = sum[k][c] / (double)count[k];
            r->truth[c] = ds->true_lights[k].radiance[c];
            d2 += (r->mean[c] - r->truth[c]) * (r->mean[c] - r->truth[c]);
            t2 += r->truth[c] * r->truth[c];
            m2 += r->mean[c] * r->mean[c];
        }
        r->error_pct = t2 > 0.0 ? 100.0 * sqrt(d2 / t2) : NAN;
        r->ratio = t2 > 0.0 ? sqrt(m2 / t2) : NAN;
    }
    return rc;
}
