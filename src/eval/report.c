/* HTML evaluation report. The page is built in memory (open_memstream) and written atomically. */
#include "eval/report.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/colour.h"
#include "core/error.h"
#include "eval/curve.h"
#include "eval/html.h"
#include "io/dir.h"
#include "io/file.h"
#include "render/view.h"
#include "train/lights/lights.h"


static void put_metric_cells(FILE *out, double psnr, double ssim, double psnr_lin, double ssim_lin, double hdr)
{
    esr_html_put_number(out, "%.2f", psnr);
    esr_html_put_number(out, "%.4f", ssim);
    esr_html_put_number(out, "%.2f", psnr_lin);
    esr_html_put_number(out, "%.4f", ssim_lin);
    esr_html_put_number(out, "%.4g", hdr);
}

static const char *const metric_header =
    "<th>PSNR</th><th>SSIM</th><th>PSNR linear</th><th>SSIM linear</th><th>HDR MSE</th>";

static void put_summary(FILE *out, const struct esr_eval_result *res)
{
    fprintf(out, "<h2>Summary (%d views)</h2>\n<table><tr><th>views</th><th>n</th>%s</tr>\n", res->n_views,
            metric_header);
    const struct esr_eval_mean *m = &res->all;
    fprintf(out, "<tr><td>all</td><td>%d</td>", m->n);
    put_metric_cells(out, m->psnr, m->ssim, m->psnr_linear, m->ssim_linear, m->hdr_mse);
    fputs("</tr>\n", out);
    for (int mode = 0; mode < ESR_LIGHT_MODE_COUNT; mode++) {
        m = &res->by_mode[mode];
        if (m->n == 0)
            continue;
        fprintf(out, "<tr><td>%s</td><td>%d</td>", esr_light_mode_name((enum esr_light_mode)mode), m->n);
        put_metric_cells(out, m->psnr, m->ssim, m->psnr_linear, m->ssim_linear, m->hdr_mse);
        fputs("</tr>\n", out);
    }
    fprintf(out, "</table>\n<p>PSNR/SSIM against the ground-truth PNG composited on white; \"linear\" is the "
                 "sRGB curve applied to the linear output; HDR MSE against the ground-truth EXR on white. "
                 "PSNR is capped at %.0f dB.</p>\n",
            ESR_EVAL_PSNR_CAP);
}

/* The pooled emitter IoU and the thresholded-L_emo baseline (when scored). */
static void put_emitters(FILE *out, const struct esr_eval_result *res)
{
    if (res->n_emitter_views == 0 && res->emo_baseline.n_cameras == 0)
        return;
    fputs("<h2>Emitters</h2>\n<table><tr><th>method</th><th>IoU</th><th>views</th></tr>\n", out);
    if (res->n_emitter_views > 0) {
        fputs("<tr><td>emission E above k (lts/pdra)</td>", out);
        esr_html_put_number(out, "%.3f", esr_iou_value(&res->emitter));
        fprintf(out, "<td>%d</td></tr>\n", res->n_emitter_views);
    }
    if (res->emo_baseline.n_cameras > 0) {
        fprintf(out, "<tr><td>baseline: L_on - L_off above its best k (%.3g, chosen on these masks: "
                     "an oracle threshold)</td>",
                res->emo_baseline.k);
        esr_html_put_number(out, "%.3f", res->emo_baseline.iou);
        fprintf(out, "<td>%d cameras</td></tr>\n", res->emo_baseline.n_cameras);
    }
    fputs("</table>\n", out);
    if (res->radiance.n == 0)
        return;
    fputs("<table><tr><th>light</th><th>mean rendered emission over its true mask (linear RGB)</th>"
          "<th>true</th><th>error |found - true| / |true|</th><th>|found| / |true|</th></tr>\n", out);
    for (int k = 0; k < res->radiance.n; k++) {
        const struct esr_emitter_radiance *r = &res->radiance.lights[k];
        fprintf(out, "<tr><td>%d ", r->light);
        esr_html_put_escaped(out, r->name);
        fprintf(out, "</td><td>%.3g, %.3g, %.3g</td><td>%.3g, %.3g, %.3g</td>", r->mean[0],
                r->mean[1], r->mean[2], r->truth[0], r->truth[1], r->truth[2]);
        esr_html_put_number(out, "%.1f%%", r->error_pct);
        esr_html_put_number(out, "%.0f%%", 100.0 * r->ratio);
        fputs("</tr>\n", out);
    }
    fputs("</table>\n<p>Mean composited emission over each light's true mask (eroded by one "
          "pixel), against scene.json's emitted radiance; norms over RGB. It differs a little from "
          "the calibrated radiance of the light in \"Lights found\", which is that light's own "
          "value: the mean here also holds pixels whose emission is composited with its edge or "
          "comes from another light.</p>\n", out);
    esr_emitter_strength_put_html(out, &res->radiance, &res->strength);
}

