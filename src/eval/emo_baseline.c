/* The thresholded-L_emo emitter baseline (see emo_baseline.h). */
#include "eval/emo_baseline.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/buffers.h"
#include "core/error.h"
#include "core/order.h"
#include "io/file.h"
#include "io/image.h"
#include "render/view.h"

/* Every pixel's max-channel L_emo, and those of the pixels the mask calls emitter. */
struct emo_values {
    float *all, *truth;
    size_t n_all, n_truth, cap_all, cap_truth;
};

/* Adds one camera: on, off (rendered linear RGB) and the ground-truth mask. */
static int add_camera(const struct esr_image *on, const struct esr_image *off,
                      const struct esr_image *gt, struct emo_values *ev)
{
    if (on->width != off->width || on->height != off->height || on->width != gt->width ||
        on->height != gt->height)
        return ESR_FAIL("L_emo baseline: rendered %dx%d / %dx%d and mask %dx%d differ", on->width,
                        on->height, off->width, off->height, gt->width, gt->height);
    const long long np = (long long)on->width * on->height;
    ESR_TRY(esr_floats_reserve(&ev->all, &ev->cap_all, ev->n_all + (size_t)np, "L_emo baseline pixels"));
    ESR_TRY(esr_floats_reserve(&ev->truth, &ev->cap_truth, ev->n_truth + (size_t)np,
                               "L_emo baseline pixels"));
    for (long long p = 0; p < np; p++) {
        float e = -INFINITY;
        for (int c = 0; c < 3; c++)
            e = fmaxf(e, on->data[p * on->channels + c] - off->data[p * off->channels + c]);
        if (!(e == e))
            e = -INFINITY; /* NaN: never above a threshold */
        ev->all[ev->n_all++] = e;
        if (gt->data[p * gt->channels] > 0.5f)
            ev->truth[ev->n_truth++] = e;
    }
    return ESR_OK;
}

/* The best pooled IoU of (e > k) over every k that changes the prediction: with both lists
 * sorted, each distinct value v of e (largest first) is a cut just below v, whose prediction is
 * the pixels at v or above; k is reported midway to the next value down. */
static void best_threshold(struct emo_values *ev, struct esr_emo_baseline *out)
{
    esr_sort_floats(ev->all, ev->n_all);
    esr_sort_floats(ev->truth, ev->n_truth);
    size_t a = ev->n_all, t = ev->n_truth; /* [a, n_all) predicted, [t, n_truth) of them true */
    while (a > 0 && ev->all[a - 1] > -INFINITY) {
        const float v = ev->all[a - 1];
        while (a > 0 && ev->all[a - 1] == v)
            a--;
        while (t > 0 && ev->truth[t - 1] >= v)
            t--;
        const size_t pred = ev->n_all - a, inter = ev->n_truth - t;
        const double iou = (double)inter / (double)(pred + ev->n_truth - inter);
        if (iou > out->iou) {
            out->iou = iou;
            out->k = a > 0 && ev->all[a - 1] > -INFINITY ? 0.5 * ((double)v + ev->all[a - 1])
                                                        : (double)v - 1.0;
        }
    }
}

/* "<dir>/<name with the trailing _on replaced by _off>.exr"; 0 when name does not end in _on. */
static int partner_path(char *out, size_t n, const char *dir, const char *name)
{
    char off[ESR_NAME_MAX];
    return esr_frame_off_partner(name, off, sizeof off) &&
           snprintf(out, n, "%s/%s.exr", dir, off) < (int)n;
}

int esr_emo_baseline_eval(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx,
                          int n, const char *render_dir, struct esr_emo_baseline *out)
{
    memset(out, 0, sizeof *out);
    struct emo_values ev;
    memset(&ev, 0, sizeof ev);
    const struct esr_phase *ph = &ds->phases[phase];
    int status = ESR_OK;
    for (int i = 0; i < n && status == ESR_OK; i++) {
        const struct esr_frame *f = &ph->frames[idx[i]];
        char on_path[ESR_PATH_MAX], off_path[ESR_PATH_MAX], gt_path[ESR_PATH_MAX];
        if (!partner_path(off_path, sizeof off_path, render_dir, f->name) ||
            esr_view_path(on_path, sizeof on_path, render_dir, f->name, ".exr") != ESR_OK)
            continue;
        esr_frame_emission_path(ds, f, gt_path, sizeof gt_path);
        if (!esr_file_exists(on_path) || !esr_file_exists(off_path) || !esr_file_exists(gt_path))
            continue;
        struct esr_image on = {0}, off = {0}, gt = {0};
        status = esr_image_read(on_path, &on);
        if (status == ESR_OK)
            status = esr_image_read(off_path, &off);
        if (status == ESR_OK)
            status = esr_image_read(gt_path, &gt);
        if (status == ESR_OK)
            status = add_camera(&on, &off, &gt, &ev);
        if (status == ESR_OK)
            out->n_cameras++;
        esr_image_free(&on);
        esr_image_free(&off);
        esr_image_free(&gt);
    }
    if (status == ESR_OK && out->n_cameras > 0)
        best_threshold(&ev, out);
    free(ev.all);
    free(ev.truth);
    return status;
}
