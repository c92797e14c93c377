/* Evaluation of rendered test views against a dataset phase (METHOD.md, "Emitter identification
 * and metrics"): PSNR / SSIM of the tone-mapped and of the gamma-corrected linear output against
 * the ground-truth PNG (composited on white), and HDR MSE of the linear EXR against the
 * ground-truth EXR (composited on white), per view, overall and per lighting mode.
 *
 * The rendered directory holds, per frame name N, the files of render/view.h (esr_view_write):
 * N.png (tone-mapped RGB on white), N_linear.png (sRGB OETF of the linear RGB on white, clipped
 * to [0,1]) and N.exr (linear RGB on white). */
#ifndef ESR_EVAL_EVALUATE_H
#define ESR_EVAL_EVALUATE_H

#include "io/dataset.h"

/* PSNR of identical images is infinite; per-view values and means are capped here so that every
 * number stays finite (JSON has no infinity) and one perfect view cannot dominate a mean. */
#define ESR_EVAL_PSNR_CAP 100.0

struct esr_eval_view {
    char name[ESR_NAME_MAX];
    enum esr_light_mode mode;  /* esr_frame_mode of the frame */
    double psnr, ssim;         /* tone-mapped output vs ground-truth PNG */
    double psnr_linear, ssim_linear; /* gamma-corrected linear output vs ground-truth PNG */
    double hdr_mse;            /* linear EXR vs ground-truth EXR; NAN when the dataset has none */
};

/* Means over a set of views (hdr_mse over the views that have it; NAN when none). */
struct esr_eval_mean {
    int n;
    double psnr, ssim, psnr_linear, ssim_linear, hdr_mse;
};

struct esr_eval_result {
    enum esr_phase_id phase;
    char render_dir[ESR_PATH_MAX];
    int n_views;
    struct esr_eval_view *views;               /* in evaluation order */
    struct esr_eval_mean all;
    struct esr_eval_mean by_mode[ESR_LIGHT_MODE_COUNT]; /* n = 0 for modes without views */
};

/* Evaluates the frames idx[0..n) of `phase` (esr_select_frames) against the images in
 * render_dir. Fails with a message naming the file on a missing or unreadable rendered image or a
 * size that differs from the dataset's. *res is zeroed first; free it with
 * esr_eval_result_free (also after an error). */
int esr_eval_phase(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx, int n,
                   const char *render_dir, struct esr_eval_result *res);
void esr_eval_result_free(struct esr_eval_result *res);

/* Writes the result as JSON (atomically):
 *   {"phase": "test_nv", "dataset": ds->root, "render_dir": ..., "psnr_cap": 100, "n_views": V,
 *    "views": [{"name", "mode", "psnr", "ssim", "psnr_linear", "ssim_linear", "hdr_mse"}...],
 *    "mean": {"n", "psnr", "ssim", "psnr_linear", "ssim_linear", "hdr_mse"},
 *    "by_mode": {"off": {...mean...}, "on": {...}}}   (only modes that have views)
 * A NAN hdr_mse is written as null. */
int esr_eval_write_json(const char *path, const struct esr_dataset *ds, const struct esr_eval_result *res);

#endif