/* esr's light split against the dataset's per-light masks (when scored). */
static void put_split(FILE *out, const struct esr_light_split *sp)
{
    if (sp->views == 0)
        return;
    fputs("<table><tr><th>dataset light</th><th>esr light</th><th>IoU</th></tr>\n", out);
    for (int k = 0; k < sp->n; k++) {
        const struct esr_light_split_row *r = &sp->rows[k];
        fprintf(out, "<tr><td>%d ", r->light);
        esr_html_put_escaped(out, r->name);
        fprintf(out, "</td><td>%d</td>", r->esr_light);
        esr_html_put_number(out, "%.3f", r->iou);
        fputs("</tr>\n", out);
    }
    fprintf(out, "</table>\n<p>Each dataset light matched to the esr light of best IoU with its "
                 "mask (%d views pooled; the masks are used by evaluation only).</p>\n",
            sp->views);
}

/* The report's folder with a trailing '/', or "" for the working directory. */
static void report_dir(const struct esr_report_spec *spec, char *dir, size_t n)
{
    snprintf(dir, n, "%s", spec->path);
    char *slash = strrchr(dir, '/');
    if (slash)
        slash[1] = '\0';
    else
        dir[0] = '\0';
}

/* Edits of light k next to the report (RUN/edits/light<k>_<what>/<view>.png, as `esr demo`
 * writes them with `esr edit`), for the first lights-on view: thumbnails with captions. */
static void put_light_edits(FILE *out, const struct esr_report_spec *spec, int k)
{
    const char *view = NULL;
    for (int i = 0; i < spec->res->n_views && !view; i++)
        if (spec->res->views[i].mode == ESR_LIGHT_ON)
            view = spec->res->views[i].name;
    if (!view)
        return;
    char dir[ESR_PATH_MAX], path[ESR_PATH_MAX * 2];
    report_dir(spec, dir, sizeof dir);
    /* the folders' names and edits are `esr demo`'s (cli/cmd_demo.c) */
    static const char *const what[] = {"off", "recoloured"};
    static const char *const caption[] = {"off", "recoloured (the hue opposite its own, saturation 1)"};
    int shown = 0;
    for (int w = 0; w < 2; w++) {
        snprintf(path, sizeof path, "%sedits/light%d_%s/%s.png", dir, k, what[w], view);
        if (!esr_file_exists(path))
            continue;
        if (!shown++) { /* the view as found, beside its edits */
            fprintf(out, "<p>Light %d edited in view ", k);
            esr_html_put_escaped(out, view);
            fputs(" (<code>esr edit --method ratio</code>):</p>\n<figure style=\"display:inline-block\">"
                  "<img src=\"", out);
            esr_html_put_escaped(out, spec->render_href);
            fputc('/', out);
            esr_html_put_escaped(out, view);
            fputs("_linear.png\" width=\"160\" alt=\"as found\"><figcaption>as found</figcaption>"
                  "</figure>\n", out); /* linear through the sRGB curve, as the edits are */
        }
        fprintf(out, "<figure style=\"display:inline-block\"><img src=\"edits/light%d_%s/", k,
                what[w]);
        esr_html_put_escaped(out, view);
        fprintf(out, ".png\" width=\"160\" alt=\"light %d %s\"><figcaption>light %d %s"
                     "</figcaption></figure>\n",
                k, what[w], k, caption[w]);
    }
}

