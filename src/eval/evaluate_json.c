/* JSON form of an evaluation result (RUN/eval/<phase>.json). */
#include <cJSON.h>
#include <stdlib.h>
#include <string.h>

#include "core/error.h"
#include "eval/evaluate.h"
#include "io/json_file.h"

static void add_metrics(cJSON *obj, double psnr, double ssim, double psnr_linear, double ssim_linear,
                        double hdr_mse)
{
    esr_json_add_number_or_null(obj, "psnr", psnr);
    esr_json_add_number_or_null(obj, "ssim", ssim);
    esr_json_add_number_or_null(obj, "psnr_linear", psnr_linear);
    esr_json_add_number_or_null(obj, "ssim_linear", ssim_linear);
    esr_json_add_number_or_null(obj, "hdr_mse", hdr_mse);
}

static cJSON *mean_json(const struct esr_eval_mean *m)
{
    cJSON *obj = cJSON_CreateObject();
    if (obj) {
        cJSON_AddNumberToObject(obj, "n", m->n);
        add_metrics(obj, m->psnr, m->ssim, m->psnr_linear, m->ssim_linear, m->hdr_mse);
    }
    return obj;
}

/* The pooled normal errors; NULL on out of memory. */
static cJSON *normals_json(const struct esr_eval_result *res)
{
    const struct esr_normal_stats *s = &res->normals;
    cJSON *obj = cJSON_CreateObject();
    if (!obj)
        return NULL;
    cJSON_AddNumberToObject(obj, "n_views", res->n_normal_views);
    cJSON_AddNumberToObject(obj, "n_gt_pixels", (double)s->n_gt);
    cJSON_AddNumberToObject(obj, "n_pixels", (double)s->n);
    esr_json_add_number_or_null(obj, "mean_deg", s->mean_deg);
    esr_json_add_number_or_null(obj, "median_deg", s->median_deg);
    esr_json_add_number_or_null(obj, "frac_good", s->frac_good);
    cJSON_AddNumberToObject(obj, "good_deg", ESR_NORMAL_GOOD_DEG);
    esr_json_add_number_or_null(obj, "coverage", s->coverage);
    cJSON_AddNumberToObject(obj, "min_opacity", ESR_NORMAL_MIN_OPACITY);
    cJSON_AddStringToObject(obj, "ground_truth", "gt/c<CCC>_normal.exr");
    return obj;
}

