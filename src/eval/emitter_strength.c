/* How strongly each light emits, summarised (see emitter_strength.h). */
#include "eval/emitter_strength.h"

#include <cJSON.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "core/error.h"
#include "eval/html.h"
#include "io/file.h"
#include "io/json_file.h"
#include "render/view.h"

/* ITU-R BT.709 luminance, in double (core/colour.h's is float). */
static double luminance(const double rgb[3]) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

double esr_emitter_luminance_ratio(const double found[3], const double truth[3])
{
    const double yt = luminance(truth), yf = luminance(found);
    return yt > 0.0 && isfinite(yf) ? yf / yt : NAN;
}

void esr_emitter_strength_summarise(const double *ratio, const int *light, int n,
                                    struct esr_emitter_strength *out)
{
    out->scored = out->dark = 0;
    out->shared_scale = out->worst_relative = NAN;
    out->worst_light = -1;
    double log_sum = 0.0;
    int positive = 0;
    for (int i = 0; i < n; i++) {
        if (isnan(ratio[i]))
            continue;
        out->scored++;
        if (ratio[i] > 0.0) {
            log_sum += log(ratio[i]);
            positive++;
        } else {
            out->dark++;
        }
    }
    if (positive == 0)
        return;
    /* the geometric mean: a light at x2 and one at x0.5 share the scale 1, each off by as much */
    out->shared_scale = exp(log_sum / positive);
    for (int i = 0; i < n; i++) {
        if (isnan(ratio[i]))
            continue;
        const double rel = fabs(fmax(ratio[i], 0.0) / out->shared_scale - 1.0);
        if (out->worst_light < 0 || rel > out->worst_relative) {
            out->worst_relative = rel;
            out->worst_light = light ? light[i] : i;
        }
    }
}

/* The light id of pixel p of an N_lights.png image (render/view.h: code value id + 1), or -1. */
static int light_id_at(const struct esr_image *ids, size_t p)
{
    return (int)lroundf(ids->data[p * (size_t)ids->channels] * 255.0f) - 1;
}

/* What every view's power is measured with. */
struct power_setup {
    const struct esr_dataset *ds;                  /* the true lights' masks */
    const char *render_dir;                        /* the views' N_emission.exr, N_lights.png */
    const struct esr_light_split *split;           /* which true light each esr light follows */
    const struct esr_emitter_radiance_result *rad; /* the true lights scored, in order */
};

/* One view's power per light into found[] / truth[] and the esr light ids it shows into *seen;
 * *ids_used counts the views whose light ids were read. */
static int add_view(const struct power_setup *ps, const struct esr_frame *f, double *found,
                    double *truth, uint32_t *seen, int *ids_used)
{
    const struct esr_dataset *ds = ps->ds;
    const char *render_dir = ps->render_dir;
    const struct esr_light_split *split = ps->split;
    const struct esr_emitter_radiance_result *rad = ps->rad;
    char path[ESR_PATH_MAX * 2];
    if (esr_view_path(path, sizeof path, render_dir, f->name, "_emission.exr") != ESR_OK ||
        !esr_file_exists(path))
        return ESR_OK; /* as eval/emitter_radiance.c: no emission, not scored */
    struct esr_image em = {0}, ids = {0};
    ESR_TRY(esr_exr_read(path, &em));
    int rc = ESR_OK, have_ids = 0;
    if (esr_view_path(path, sizeof path, render_dir, f->name, "_lights.png") == ESR_OK &&
        esr_file_exists(path)) {
        rc = esr_png_read(path, &ids);
        have_ids = rc == ESR_OK;
        if (rc == ESR_OK && (ids.width != em.width || ids.height != em.height))
            rc = ESR_FAIL("%s: %dx%d, but the rendered emission is %dx%d", path, ids.width,
                          ids.height, em.width, em.height);
    }
    const size_t np = (size_t)em.width * (size_t)em.height;
    for (size_t p = 0; rc == ESR_OK && have_ids && p < np; p++) {
        const int id = light_id_at(&ids, p);
        if (id >= 0 && id < ESR_MAX_LIGHTS)
            *seen |= 1u << id;
    }
    for (int i = 0; rc == ESR_OK && i < rad->n; i++) {
        const struct esr_emitter_radiance *r = &rad->lights[i];
        esr_frame_light_mask_path(ds, f, r->light, path, sizeof path);
        struct esr_image mask = {0};
        const int has_mask = path[0] && esr_file_exists(path);
        if (has_mask)
            rc = esr_png_read(path, &mask);
        if (rc == ESR_OK && has_mask && (mask.width != em.width || mask.height != em.height))
            rc = ESR_FAIL("%s: %dx%d, but the rendered emission is %dx%d", path, mask.width,
                          mask.height, em.width, em.height);
        for (size_t p = 0; rc == ESR_OK && p < np; p++) {
            const int in_mask = has_mask && mask.data[p * (size_t)mask.channels] > 0.5f;
            int mine = in_mask;
            if (have_ids) {
                const int id = light_id_at(&ids, p);
                mine = id >= 0 && id < ESR_MAX_LIGHTS && split->dataset_light[id] == r->light;
            }
            const float *e = em.data + p * (size_t)em.channels;
            const double rgb[3] = {e[0], e[1], e[2]};
            found[i] += mine ? luminance(rgb) : 0.0;
            truth[i] += in_mask ? luminance(r->truth) : 0.0;
        }
        esr_image_free(&mask);
    }
    *ids_used += have_ids && rc == ESR_OK;
    esr_image_free(&em);
    esr_image_free(&ids);
    return rc;
}