/* The lights the model found (train/lights/lights.h), when it has any, and their edits. */
static void put_lights(FILE *out, const struct esr_report_spec *spec)
{
    const struct esr_lights *L = spec->lights;
    if (!L || L->n == 0)
        return;
    const struct esr_light_split *sp = &spec->res->split;
    fprintf(out, "<h2>Lights found (%d)</h2>\n<table><tr><th>id</th><th>centroid</th><th>area</th>"
                 "<th>points unseen</th><th>calibrated radiance (linear RGB)</th>"
                 "<th>power</th><th>strength scale</th><th>strength fitted?</th>%s</tr>\n",
            L->n, sp->views ? "<th>dataset light (evaluation)</th>" : "");
    long unseen[ESR_MAX_LIGHTS];
    esr_lights_unseen_points(L, unseen);
    for (int i = 0; i < L->n; i++) {
        const struct esr_light *l = &L->light[i];
        fprintf(out, "<tr><td>%d</td><td>%.2f, %.2f, %.2f</td><td>%.3g</td><td>%ld of %ld</td>"
                     "<td>%.3g, %.3g, %.3g</td><td>%.3g</td><td>%.2f, %.2f, %.2f</td><td>%s</td>",
                i, (double)l->centroid[0], (double)l->centroid[1], (double)l->centroid[2],
                (double)l->area, unseen[i], l->points, (double)l->radiance[0], (double)l->radiance[1],
                (double)l->radiance[2], (double)l->power, (double)l->scale[0],
                (double)l->scale[1], (double)l->scale[2],
                esr_light_strength_fitted(L, i) ? "fitted" : ESR_LIGHT_BORROWED_TEXT);
        if (sp->views) { /* the dataset lights matched to it, or none: not a light of the scene */
            int matched = 0;
            fputs("<td>", out);
            for (int k = 0; k < sp->n; k++)
                if (sp->rows[k].esr_light == i) {
                    fprintf(out, "%s%d ", matched++ ? ", " : "", sp->rows[k].light);
                    esr_html_put_escaped(out, sp->rows[k].name);
                    fprintf(out, " (IoU %.3f)", sp->rows[k].iou);
                }
            const int k = sp->dataset_light[i]; /* a second piece of a light: it follows it */
            if (!matched && k >= 0)
                fprintf(out, "part of %d (half its pixels or more in its masks)</td>", k);
            else
                fputs(matched ? "</td>" : "none: not one of the dataset's lights</td>", out);
        }
        fputs("</tr>\n", out);
    }
    fputs("</table>\n<p>Connected emitting surfaces; the unseen part (a lampshade's bottom: "
          "surface no camera sees, or that only lights-off or clipped photos show and whose "
          "light the photos ask for) emits the light's mean field; strength calibrated by the light each casts "
          "on the non-emitting surfaces (<code>esr lights RUN</code> lists them, with H, S, V as <code>esr edit --color</code> "
          "takes them; <code>--picture FILE.png</code> shows where each is). "
          "Centroid and area in scene units; radiance linear RGB on the photos' scale (a pixel's "
          "sRGB value made linear: 1 = white); "
          "power = pi x area x the radiance's luminance (Lambertian, one side); strength scale = "
          "radiance / the emission field's mean, which clipped photos pin near 1.", out);
    if (esr_lights_balanced(L)) {
        float b[3];
        esr_lights_balance_of(L, b);
        fprintf(out, " Colour set by the lights' silhouette pixels in the lights-on photos: base "
                     "colour x %.3f, %.3f, %.3f, the lights and the environment map over it.",
                (double)b[0], (double)b[1], (double)b[2]);
    }
    fputs("</p>\n", out);
    for (int i = 0; i < L->n; i++)
        put_light_edits(out, spec, i);
}

/* The surface against the dataset's mesh (eval/geometry.h), when scored. */
static void put_geometry(FILE *out, const struct esr_chamfer_result *g)
{
    if (!g)
        return;
    fprintf(out, "<h2>Geometry</h2>\n<table><tr><th>Chamfer distance</th><th>accuracy</th>"
                 "<th>completeness</th><th>samples</th></tr>\n<tr><td>%.5f</td><td>%.5f</td>"
                 "<td>%.5f</td><td>%zu</td></tr>\n</table>\n<p>Mean distance, in scene units, "
                 "from points on the marching-cubes surface to the dataset's mesh (accuracy) and "
                 "back (completeness); the Chamfer distance is their mean (RUN/eval/geometry.json)."
                 "</p>\n",
            g->chamfer, g->accuracy, g->completeness, g->n_samples);
}

