/* Per-view metrics of a rendered directory against a dataset phase, and their means. */
#include "eval/evaluate.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "eval/metrics.h"
#include "io/file.h"
#include "io/image.h"
#include "render/view.h"

static const float white[3] = {1.0f, 1.0f, 1.0f};

/* Reads a rendered image as 3-channel RGB on white (PNG: straight alpha; EXR: premultiplied)
 * and checks it has the dataset's size. */
static int load_rendered(const struct esr_dataset *ds, const char *path, struct esr_image *rgb)
{
    struct esr_image raw = {0};
    if (!esr_file_exists(path))
        return ESR_FAIL("rendered image '%s' is missing (run `esr render` for this phase first)", path);
    ESR_TRY(esr_image_read(path, &raw));
    int status = ESR_OK;
    if (raw.width != ds->width || raw.height != ds->height)
        status = ESR_FAIL("rendered image '%s' is %dx%d but the dataset's images are %dx%d", path, raw.width,
                          raw.height, ds->width, ds->height);
    else if (raw.channels == 3)
        *rgb = raw;
    else if (raw.channels != 4)
        status = ESR_FAIL("rendered image '%s' has %d channels; expected RGB or RGBA", path, raw.channels);
    else if (esr_image_is_exr(path))
        status = esr_image_composite_premultiplied(&raw, white, rgb);
    else
        status = esr_image_composite(&raw, white, rgb);
    if (rgb->data != raw.data) /* raw was converted (or refused), not handed over */
        esr_image_free(&raw);
    return status;
}

/* PSNR (capped) and SSIM of the rendered image at path against gt. */
static int compare_ldr(const struct esr_dataset *ds, const char *path, const struct esr_image *gt, double *psnr,
                       double *ssim)
{
    struct esr_image img = {0};
    double mse = 0.0;
    ESR_TRY(load_rendered(ds, path, &img));
    int status = esr_metric_mse(&img, gt, &mse);
    if (status == ESR_OK)
        status = esr_metric_ssim(&img, gt, ssim);
    *psnr = fmin(esr_psnr_from_mse(mse), ESR_EVAL_PSNR_CAP);
    esr_image_free(&img);
    return status;
}

/* HDR MSE of the rendered EXR against the frame's ground-truth EXR; NAN when there is none. */
static int compare_hdr(const struct esr_dataset *ds, const struct esr_frame *f, const char *path, double *hdr_mse)
{
    char gt_path[ESR_PATH_MAX];
    esr_frame_exr_path(ds, f, gt_path, sizeof gt_path);
    *hdr_mse = NAN;
    if (!esr_file_exists(gt_path))
        return ESR_OK;
    struct esr_image pred = {0}, gt = {0};
    ESR_TRY(load_rendered(ds, path, &pred));
    int status = esr_exr_read(gt_path, &gt);
    if (status == ESR_OK)
        status = esr_metric_hdr_mse(&pred, &gt, hdr_mse);
    esr_image_free(&pred);
    esr_image_free(&gt);
    return status;
}

/* Angular error of the rendered N_normal.exr against the frame's ground-truth normal map, when
 * the dataset has one: the view's errors are appended to *all and summarised in v->normal. */
static int compare_normals(const struct esr_dataset *ds, const struct esr_frame *f, const char *dir,
                           struct esr_eval_view *v, struct esr_normal_errors *all)
{
    char gt_path[ESR_PATH_MAX], path[ESR_PATH_MAX];
    if (!esr_normal_gt_path(ds, f, gt_path, sizeof gt_path))
        return ESR_OK;
    ESR_TRY(esr_view_path(path, sizeof path, dir, f->name, "_normal.exr"));
    if (!esr_file_exists(path))
        return ESR_FAIL("rendered normal map '%s' is missing (render this phase again: `esr eval --rerender` or "
                        "`esr render`)",
                        path);
    struct esr_image pred = {0}, gt = {0};
    size_t first = all->n;
    long gt_before = all->n_gt;
    int status = esr_exr_read(path, &pred);
    if (status == ESR_OK)
        status = esr_exr_read(gt_path, &gt);
    if (status == ESR_OK && (pred.width != ds->width || pred.height != ds->height))
        status = ESR_FAIL("rendered normal map '%s' is %dx%d but the dataset's images are %dx%d", path, pred.width,
                          pred.height, ds->width, ds->height);
    if (status == ESR_OK && (gt.width != ds->width || gt.height != ds->height))
        status = ESR_FAIL("ground-truth normal map '%s' is %dx%d but the dataset's images are %dx%d", gt_path,
                          gt.width, gt.height, ds->width, ds->height);
    if (status == ESR_OK)
        status = esr_normal_errors_add(all, &pred, &gt);
    if (status == ESR_OK) {
        v->has_normal_gt = 1;
        v->normal = esr_normal_stats_of(all->deg + first, all->n - first, all->n_gt - gt_before);
    }
    esr_image_free(&pred);
    esr_image_free(&gt);
    return status;
}

