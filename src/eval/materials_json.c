/* The material scores as text: the "materials" object of RUN/eval/P.json and the terminal lines
 * (eval/materials.h). */
#include <cJSON.h>
#include <math.h>

#include "eval/materials.h"
#include "eval/normals.h"
#include "io/json_file.h"

static void add_split(cJSON *root, const char *key, const struct esr_material_split_stats *s)
{
    cJSON *o = cJSON_AddObjectToObject(root, key);
    if (!o)
        return;
    cJSON_AddNumberToObject(o, "pixels", (double)s->n);
    esr_json_add_number_or_null(o, "roughness_mae", s->roughness_mae);
    esr_json_add_number_or_null(o, "metallic_mae", s->metallic_mae);
    esr_json_add_number_or_null(o, "mean_metallic", s->mean_metallic);
}

static void add_scores(cJSON *o, const struct esr_material_stats *s)
{
    esr_json_add_number_or_null(o, "base_color_psnr", s->base_color_psnr);
    esr_json_add_number_or_null(o, "base_color_psnr_gain", s->base_color_psnr_gain);
    esr_json_add_number_or_null(o, "roughness_mae", s->roughness_mae);
    esr_json_add_number_or_null(o, "metallic_mae", s->metallic_mae);
    esr_json_add_number_or_null(o, "coverage", s->coverage);
}

void *esr_materials_json(const struct esr_materials_result *r)
{
    if (!r->has_truth)
        return NULL;
    cJSON *o = cJSON_CreateObject();
    if (!o)
        return NULL;
    if (r->skipped[0]) {
        cJSON_AddStringToObject(o, "skipped", r->skipped);
        return o;
    }
    const struct esr_material_stats *s = &r->pooled;
    cJSON_AddNumberToObject(o, "n_views", r->n_views);
    cJSON_AddNumberToObject(o, "n_gt_pixels", (double)s->n_gt);
    cJSON_AddNumberToObject(o, "n_pixels", (double)s->n);
    cJSON_AddNumberToObject(o, "min_opacity", ESR_NORMAL_MIN_OPACITY);
    add_scores(o, s);
    cJSON_AddItemToObject(o, "gain", cJSON_CreateDoubleArray(s->gain, 3));
    add_split(o, "metallic", &s->metal);
    add_split(o, "non_metallic", &s->dielectric);
    cJSON_AddNumberToObject(o, "metallic_at_least", ESR_MATERIAL_METAL_AT_LEAST);
    cJSON_AddNumberToObject(o, "non_metallic_at_most", ESR_MATERIAL_DIELECTRIC_AT_MOST);
    cJSON_AddStringToObject(o, "ground_truth", "gt/c<CCC>_{base_color,roughness,metallic,normal}.exr");
    cJSON *views = cJSON_AddArrayToObject(o, "per_view");
    for (int k = 0; views && k < r->n_views; k++) {
        cJSON *v = cJSON_CreateObject();
        if (!v)
            break;
        cJSON_AddStringToObject(v, "name", r->views[k].name);
        add_scores(v, &r->views[k].stats);
        cJSON_AddItemToArray(views, v);
    }
    return o;
}

/* v in fmt, or "-" for a missing mean. */
static void put(FILE *out, const char *fmt, double v)
{
    if (isnan(v))
        fputs("-", out);
    else
        fprintf(out, fmt, v);
}

static void print_split(FILE *out, const char *what, const char *bound, const struct esr_material_split_stats *s)
{
    fprintf(out, "  %s pixels (truth metallic %s): %ld; roughness MAE ", what, bound, s->n);
    put(out, "%.3f", s->roughness_mae);
    fputs(", metallic MAE ", out);
    put(out, "%.3f", s->metallic_mae);
    fputs(", mean predicted metallic ", out);
    put(out, "%.3f", s->mean_metallic);
    fputc('\n', out);
}

void esr_materials_print(FILE *out, FILE *err, const struct esr_materials_result *r)
{
    if (!r->has_truth)
        return;
    if (r->skipped[0]) {
        fprintf(err, "note: material maps not scored: %s\n", r->skipped);
        return;
    }
    const struct esr_material_stats *s = &r->pooled;
    fprintf(out, "materials vs gt (%d views, pixels pooled; %ld of %ld surface pixels at opacity > %.1f): base "
                 "colour ",
            r->n_views, s->n, s->n_gt, (double)ESR_NORMAL_MIN_OPACITY);
    put(out, "%.2f dB", s->base_color_psnr);
    fputs(", ", out);
    put(out, "%.2f dB", s->base_color_psnr_gain);
    fprintf(out, " with gains %.3f %.3f %.3f; roughness MAE ", s->gain[0], s->gain[1], s->gain[2]);
    put(out, "%.3f", s->roughness_mae);
    fputs(", metallic MAE ", out);
    put(out, "%.3f", s->metallic_mae);
    fputc('\n', out);
    char at_least[32], at_most[32];
    snprintf(at_least, sizeof at_least, ">= %.1f", ESR_MATERIAL_METAL_AT_LEAST);
    snprintf(at_most, sizeof at_most, "<= %.1f", ESR_MATERIAL_DIELECTRIC_AT_MOST);
    print_split(out, "metallic", at_least, &s->metal);
    print_split(out, "non-metallic", at_most, &s->dielectric);
}
