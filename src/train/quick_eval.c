/* Test-view PSNR of a model (see quick_eval.h). */
#include "train/quick_eval.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "io/dataset.h"
#include "train/model.h"

static double psnr_of(double mse) { return -10.0 * log10(mse > 1e-12 ? mse : 1e-12); }

/* Renders one frame and adds its two PSNRs to out. */
static int eval_frame(const struct esr_model *m, const struct esr_dataset *ds,
                      const struct esr_frame *f, float *orig, float *dir, float *rgb, float *lin,
                      struct esr_quick_eval *out)
{
    const int w = ds->width, h = ds->height;
    const size_t n = (size_t)w * (size_t)h;
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            size_t r = (size_t)j * (size_t)w + (size_t)i;
            esr_camera_ray(&f->camera, (float)i + 0.5f, (float)j + 0.5f, orig + r * 3, dir + r * 3);
        }
    struct esr_render_out ro;
    memset(&ro, 0, sizeof ro);
    ro.rgb = rgb;
    ro.linear = lin;
    ESR_TRY(esr_model_render_rays(m, orig, dir, n, f->lights_on, &ro));
    struct esr_image gt;
    ESR_TRY(esr_frame_load_rgb(ds, f, &gt, NULL));
    double e_tone = 0.0, e_lin = 0.0;
    for (size_t i = 0; i < n * 3; i++) {
        double t = gt.data[i];
        double a = fmin(fmax(rgb[i], 0.0), 1.0) - t;
        double g = esr_srgb_from_linear(fminf(fmaxf(lin[i], 0.0f), 1.0f)) - t;
        e_tone += a * a;
        e_lin += g * g;
    }
    esr_image_free(&gt);
    int on = f->lights_on ? 1 : 0;
    out->psnr_tone[on] += psnr_of(e_tone / (double)(n * 3));
    out->psnr_lin[on] += psnr_of(e_lin / (double)(n * 3));
    out->views[on]++;
    return ESR_OK;
}

int esr_quick_eval_run(const char *model_path, const char *data_dir, struct esr_quick_eval *out)
{
    memset(out, 0, sizeof(*out));
    struct esr_model m;
    ESR_TRY(esr_model_load(&m, model_path));
    struct esr_dataset ds;
    if (esr_dataset_load(data_dir, &ds) != ESR_OK) {
        esr_model_free(&m);
        return ESR_ERR;
    }
    int rc = ESR_OK;
    const struct esr_phase *ph = &ds.phases[ESR_PHASE_TEST_NV];
    if (!ph->present || ph->n_frames < 1)
        rc = ESR_FAIL("dataset %s: no test_nv frames to evaluate", ds.root);
    size_t n = (size_t)ds.width * (size_t)ds.height;
    float *buf = rc == ESR_OK ? malloc(n * 12 * sizeof(float)) : NULL;
    if (rc == ESR_OK && !buf)
        rc = ESR_FAIL("quick eval: out of memory");
    for (int i = 0; rc == ESR_OK && i < ph->n_frames; i++)
        rc = eval_frame(&m, &ds, &ph->frames[i], buf, buf + n * 3, buf + n * 6, buf + n * 9, out);
    for (int c = 0; c < 2 && rc == ESR_OK; c++)
        if (out->views[c]) {
            out->psnr_tone[c] /= out->views[c];
            out->psnr_lin[c] /= out->views[c];
        }
    free(buf);
    esr_dataset_free(&ds);
    esr_model_free(&m);
    return rc;
}