static cJSON *result_json(const struct esr_dataset *ds, const struct esr_eval_result *res)
{
    cJSON *root = cJSON_CreateObject();
    cJSON *views = cJSON_CreateArray(), *by_mode = cJSON_CreateObject();
    if (!root || !views || !by_mode) {
        cJSON_Delete(root);
        cJSON_Delete(views);
        cJSON_Delete(by_mode);
        return NULL;
    }
    cJSON_AddStringToObject(root, "phase", esr_phase_name(res->phase));
    cJSON_AddStringToObject(root, "dataset", ds->root);
    cJSON_AddStringToObject(root, "render_dir", res->render_dir);
    cJSON_AddNumberToObject(root, "psnr_cap", ESR_EVAL_PSNR_CAP);
    cJSON_AddNumberToObject(root, "n_views", res->n_views);
    cJSON_AddItemToObject(root, "views", views);
    for (int i = 0; i < res->n_views; i++) {
        const struct esr_eval_view *v = &res->views[i];
        cJSON *o = cJSON_CreateObject();
        if (!o)
            break;
        cJSON_AddStringToObject(o, "name", v->name);
        cJSON_AddStringToObject(o, "mode", esr_light_mode_name(v->mode));
        add_metrics(o, v->psnr, v->ssim, v->psnr_linear, v->ssim_linear, v->hdr_mse);
        if (v->has_normal_gt) {
            esr_json_add_number_or_null(o, "normal_deg", v->normal.mean_deg);
            esr_json_add_number_or_null(o, "normal_median_deg", v->normal.median_deg);
            esr_json_add_number_or_null(o, "normal_frac_good", v->normal.frac_good);
            esr_json_add_number_or_null(o, "normal_coverage", v->normal.coverage);
        }
        if (v->has_emitter)
            cJSON_AddNumberToObject(o, "emitter_iou", v->emitter_iou);
        cJSON_AddItemToArray(views, o);
    }
    cJSON_AddItemToObject(root, "mean", mean_json(&res->all));
    cJSON_AddItemToObject(root, "by_mode", by_mode);
    for (int mode = 0; mode < ESR_LIGHT_MODE_COUNT; mode++)
        if (res->by_mode[mode].n > 0)
            cJSON_AddItemToObject(by_mode, esr_light_mode_name((enum esr_light_mode)mode),
                                  mean_json(&res->by_mode[mode]));
    if (res->n_normal_views > 0)
        cJSON_AddItemToObject(root, "normals", normals_json(res));
    if (res->n_emitter_views > 0) {
        cJSON_AddNumberToObject(root, "emitter_iou", esr_iou_value(&res->emitter));
        cJSON_AddNumberToObject(root, "emitter_views", res->n_emitter_views);
    }
    if (res->emo_baseline.n_cameras > 0) {
        cJSON *b = cJSON_AddObjectToObject(root, "emitter_iou_emo_threshold");
        cJSON_AddNumberToObject(b, "iou", res->emo_baseline.iou);
        cJSON_AddNumberToObject(b, "k", res->emo_baseline.k);
        cJSON_AddNumberToObject(b, "cameras", res->emo_baseline.n_cameras);
    }
    if (res->radiance.n > 0) {
        cJSON *arr = cJSON_AddArrayToObject(root, "emitter_radiance");
        for (int k = 0; k < res->radiance.n; k++) {
            const struct esr_emitter_radiance *r = &res->radiance.lights[k];
            cJSON *o = cJSON_CreateObject();
            cJSON_AddNumberToObject(o, "light", r->light);
            cJSON_AddStringToObject(o, "name", r->name);
            cJSON_AddNumberToObject(o, "pixels", (double)r->pixels);
            cJSON_AddItemToObject(o, "mean_rgb", cJSON_CreateDoubleArray(r->mean, 3));
            cJSON_AddItemToObject(o, "truth_rgb", cJSON_CreateDoubleArray(r->truth, 3));
            esr_json_add_number_or_null(o, "error_pct", r->error_pct);
            esr_json_add_number_or_null(o, "ratio", r->ratio);
            esr_emitter_strength_add_light_json(o, r);
            cJSON_AddItemToArray(arr, o);
        }
        esr_emitter_strength_add_json(root, &res->strength);
    }
    if (res->split.views > 0) {
        cJSON *sp = cJSON_AddObjectToObject(root, "light_split");
        cJSON_AddNumberToObject(sp, "views", res->split.views);
        cJSON_AddNumberToObject(sp, "mean_iou", res->split.mean_iou);
        cJSON *arr = cJSON_AddArrayToObject(sp, "lights");
        for (int k = 0; k < res->split.n; k++) {
            const struct esr_light_split_row *r = &res->split.rows[k];
            cJSON *o = cJSON_CreateObject();
            cJSON_AddNumberToObject(o, "light", r->light);
            cJSON_AddStringToObject(o, "name", r->name);
            cJSON_AddNumberToObject(o, "esr_light", r->esr_light);
            cJSON_AddNumberToObject(o, "iou", r->iou);
            cJSON_AddNumberToObject(o, "true_pixels", (double)r->true_pixels);
            cJSON_AddItemToArray(arr, o);
        }
    }
    cJSON *materials = esr_materials_json(&res->materials);
    if (materials)
        cJSON_AddItemToObject(root, "materials", materials);
    const enum esr_light_mode modes[2] = {ESR_LIGHT_OFF, ESR_LIGHT_ON};
    const char *keys[2] = {"hdr_mse_off", "hdr_mse_on"};
    for (int i = 0; i < 2; i++)
        if (res->by_mode[modes[i]].n > 0)
            esr_json_add_number_or_null(root, keys[i], res->by_mode[modes[i]].hdr_mse);
    return root;
}

int esr_eval_write_json(const char *path, const struct esr_dataset *ds, const struct esr_eval_result *res)
{
    return esr_json_write_atomic(path, result_json(ds, res));
}