/* The pooled normal error, or a line saying the dataset has no ground-truth normal maps. */
static void put_normals(FILE *out, const struct esr_eval_result *res)
{
    const struct esr_normal_stats *s = &res->normals;
    fputs("<h2>Surface normals</h2>\n", out);
    if (res->n_normal_views == 0) {
        fputs("<p>The dataset has no ground-truth normal maps (gt/c&lt;CCC&gt;_normal.exr) for these views; not "
              "scored.</p>\n",
              out);
        return;
    }
    fprintf(out, "<table><tr><th>views</th><th>mean error (deg)</th><th>median (deg)</th><th>under %.0f deg</th>"
                 "<th>coverage</th></tr>\n<tr><td>%d</td>",
            ESR_NORMAL_GOOD_DEG, res->n_normal_views);
    esr_html_put_number(out, "%.2f", s->mean_deg);
    esr_html_put_number(out, "%.2f", s->median_deg);
    esr_html_put_number(out, "%.3f", s->frac_good);
    esr_html_put_number(out, "%.3f", s->coverage);
    fprintf(out, "</tr>\n</table>\n<p>Angle between the normalised composited normal of the render and the "
                 "ground-truth world-space normal, over the %ld pixels (of %ld where the ground truth has a surface) "
                 "whose rendered opacity is over %.1f; pixels of all views pooled.</p>\n",
            s->n, s->n_gt, (double)ESR_NORMAL_MIN_OPACITY);
}

/* Training curves of the fields that the log has (none: the section is left out). */
static int put_curves(FILE *out, const char *log_path)
{
    static const char *const keys[] = {"psnr", "loss"};
    if (!log_path || !esr_file_exists(log_path))
        return ESR_OK;
    int header = 0;
    for (size_t k = 0; k < sizeof keys / sizeof keys[0]; k++) {
        struct esr_curve c;
        ESR_TRY(esr_curve_load_jsonl(log_path, keys[k], &c));
        if (c.n > 0) {
            if (!header++)
                fputs("<h2>Training</h2>\n", out);
            esr_curve_write_svg(out, &c, keys[k], 640, 200);
        }
        esr_curve_free(&c);
    }
    return ESR_OK;
}

static void put_thumb(FILE *out, const char *href, const char *name, const char *suffix)
{
    fputs("<td><a href=\"", out);
    esr_html_put_escaped(out, href);
    fputc('/', out);
    esr_html_put_escaped(out, name);
    fputs(suffix, out);
    fputs("\"><img src=\"", out);
    esr_html_put_escaped(out, href);
    fputc('/', out);
    esr_html_put_escaped(out, name);
    fputs(suffix, out);
    fputs("\" width=\"128\" alt=\"\"></a></td>", out);
}

static void put_views(FILE *out, const struct esr_report_spec *spec)
{
    const int emitters = spec->res->n_emitter_views > 0;
    fprintf(out, "<h2>Views</h2>\n<table><tr><th>view</th><th>mode</th><th>ground truth</th><th>tone-mapped</th>"
                 "<th>linear</th><th>normal</th>%s%s<th>normal error (deg)</th></tr>\n",
            emitters ? "<th>emission (with lights: over the brightest light's radiance)</th><th>emitter mask</th><th>true emitters</th>"
                       "<th>emission's effect (on - off)</th><th>true effect</th>"
                     : "",
            metric_header);
    for (int i = 0; i < spec->res->n_views; i++) {
        const struct esr_eval_view *v = &spec->res->views[i];
        fputs("<tr><td>", out);
        esr_html_put_escaped(out, v->name);
        fprintf(out, "</td><td>%s</td>", esr_light_mode_name(v->mode));
        put_thumb(out, spec->gt_href, v->name, ".png");
        put_thumb(out, spec->render_href, v->name, ".png");
        put_thumb(out, spec->render_href, v->name, "_linear.png");
        put_thumb(out, spec->render_href, v->name, "_normal.png");
        if (emitters) {
            put_thumb(out, spec->render_href, v->name, "_emission.png");
            put_thumb(out, spec->render_href, v->name, "_emitter.png");
            put_thumb(out, spec->gt_href, v->name, "_emitter_true.png");
            if (v->mode == ESR_LIGHT_ON) { /* the decomposition: off (the _off row) + effect */
                put_thumb(out, spec->render_href, v->name, "_emo.png");
                put_thumb(out, spec->gt_href, v->name, "_emo_true.png");
            } else { /* lights off: no emission to have an effect */
                fputs("<td>-</td><td>-</td>", out);
            }
        }
        put_metric_cells(out, v->psnr, v->ssim, v->psnr_linear, v->ssim_linear, v->hdr_mse);
        esr_html_put_number(out, "%.2f", v->has_normal_gt ? v->normal.mean_deg : NAN);
        fputs("</tr>\n", out);
    }
    fputs("</table>\n", out);
}