/* Emitter mask N_emitter.png against the phase's ground-truth emission mask, when both exist:
 * added to the pooled accumulator and scored alone in v. */
static int compare_emitters(const struct esr_dataset *ds, const struct esr_frame *f, const char *dir,
                            struct esr_eval_view *v, struct esr_iou_accum *pooled)
{
    char path[ESR_PATH_MAX], gt_path[ESR_PATH_MAX];
    ESR_TRY(esr_view_path(path, sizeof path, dir, f->name, "_emitter.png"));
    esr_frame_emission_path(ds, f, gt_path, sizeof gt_path);
    if (!esr_file_exists(path) || !esr_file_exists(gt_path))
        return ESR_OK;
    struct esr_image pred = {0}, gt = {0};
    int status = esr_image_read(path, &pred);
    if (status == ESR_OK)
        status = esr_image_read(gt_path, &gt);
    struct esr_iou_accum one;
    esr_iou_init(&one);
    if (status == ESR_OK)
        status = esr_iou_add(&one, &pred, 0.5f, &gt, 0.5f);
    if (status == ESR_OK) {
        pooled->intersection += one.intersection;
        pooled->union_count += one.union_count;
        v->has_emitter = 1;
        v->emitter_iou = esr_iou_value(&one);
    }
    esr_image_free(&pred);
    esr_image_free(&gt);
    return status;
}

static int eval_view(const struct esr_dataset *ds, const struct esr_frame *f, const char *dir,
                     struct esr_eval_view *v, struct esr_normal_errors *normals,
                     struct esr_iou_accum *emitters)
{
    char path[ESR_PATH_MAX];
    struct esr_image gt = {0};
    snprintf(v->name, sizeof v->name, "%s", f->name);
    v->mode = esr_frame_mode(ds, f);
    ESR_TRY(esr_frame_load_rgb(ds, f, &gt, NULL));
    int status = esr_view_path(path, sizeof path, dir, f->name, ".png");
    if (status == ESR_OK)
        status = compare_ldr(ds, path, &gt, &v->psnr, &v->ssim);
    if (status == ESR_OK)
        status = esr_view_path(path, sizeof path, dir, f->name, "_linear.png");
    if (status == ESR_OK)
        status = compare_ldr(ds, path, &gt, &v->psnr_linear, &v->ssim_linear);
    if (status == ESR_OK)
        status = esr_view_path(path, sizeof path, dir, f->name, ".exr");
    if (status == ESR_OK)
        status = compare_hdr(ds, f, path, &v->hdr_mse);
    if (status == ESR_OK)
        status = compare_normals(ds, f, dir, v, normals);
    if (status == ESR_OK)
        status = compare_emitters(ds, f, dir, v, emitters);
    esr_image_free(&gt);
    return status;
}

int esr_eval_check_truth(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx,
                         int n)
{
    const struct esr_phase *ph = &ds->phases[phase];
    for (int i = 0; i < n; i++) {
        const struct esr_frame *f = &ph->frames[idx[i]];
        struct esr_image img = {0};
        ESR_TRY(esr_frame_load_rgb(ds, f, &img, NULL));
        esr_image_free(&img);
        char path[ESR_PATH_MAX];
        esr_frame_exr_path(ds, f, path, sizeof path);
        if (!esr_file_exists(path))
            continue;
        ESR_TRY(esr_exr_read(path, &img));
        const int w = img.width, h = img.height;
        esr_image_free(&img);
        if (w != ds->width || h != ds->height)
            return ESR_FAIL("%s is %dx%d, the dataset's images are %dx%d", path, w, h, ds->width,
                            ds->height);
    }
    return esr_materials_check_truth(ds, phase, idx, n);
}