int esr_emitter_strength_eval(const struct esr_dataset *ds, enum esr_phase_id phase,
                              const int *idx, int n, const char *render_dir,
                              const struct esr_light_split *split,
                              struct esr_emitter_radiance_result *rad,
                              struct esr_emitter_strength *out)
{
    memset(out, 0, sizeof *out);
    out->lights_true = ds->n_lights;
    out->lights_found = out->lights_wrong = -1;
    out->shared_scale = out->worst_relative = NAN;
    out->worst_light = -1;
    double found[ESR_MAX_TRUE_LIGHTS] = {0}, truth[ESR_MAX_TRUE_LIGHTS] = {0};
    uint32_t seen = 0;
    const struct esr_phase *ph = &ds->phases[phase];
    const struct power_setup ps = {ds, render_dir, split, rad};
    for (int i = 0; i < n; i++)
        ESR_TRY(add_view(&ps, &ph->frames[idx[i]], found, truth, &seen, &out->power_views));
    if (out->power_views > 0) {
        out->lights_found = out->lights_wrong = 0;
        out->found_from = "renders";
        for (int j = 0; j < ESR_MAX_LIGHTS; j++) {
            out->lights_found += (seen >> j) & 1u;
            out->lights_wrong += ((seen >> j) & 1u) && split->dataset_light[j] < 0;
        }
        if (split->views == 0) /* no masks: which true light an esr light is, unknown */
            out->lights_wrong = -1;
    }
    double ratio[ESR_MAX_TRUE_LIGHTS];
    int light[ESR_MAX_TRUE_LIGHTS];
    for (int i = 0; i < rad->n; i++) {
        struct esr_emitter_radiance *r = &rad->lights[i];
        const int scored = truth[i] > 0.0;
        r->power = scored ? found[i] : NAN;
        r->truth_power = scored ? truth[i] : NAN;
        r->power_ratio = scored ? found[i] / truth[i] : NAN;
        ratio[i] = r->lum_ratio;
        light[i] = r->light;
    }
    esr_emitter_strength_summarise(ratio, light, rad->n, out);
    return ESR_OK;
}

static void add_count(cJSON *obj, const char *name, int v)
{
    if (v < 0)
        cJSON_AddNullToObject(obj, name);
    else
        cJSON_AddNumberToObject(obj, name, v);
}

void esr_emitter_strength_add_json(cJSON *root, const struct esr_emitter_strength *s)
{
    cJSON *o = cJSON_AddObjectToObject(root, "emitter_strength");
    if (!o)
        return;
    esr_json_add_number_or_null(o, "shared_scale", s->shared_scale);
    esr_json_add_number_or_null(o, "worst_relative", s->worst_relative);
    add_count(o, "worst_light", s->worst_light);
    add_count(o, "lights_found", s->lights_found);
    if (s->found_from)
        cJSON_AddStringToObject(o, "lights_found_from", s->found_from);
    else
        cJSON_AddNullToObject(o, "lights_found_from");
    add_count(o, "lights_wrong", s->lights_wrong);
    add_count(o, "lights_true", s->lights_true);
    cJSON_AddNumberToObject(o, "lights_scored", s->scored);
    cJSON_AddNumberToObject(o, "lights_dark", s->dark);
    cJSON_AddStringToObject(o, "power",
                            "luminance of the rendered emission summed over the light's pixels and the views "
                            "(image-space power: projected area in pixels x radiance); found over the pixels "
                            "of the esr lights that follow the light (N_lights.png), else its true mask; "
                            "truth over its true mask");
}