/* Frame f's ground-truth emission mask copied to gt_dir/<name>_emitter_true.png, when the
 * dataset has one. */
static int copy_true_emitters(const struct esr_report_spec *spec, const struct esr_frame *f)
{
    char src[ESR_PATH_MAX], dst[ESR_PATH_MAX];
    esr_frame_emission_path(spec->ds, f, src, sizeof src);
    if (!esr_file_exists(src))
        return ESR_OK;
    ESR_TRY(esr_view_path(dst, sizeof dst, spec->gt_dir, f->name, "_emitter_true.png"));
    return esr_file_copy(src, dst);
}

/* The true emission effect of a lights-on frame f: its EXR minus its camera's lights-off EXR
 * (both composited on white), sRGB-encoded and clipped, as gt_dir/<name>_emo_true.png; nothing
 * when either EXR is missing or f's name does not end in _on. */
static int write_true_effect(const struct esr_report_spec *spec, const struct esr_phase *ph,
                             const struct esr_frame *f)
{
    char off_name[ESR_NAME_MAX];
    if (!esr_frame_off_partner(f->name, off_name, sizeof off_name))
        return ESR_OK;
    const struct esr_frame *off = NULL;
    for (int k = 0; k < ph->n_frames && !off; k++)
        if (!strcmp(ph->frames[k].name, off_name))
            off = &ph->frames[k];
    char on_path[ESR_PATH_MAX], off_path[ESR_PATH_MAX], dst[ESR_PATH_MAX];
    esr_frame_exr_path(spec->ds, f, on_path, sizeof on_path);
    if (!off || !esr_file_exists(on_path))
        return ESR_OK;
    esr_frame_exr_path(spec->ds, off, off_path, sizeof off_path);
    if (!esr_file_exists(off_path))
        return ESR_OK;
    struct esr_image a = {0}, b = {0}, out = {0};
    int status = esr_exr_read(on_path, &a);
    if (status == ESR_OK)
        status = esr_exr_read(off_path, &b);
    if (status == ESR_OK && (a.width != b.width || a.height != b.height))
        status = ESR_FAIL("%s and %s differ in size", on_path, off_path);
    if (status == ESR_OK)
        status = esr_image_alloc(&out, a.width, a.height, 3);
    for (size_t p = 0; status == ESR_OK && p < (size_t)a.width * (size_t)a.height; p++)
        for (int c = 0; c < 3; c++) { /* premultiplied RGBA on white: rgb + 1 - A */
            const float on = a.data[p * 4 + c] + 1.0f - a.data[p * 4 + 3];
            const float of = b.data[p * 4 + c] + 1.0f - b.data[p * 4 + 3];
            const float e = on - of;
            out.data[p * 3 + c] = esr_srgb_from_linear(e < 0.0f ? 0.0f : e > 1.0f ? 1.0f : e);
        }
    if (status == ESR_OK)
        status = esr_view_path(dst, sizeof dst, spec->gt_dir, f->name, "_emo_true.png");
    if (status == ESR_OK)
        status = esr_png_write(dst, &out, 8);
    esr_image_free(&a);
    esr_image_free(&b);
    esr_image_free(&out);
    return status;
}

