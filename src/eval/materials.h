/* Rendered material maps (base colour, roughness, metallic) scored against the ground-truth maps
 * of datasets written by `esr synth` (issue 49, "Scores").
 *
 * Ground truth, per test camera CCC (scene.json "ground_truth"): DATA/gt/c<CCC>_base_color.exr
 * (linear RGB), c<CCC>_roughness.exr and c<CCC>_metallic.exr (Y), one ray per pixel centre, 0 on
 * background; the surface is told from the background by c<CCC>_normal.exr, as the normal score
 * does (eval/normals.h: a nonzero normal).
 * Prediction: the rendered N_basecolor.png (sRGB OETF of the linear value), N_roughness.png and
 * N_metallic.png (grey), each composited on white by the opacity (render/view.h), and that
 * opacity from N_normal.exr's alpha.
 *
 * A pixel is scored where the truth has a surface and the render is opaque (opacity >
 * ESR_NORMAL_MIN_OPACITY), as the normals are; there the rendered value is taken off the white
 * background again, x = (v - (1 - a)) / a, so that a surface's edge scores its material, not
 * the white. Over the scored pixels of all views pooled:
 *   base_color_psnr       PSNR (peak 1) of the sRGB-encoded maps, the truth's encoded from
 *                         its linear value clipped to [0,1], over the three channels;
 *   base_color_psnr_gain  the same after one gain per channel applied to the prediction in
 *                         linear, g_c = sum(t_c r_c) / sum(r_c^2) (least squares of g r = t
 *                         over the pooled pixels, t and r linear): the overall scale of the
 *                         albedo, which photos under unknown light cannot fix; a channel the
 *                         prediction leaves black keeps gain 1 (no gain changes it);
 *   roughness_mae, metallic_mae  mean absolute errors;
 * and the two errors and the mean predicted metallic again over the truly metallic pixels
 * (truth metallic >= ESR_MATERIAL_METAL_AT_LEAST) and the non-metallic ones (<=
 * ESR_MATERIAL_DIELECTRIC_AT_MOST). A mean over no pixel is NAN (null in JSON). */
#ifndef ESR_EVAL_MATERIALS_H
#define ESR_EVAL_MATERIALS_H

#include <stdio.h>

#include "io/dataset.h"
#include "io/image.h"

#define ESR_MATERIAL_METAL_AT_LEAST 0.9
#define ESR_MATERIAL_DIELECTRIC_AT_MOST 0.1
/* PSNR of identical maps is infinite; capped as the image PSNRs are (ESR_EVAL_PSNR_CAP). */
#define ESR_MATERIAL_PSNR_CAP 100.0

/* Sums over one of the two pixel sets split by the truth's metallic. */
struct esr_material_split_sums {
    long n;
    double ae_rough, ae_metal, pred_metal;
};

/* Sums over a set of pixels (grown view by view; zero-initialise). */
struct esr_material_sums {
    long n_gt, n;              /* truth surface pixels, scored pixels */
    double se_base;            /* squared error of the sRGB base colour, 3 channels */
    double se_base_gain;       /* the same with the gains applied (esr_material_add_gained) */
    double sum_tr[3], sum_rr[3]; /* sum t r and sum r r per channel, linear */
    double ae_rough, ae_metal;
    struct esr_material_split_sums metal, dielectric;
};

/* One view's maps. pred: base RGB (first 3 channels, sRGB, on white), roughness and metallic
 * (first channel, on white) and opacity (its last channel: N_normal.exr's alpha, or a grey
 * image). truth: base RGB (first 3 channels, linear), roughness, metallic (first channel) and
 * normal (first 3 channels; zero on background). All of one size. */
struct esr_material_maps {
    const struct esr_image *base, *roughness, *metallic, *opacity_or_normal;
};

/* Adds the view's scored pixels to s (everything but se_base_gain). Fails when the sizes differ
 * or a colour map has fewer than 3 channels. */
int esr_material_add(struct esr_material_sums *s, const struct esr_material_maps *pred,
                     const struct esr_material_maps *truth);
/* Adds the view's squared base-colour error with gain[c] applied to the prediction in linear to
 * s->se_base_gain: the second pass, once the gains of all views are known. */
int esr_material_add_gained(struct esr_material_sums *s, const struct esr_material_maps *pred,
                            const struct esr_material_maps *truth, const double gain[3]);
