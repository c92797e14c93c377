/* esr's light split against the dataset's per-light masks (see light_split.h). */
#include "eval/light_split.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"
#include "render/view.h"

#define MAX_TRUE ESR_MAX_TRUE_LIGHTS

struct counts {
    long inter[MAX_TRUE][ESR_MAX_LIGHTS], truth[MAX_TRUE], pred[ESR_MAX_LIGHTS];
};

/* Adds one view: ids (code values, 0 = none) against each light's mask. */
static int add_view(const struct esr_dataset *ds, const struct esr_frame *f,
                    const struct esr_image *ids, int lights, struct counts *c, int *used)
{
    const size_t np = (size_t)ids->width * (size_t)ids->height;
    *used = 0;
    for (int k = 0; k < lights; k++) {
        char path[ESR_PATH_MAX * 2];
        esr_frame_light_mask_path(ds, f, k, path, sizeof path);
        if (!path[0] || !esr_file_exists(path))
            continue;
        struct esr_image mask = {0};
        ESR_TRY(esr_png_read(path, &mask));
        int rc = mask.width == ids->width && mask.height == ids->height
                     ? ESR_OK
                     : ESR_FAIL("%s: %dx%d, the rendered light ids %dx%d", path, mask.width,
                                mask.height, ids->width, ids->height);
        for (size_t p = 0; rc == ESR_OK && p < np; p++) {
            if (mask.data[p * (size_t)mask.channels] <= 0.5f)
                continue;
            c->truth[k]++;
            const int id = (int)lroundf(ids->data[p * (size_t)ids->channels] * 255.0f) - 1;
            if (id >= 0 && id < ESR_MAX_LIGHTS)
                c->inter[k][id]++;
        }
        esr_image_free(&mask);
        ESR_TRY(rc);
        *used = 1;
    }
    if (*used)
        for (size_t p = 0; p < np; p++) {
            const int id = (int)lroundf(ids->data[p * (size_t)ids->channels] * 255.0f) - 1;
            if (id >= 0 && id < ESR_MAX_LIGHTS)
                c->pred[id]++;
        }
    return ESR_OK;
}

int esr_light_split_eval(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx,
                         int n, const char *render_dir, struct esr_light_split *out)
{
    memset(out, 0, sizeof(*out));
    for (int j = 0; j < ESR_MAX_LIGHTS; j++)
        out->dataset_light[j] = -1;
    const int lights = ds->n_lights < MAX_TRUE ? ds->n_lights : MAX_TRUE;
    static struct counts zero;
    struct counts c = zero;
    const struct esr_phase *ph = &ds->phases[phase];
    for (int i = 0; i < n; i++) {
        const struct esr_frame *f = &ph->frames[idx[i]];
        char path[ESR_PATH_MAX];
        if (esr_view_path(path, sizeof path, render_dir, f->name, "_lights.png") != ESR_OK ||
            !esr_file_exists(path))
            continue;
        struct esr_image ids = {0};
        ESR_TRY(esr_png_read(path, &ids));
        int used = 0;
        const int rc = add_view(ds, f, &ids, lights, &c, &used);
        esr_image_free(&ids);
        ESR_TRY(rc);
        out->views += used;
    }
    if (out->views == 0)
        return ESR_OK;
    double sum = 0.0;
    for (int k = 0; k < lights; k++) {
        if (c.truth[k] == 0)
            continue;
        struct esr_light_split_row *r = &out->rows[out->n++];
        r->light = k;
        r->true_pixels = c.truth[k];
        if (k < ds->n_true_lights)
            snprintf(r->name, sizeof r->name, "%s", ds->true_lights[k].name);
        r->esr_light = -1;
        for (int j = 0; j < ESR_MAX_LIGHTS; j++) {
            const long uni = c.truth[k] + c.pred[j] - c.inter[k][j];
            const double iou = uni > 0 ? (double)c.inter[k][j] / (double)uni : 0.0;
            if (c.inter[k][j] > 0 && iou > r->iou) {
                r->iou = iou;
                r->esr_light = j;
            }
        }
        sum += r->iou;
    }
    out->mean_iou = out->n ? sum / out->n : 0.0;
    for (int j = 0; j < ESR_MAX_LIGHTS; j++) { /* most of its pixels in K's masks: it follows K */
        for (int k = 0; k < lights; k++) {
            const int have = out->dataset_light[j];
            if (c.pred[j] > 0 && 2 * c.inter[k][j] >= c.pred[j] &&
                (have < 0 || c.inter[k][j] > c.inter[have][j])) /* half each: the larger overlap */
                out->dataset_light[j] = k;
        }
    }
    return ESR_OK;
}