/* Copies of the evaluated ground-truth images, composited on white as the metrics saw them. */
static int write_gt_copies(const struct esr_report_spec *spec)
{
    const struct esr_phase *ph = &spec->ds->phases[spec->res->phase];
    ESR_TRY(esr_dir_prepare_output(spec->gt_dir));
    for (int i = 0; i < spec->res->n_views; i++) {
        const char *name = spec->res->views[i].name;
        const struct esr_frame *f = NULL;
        for (int k = 0; k < ph->n_frames && !f; k++)
            if (!strcmp(ph->frames[k].name, name))
                f = &ph->frames[k];
        if (!f)
            return ESR_FAIL("view '%s' is not in phase %s", name, esr_phase_name(spec->res->phase));
        char path[ESR_PATH_MAX];
        struct esr_image rgb = {0};
        ESR_TRY(esr_view_path(path, sizeof path, spec->gt_dir, name, ".png"));
        ESR_TRY(esr_frame_load_rgb(spec->ds, f, &rgb, NULL));
        int status = esr_png_write(path, &rgb, 8);
        esr_image_free(&rgb);
        ESR_TRY(status);
        ESR_TRY(copy_true_emitters(spec, f));
        if (spec->res->n_emitter_views > 0)
            ESR_TRY(write_true_effect(spec, ph, f));
    }
    return esr_materials_write_truth(spec->ds, &spec->res->materials, spec->gt_dir);
}

/* Links to the edit phases' pages next to the report (report_<phase>_<method>.html, as `esr eval
 * RUN --phase P --method M` writes them), when there are any. */
static void put_edit_links(FILE *out, const struct esr_report_spec *spec)
{
    static const char *const phases[] = {"test_nvi", "test_nvc", "test_nvic"};
    static const char *const methods[] = {"direct", "ratio", "finetune"};
    char dir[ESR_PATH_MAX], path[ESR_PATH_MAX * 2];
    report_dir(spec, dir, sizeof dir);
    int shown = 0;
    for (int p = 0; p < 3; p++)
        for (int m = 0; m < 3; m++) {
            snprintf(path, sizeof path, "%sreport_%s_%s.html", dir, phases[p], methods[m]);
            if (!esr_file_exists(path))
                continue;
            fprintf(out, "%s<a href=\"report_%s_%s.html\">%s, %s</a>", shown++ ? " | " : "<p>Relit: ",
                    phases[p], methods[m], phases[p], methods[m]);
        }
    if (shown)
        fputs("</p>\n", out);
}

static int put_page(FILE *out, const struct esr_report_spec *spec)
{
    fputs("<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>esr report: ", out);
    esr_html_put_escaped(out, spec->title);
    fputs("</title>\n<style>body{font-family:sans-serif;margin:1em}table{border-collapse:collapse}"
          "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}img{display:block}</style>\n"
          "</head><body>\n<h1>",
          out);
    esr_html_put_escaped(out, spec->title);
    fprintf(out, "</h1>\n<p>phase %s of dataset ", esr_phase_name(spec->res->phase));
    esr_html_put_escaped(out, spec->ds->root);
    fputs("</p>\n", out);
    put_edit_links(out, spec);
    put_summary(out, spec->res);
    put_geometry(out, spec->geometry);
    put_normals(out, spec->res);
    esr_materials_put_html(out, &spec->res->materials, spec->render_href, spec->gt_href);
    put_emitters(out, spec->res);
    put_lights(out, spec);
    put_split(out, &spec->res->split);
    ESR_TRY(put_curves(out, spec->train_log));
    put_views(out, spec);
    fputs("</body></html>\n", out);
    return ESR_OK;
}

int esr_report_write(const struct esr_report_spec *spec)
{
    ESR_TRY(write_gt_copies(spec));
    char *text = NULL;
    size_t size = 0;
    FILE *out = open_memstream(&text, &size);
    if (!out)
        return ESR_FAIL("out of memory building '%s'", spec->path);
    int status = put_page(out, spec);
    if (ferror(out) && status == ESR_OK)
        status = ESR_FAIL("out of memory building '%s'", spec->path);
    fclose(out);
    if (status == ESR_OK)
        status = esr_file_write_atomic(spec->path, text, size);
    free(text);
    return status;
}