/* Adds b's sums to a. */
void esr_material_sums_merge(struct esr_material_sums *a, const struct esr_material_sums *b);
/* The least-squares gains of s: sum_tr / sum_rr per channel, 1 where sum_rr is 0. */
void esr_material_gains(const struct esr_material_sums *s, double gain[3]);

struct esr_material_split_stats {
    long n;
    double roughness_mae, metallic_mae, mean_metallic; /* NAN when n = 0 */
};

struct esr_material_stats {
    long n_gt, n;
    double coverage;                 /* n / n_gt; NAN when n_gt = 0 */
    double base_color_psnr, base_color_psnr_gain; /* capped; NAN when n = 0 */
    double gain[3];
    double roughness_mae, metallic_mae;
    struct esr_material_split_stats metal, dielectric;
};

/* Statistics of s (its se_base_gain as added with the gains of `gain`, which are copied). */
struct esr_material_stats esr_material_stats_of(const struct esr_material_sums *s, const double gain[3]);

/* One scored camera (its first evaluated frame's name). */
struct esr_material_view {
    char name[ESR_NAME_MAX];
    struct esr_material_stats stats; /* its own pixels; the gains are the pooled ones */
};

struct esr_materials_result {
    int has_truth;        /* some evaluated frame's camera has gt/c<CCC>_base_color.exr */
    char skipped[512];    /* why it was not scored although it has truth ("" when scored) */
    int n_views;          /* cameras scored */
    struct esr_material_view *views;
    struct esr_material_stats pooled;
};

/* Path of the truth map `map` ("normal", "base_color", "roughness", "metallic") of the frame
 * named `name` in the dataset at root: "<root>/gt/c<CCC>_<map>.exr" when the name has the form
 * c<CCC>_... (CCC digits); returns 1 and fills out when it does and the file exists, else 0
 * (out is filled whenever the name has that form, for messages). */
int esr_material_gt_path(const char *root, const char *name, const char *map, char *out, size_t n);

/* Scores the frames idx[0..n) of `phase` with their renders in render_dir, each camera once (its
 * lights-off and lights-on frames render the same materials). Not scored, with the reason in
 * out->skipped, when a camera lacks one of the truth maps or the renders have no material maps
 * (a model before the lts stage). Fails naming the file on a map of another size than the
 * dataset's, an unreadable one, or a render directory with some material maps but not all.
 * *out is zeroed first; free it with esr_materials_result_free (also after an error). */
int esr_materials_eval(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx, int n,
                       const char *render_dir, struct esr_materials_result *out);
void esr_materials_result_free(struct esr_materials_result *r);

/* Reads the truth maps esr_materials_eval would read for the frames idx[0..n) and fails naming
 * the first that is unreadable or of another size than the dataset's (a missing one is not an
 * error: the scores are skipped then): for esr_eval_check_truth, before any rendering. */
int esr_materials_check_truth(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx, int n);

/* The result as the "materials" object of RUN/eval/P.json (cJSON *, returned as void * so that
 * this header does not need cJSON): {"n_views", "n_gt_pixels", "n_pixels", "coverage",
 * "min_opacity", "base_color_psnr", "base_color_psnr_gain", "gain": [r, g, b], "roughness_mae",
 * "metallic_mae", "metallic": {"pixels", "roughness_mae", "metallic_mae", "mean_metallic"},
 * "non_metallic": {...}, "metallic_at_least": 0.9, "non_metallic_at_most": 0.1, "ground_truth",
 * "per_view": [{"name", "base_color_psnr", "base_color_psnr_gain", "roughness_mae",
 * "metallic_mae", "coverage"}...]}, or {"skipped": reason}; NAN as null. NULL when there is no
 * truth (the key is then left out) or on out of memory. */
void *esr_materials_json(const struct esr_materials_result *r);

/* The scores as lines on out (a note on err when skipped; nothing without truth). */
void esr_materials_print(FILE *out, FILE *err, const struct esr_materials_result *r);

/* The truth maps of the scored cameras as gt_dir/<name>_basecolor_true.png (sRGB),
 * _roughness_true.png and _metallic_true.png (grey), white where the truth has no surface: what
 * the report shows beside the rendered maps. */
int esr_materials_write_truth(const struct esr_dataset *ds, const struct esr_materials_result *r,
                              const char *gt_dir);

/* The report's "Materials" section (nothing without truth): the scores, and per camera the
 * rendered maps (render_href/<name>_basecolor.png ...) beside the truth (gt_href/<name>_*_true.png). */
void esr_materials_put_html(FILE *out, const struct esr_materials_result *r, const char *render_href,
                            const char *gt_href);

#endif