void esr_emitter_strength_add_light_json(cJSON *obj, const struct esr_emitter_radiance *r)
{
    cJSON_AddBoolToObject(obj, "eroded", r->eroded);
    cJSON_AddNumberToObject(obj, "mask_pixels", (double)r->mask_pixels);
    esr_json_add_number_or_null(obj, "luminance_ratio", r->lum_ratio);
    esr_json_add_number_or_null(obj, "power", r->power);
    esr_json_add_number_or_null(obj, "truth_power", r->truth_power);
    esr_json_add_number_or_null(obj, "power_ratio", r->power_ratio);
}

/* "found N of T" with what is known. */
static void put_counts(FILE *out, const struct esr_emitter_strength *s, const char *sep)
{
    if (s->lights_found >= 0)
        fprintf(out, "%d lights found (%s) for %d true", s->lights_found, s->found_from, s->lights_true);
    else
        fprintf(out, "lights found unknown (no light ids rendered), %d true", s->lights_true);
    if (s->lights_wrong > 0)
        fprintf(out, "%s%d rendered light(s) follow no true light (a reflection or a fleck counted as a light)",
                sep, s->lights_wrong);
}

void esr_emitter_strength_put_html(FILE *out, const struct esr_emitter_radiance_result *rad,
                                   const struct esr_emitter_strength *s)
{
    if (rad->n == 0)
        return;
    fputs("<table><tr><th>light</th><th>pixels scored</th><th>luminance found / true</th>"
          "<th>over the shared scale</th><th>power found / true</th></tr>\n",
          out);
    for (int i = 0; i < rad->n; i++) {
        const struct esr_emitter_radiance *r = &rad->lights[i];
        fprintf(out, "<tr><td>%d ", r->light);
        esr_html_put_escaped(out, r->name);
        fprintf(out, "</td><td>%ld%s</td>", r->pixels,
                r->pixels == 0 ? " (not seen)" : r->eroded ? "" : " (whole mask: too small to erode)");
        esr_html_put_number(out, "%.3f", r->lum_ratio);
        esr_html_put_number(out, "%.3f", r->lum_ratio / s->shared_scale);
        esr_html_put_number(out, "%.3f", r->power_ratio);
        fputs("</tr>\n", out);
    }
    fputs("</table>\n<p>Strength: ", out);
    if (isnan(s->shared_scale))
        fputs("no light found with a strength", out);
    else
        fprintf(out, "shared scale %.3f (geometric mean of found / true luminance), worst light %d at "
                     "%.1f%% from it",
                s->shared_scale, s->worst_light, 100.0 * s->worst_relative);
    if (s->dark > 0)
        fprintf(out, ", %d light(s) found dark", s->dark);
    fputs("; ", out);
    put_counts(out, s, "; ");
    fputs(". Power is the luminance of the rendered emission summed over a light's pixels in these "
          "views (projected area x radiance, what a relight multiplies): the found light's pixels "
          "(its light ids) against the true mask's.</p>\n",
          out);
}

void esr_emitter_strength_print(FILE *out, const struct esr_emitter_radiance_result *rad,
                                const struct esr_emitter_strength *s)
{
    if (rad->n == 0)
        return;
    for (int i = 0; i < rad->n; i++) {
        const struct esr_emitter_radiance *r = &rad->lights[i];
        if (r->pixels == 0) {
            fprintf(out, "light %d (%s): in no evaluated view\n", r->light, r->name);
            continue;
        }
        fprintf(out, "light %d (%s): luminance x%.3f of the truth", r->light, r->name, r->lum_ratio);
        if (!isnan(s->shared_scale))
            fprintf(out, " (x%.3f of the shared scale)", r->lum_ratio / s->shared_scale);
        if (!isnan(r->power_ratio))
            fprintf(out, ", power x%.3f", r->power_ratio);
        fprintf(out, "%s\n", r->eroded ? "" : "; scored on its whole mask, too small to erode");
    }
    if (isnan(s->shared_scale))
        fputs("strength: no light found with a strength", out);
    else
        fprintf(out, "strength: shared scale %.3f, worst light %d %.1f%% from it", s->shared_scale,
                s->worst_light, 100.0 * s->worst_relative);
    if (s->dark > 0)
        fprintf(out, ", %d found dark", s->dark);
    fputs("; ", out);
    put_counts(out, s, ", ");
    fputs("\n", out);
}
