/* The thresholded-L_emo emitter baseline (see emo_baseline.h). */
#include "eval/emo_baseline.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "core/error.h"
#include "io/file.h"
#include "io/image.h"
#include "render/view.h"

#define N_K 64

static double threshold(int i)
{
    return 0.01 * pow(3000.0, (double)i / (N_K - 1)); /* 0.01 .. 30 */
}

/* Adds one camera: on, off (rendered linear RGB) and the ground-truth mask. */
static int add_camera(const struct esr_image *on, const struct esr_image *off,
                      const struct esr_image *gt, uint64_t *inter, uint64_t *uni)
{
    if (on->width != off->width || on->height != off->height || on->width != gt->width ||
        on->height != gt->height)
        return ESR_FAIL("L_emo baseline: rendered %dx%d / %dx%d and mask %dx%d differ", on->width,
                        on->height, off->width, off->height, gt->width, gt->height);
    const long long np = (long long)on->width * on->height;
    for (long long p = 0; p < np; p++) {
        float e = -INFINITY;
        for (int c = 0; c < 3; c++)
            e = fmaxf(e, on->data[p * on->channels + c] - off->data[p * off->channels + c]);
        const int truth = gt->data[p * gt->channels] > 0.5f;
        for (int i = 0; i < N_K; i++) {
            const int pred = e > threshold(i);
            inter[i] += (uint64_t)(pred & truth);
            uni[i] += (uint64_t)(pred | truth);
        }
    }
    return ESR_OK;
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
    uint64_t inter[N_K] = {0}, uni[N_K] = {0};
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
            status = add_camera(&on, &off, &gt, inter, uni);
        if (status == ESR_OK)
            out->n_cameras++;
        esr_image_free(&on);
        esr_image_free(&off);
        esr_image_free(&gt);
    }
    ESR_TRY(status);
    for (int i = 0; i < N_K && out->n_cameras > 0; i++) {
        double iou = uni[i] ? (double)inter[i] / (double)uni[i] : 0.0;
        if (iou > out->iou) {
            out->iou = iou;
            out->k = threshold(i);
        }
    }
    return ESR_OK;
}
