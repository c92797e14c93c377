/* Evaluation of rendered test views against a dataset phase (METHOD.md, "Emitter identification
 * and metrics"): PSNR / SSIM of the tone-mapped and of the gamma-corrected linear output against
 * the ground-truth PNG (composited on white), and HDR MSE of the linear EXR against the
 * ground-truth EXR (composited on white), per view, overall and per lighting mode; and, on
 * datasets with ground-truth normal maps (eval/normals.h), the angular error of the rendered
 * surface normals, and with ground-truth material maps (eval/materials.h), the rendered base
 * colour, roughness and metallic against them.
 *
 * The rendered directory holds, per frame name N, the files of render/view.h (esr_view_write):
 * N.png (tone-mapped RGB on white), N_linear.png (sRGB OETF of the linear RGB on white, clipped
 * to [0,1]), N.exr (linear RGB on white) and N_normal.exr (composited normal, opacity). */
#ifndef ESR_EVAL_EVALUATE_H
#define ESR_EVAL_EVALUATE_H

#include "eval/emitter_radiance.h"
#include "eval/emitter_strength.h"
#include "eval/emo_baseline.h"
#include "eval/light_split.h"
#include "eval/materials.h"
#include "eval/metrics.h"
#include "eval/normals.h"
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
    int has_normal_gt;         /* 1 when the frame has a ground-truth normal map */
    struct esr_normal_stats normal; /* angular error of N_normal.exr vs it (when has_normal_gt) */
    int has_emitter;           /* 1 when N_emitter.png and the phase's emission mask both exist */
    double emitter_iou;        /* IoU of this view alone (when has_emitter) */
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
    int n_normal_views;                        /* views with a ground-truth normal map */
    struct esr_normal_stats normals;           /* pixels of those views pooled (n_normal_views > 0) */
    int n_emitter_views;                       /* views with a predicted and a true emitter mask */
    struct esr_iou_accum emitter;              /* their pixels pooled (METHOD.md: one division) */
    struct esr_emo_baseline emo_baseline;      /* thresholded L_emo (n_cameras 0: not computed) */
    struct esr_emitter_radiance_result radiance; /* per light vs scene.json (n 0: not scored) */
    struct esr_light_split split;              /* esr's lights vs per-light masks (views 0: none) */
    struct esr_materials_result materials;     /* material maps vs truth (has_truth 0: none) */
    struct esr_emitter_strength strength;      /* the lights' strengths summarised (with radiance) */
};

/* Evaluates the frames idx[0..n) of `phase` (esr_select_frames) against the images in
 * render_dir; N_normal.exr is read only for frames with a ground-truth normal map. Fails with a
 * message naming the file on a missing or unreadable rendered image or a size that differs from
 * the dataset's. *res is zeroed first; free it with
 * esr_eval_result_free (also after an error). */
int esr_eval_phase(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx, int n,
                   const char *render_dir, struct esr_eval_result *res);
void esr_eval_result_free(struct esr_eval_result *res);

/* Reads the ground truth esr_eval_phase compares with (each frame's image and, when the dataset
 * has it, its linear EXR and material maps) and fails naming the first file that is missing,
 * unreadable or of another size: called before rendering, so a broken dataset stops an evaluation before it
 * spends minutes on renders it cannot score. */
int esr_eval_check_truth(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx,
                         int n);

/* Writes the result as JSON (atomically):
 *   {"phase": "test_nv", "dataset": ds->root, "render_dir": ..., "psnr_cap": 100, "n_views": V,
 *    "views": [{"name", "mode", "psnr", "ssim", "psnr_linear", "ssim_linear", "hdr_mse",
 *               "normal_deg", "normal_median_deg", "normal_frac_good", "normal_coverage"}...],
 *    "mean": {"n", "psnr", "ssim", "psnr_linear", "ssim_linear", "hdr_mse"},
 *    "by_mode": {"off": {...mean...}, "on": {...}},   (only modes that have views)
 *    "normals": {"n_views", "n_gt_pixels", "n_pixels", "mean_deg", "median_deg", "frac_good",
 *                "good_deg": 10, "coverage", "min_opacity": 0.5, "ground_truth"},
 *    "emitter_iou": pooled IoU of N_emitter.png vs <phase>/emission/<name>.png,
 *    "emitter_views": views counted,
 *    "emitter_iou_emo_threshold": {"iou", "k", "cameras"}: the thresholded-L_emo baseline,
 *    "emitter_radiance": [{"light", "name", "pixels", "mean_rgb", "truth_rgb", "error_pct",
 *                          "ratio", "eroded", "mask_pixels", "luminance_ratio", "power",
 *                          "truth_power", "power_ratio"}...] (eval/emitter_radiance.h; when scored),
 *    "emitter_strength": {"shared_scale", "worst_relative", ...} (eval/emitter_strength.h; with
 *                        emitter_radiance),
 *    "hdr_mse_off", "hdr_mse_on": by_mode's hdr_mse of those modes (when they have views),
 *    "light_split": {"views", "mean_iou", "lights": [{"light", "name", "esr_light", "iou",
 *                    "true_pixels"}...]} (eval/light_split.h; when scored),
 *    "materials": {...} (eval/materials.h; when the dataset has material truth maps)}
 * (a view carries "emitter_iou" too; both only when some view has the two masks; the baseline
 * when some camera has both lightings rendered and a ground-truth mask)
 * The normal_* keys of a view and "normals" are present only when there is a ground-truth normal
 * map (of that view / of any view); pixels are pooled over the views in "normals". A NAN value is
 * written as null. */
int esr_eval_write_json(const char *path, const struct esr_dataset *ds, const struct esr_eval_result *res);

#endif
