/* Test-view PSNR of a model (see quick_eval.h). */
#include "eval/quick_eval.h"

#include <math.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "io/dataset.h"
#include "model/model.h"
#include "render/view.h"

/* Renders one frame (render/view.h, the one view renderer) and adds its two PSNRs to out. */
static int eval_frame(const struct esr_model *m, const struct esr_dataset *ds,
                      const struct esr_frame *f, struct esr_quick_eval *out)
{
    struct esr_view_images v;
    struct esr_image gt;
    int rc = esr_view_render(m, &f->camera, f->lights_on, &v);
    if (rc == ESR_OK)
        rc = esr_frame_load_rgb(ds, f, &gt, NULL);
    if (rc != ESR_OK) {
        esr_view_images_free(&v);
        return rc;
    }
    const size_t n = (size_t)ds->width * (size_t)ds->height * 3;
    double e_tone = 0.0, e_lin = 0.0;
    for (size_t i = 0; i < n; i++) {
        double t = gt.data[i];
        double a = fmin(fmax(v.rgb.data[i], 0.0), 1.0) - t;
        double g = esr_srgb_from_linear(fminf(fmaxf(v.linear.data[i], 0.0f), 1.0f)) - t;
        e_tone += a * a;
        e_lin += g * g;
    }
    esr_image_free(&gt);
    esr_view_images_free(&v);
    int on = f->lights_on ? 1 : 0;
    out->psnr_tone[on] += esr_psnr_from_mse(fmax(e_tone / (double)n, 1e-12));
    out->psnr_lin[on] += esr_psnr_from_mse(fmax(e_lin / (double)n, 1e-12));
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
    for (int i = 0; rc == ESR_OK && i < ph->n_frames; i++)
        rc = eval_frame(&m, &ds, &ph->frames[i], out);
    for (int c = 0; c < 2 && rc == ESR_OK; c++)
        if (out->views[c]) {
            out->psnr_tone[c] /= out->views[c];
            out->psnr_lin[c] /= out->views[c];
        }
    esr_dataset_free(&ds);
    esr_model_free(&m);
    return rc;
}