/* Mean of the views whose mode is `mode` (every view when mode < 0). */
static struct esr_eval_mean mean_of(const struct esr_eval_result *res, int mode)
{
    struct esr_eval_mean m;
    memset(&m, 0, sizeof m);
    int n_hdr = 0;
    for (int i = 0; i < res->n_views; i++) {
        const struct esr_eval_view *v = &res->views[i];
        if (mode >= 0 && (int)v->mode != mode)
            continue;
        m.n++;
        m.psnr += v->psnr;
        m.ssim += v->ssim;
        m.psnr_linear += v->psnr_linear;
        m.ssim_linear += v->ssim_linear;
        if (!isnan(v->hdr_mse)) {
            m.hdr_mse += v->hdr_mse;
            n_hdr++;
        }
    }
    if (m.n > 0) {
        m.psnr /= m.n;
        m.ssim /= m.n;
        m.psnr_linear /= m.n;
        m.ssim_linear /= m.n;
    }
    m.hdr_mse = n_hdr ? m.hdr_mse / n_hdr : NAN;
    return m;
}

int esr_eval_phase(const struct esr_dataset *ds, enum esr_phase_id phase, const int *idx, int n,
                   const char *render_dir, struct esr_eval_result *res)
{
    memset(res, 0, sizeof *res);
    res->phase = phase;
    if ((int)phase < 0 || phase >= ESR_PHASE_COUNT || !ds->phases[phase].present)
        return ESR_FAIL("dataset '%s' has no phase %s", ds->root, esr_phase_name(phase));
    if (n <= 0)
        return ESR_FAIL("no frames selected to evaluate");
    if (snprintf(res->render_dir, sizeof res->render_dir, "%s", render_dir) >= (int)sizeof res->render_dir)
        return ESR_FAIL("render directory path '%s' is too long", render_dir);
    const struct esr_phase *ph = &ds->phases[phase];
    res->views = calloc((size_t)n, sizeof *res->views);
    if (!res->views)
        return ESR_FAIL("out of memory evaluating %d views", n);
    struct esr_normal_errors normals;
    memset(&normals, 0, sizeof normals);
    esr_iou_init(&res->emitter);
    int status = ESR_OK;
    for (int i = 0; i < n && status == ESR_OK; i++) {
        if (idx[i] < 0 || idx[i] >= ph->n_frames)
            status = ESR_FAIL("frame index %d out of range for phase %s", idx[i], esr_phase_name(phase));
        else
            status = eval_view(ds, &ph->frames[idx[i]], render_dir, &res->views[i], &normals,
                               &res->emitter);
        if (status == ESR_OK) {
            res->n_views = i + 1;
            res->n_normal_views += res->views[i].has_normal_gt;
            res->n_emitter_views += res->views[i].has_emitter;
        }
    }
    if (status == ESR_OK && res->n_normal_views > 0)
        res->normals = esr_normal_stats_of(normals.deg, normals.n, normals.n_gt);
    esr_normal_errors_free(&normals);
    if (status == ESR_OK)
        status = esr_emo_baseline_eval(ds, phase, idx, res->n_views, render_dir, &res->emo_baseline);
    if (status == ESR_OK)
        status = esr_emitter_radiance_eval(ds, phase, idx, res->n_views, render_dir, &res->radiance);
    if (status == ESR_OK)
        status = esr_light_split_eval(ds, phase, idx, res->n_views, render_dir, &res->split);
    if (status == ESR_OK)
        status = esr_materials_eval(ds, phase, idx, res->n_views, render_dir, &res->materials);
    if (status == ESR_OK)
        status = esr_emitter_strength_eval(ds, phase, idx, res->n_views, render_dir, &res->split,
                                           &res->radiance, &res->strength);
    ESR_TRY(status);
    res->all = mean_of(res, -1);
    for (int mode = 0; mode < ESR_LIGHT_MODE_COUNT; mode++)
        res->by_mode[mode] = mean_of(res, mode);
    return ESR_OK;
}

void esr_eval_result_free(struct esr_eval_result *res)
{
    free(res->views);
    esr_materials_result_free(&res->materials);
    memset(res, 0, sizeof *res);
}
